"""Closed-loop environments of the shipped examples (paper §III, Algorithm 1): the true world
a plan is executed in and the agent that keeps the robot's belief and states the next problem.

Each module has a ``make_episode(problem, seed)`` that an example's ``example.toml`` names as
its ``environment`` (:class:`ssr_compile.policy.Episode`).  The stream bindings the agents plan
with stay in :mod:`ssr_compile.streams`.
"""
