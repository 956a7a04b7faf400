"""The replanning state (Algorithm 1's ``a_prev`` and ``f_prev``, and what the solver already
evaluated) has one type, :class:`ssr_compile.solver.ReplanState`: ``solve(..., state)`` gives
what the same state given by hand gives, and the policy uses the solver's type."""

from __future__ import annotations

import inspect

from ssr_compile.streams.environments import progress

from ssr_compile import policy, solver
from ssr_compile.policy import constant_facts
from ssr_compile.solver import ReplanState, SolveOptions, solve, with_kept


def _outcome(solution):
    """What a solve call decides (not how long it took)."""
    st = solution.stats
    return (
        solution.status,
        None if solution.plan is None else [(s.name, s.args, s.deferred) for s in solution.plan],
        solution.cost,
        solution.certificate,
        [(str(r.instance), r.outputs) for r in solution.evaluated],
        (st.iterations, st.levels, st.planner_calls, st.sizes),
        {k: (v.calls, v.successes, v.failures) for k, v in st.streams.items()},
    )


def _first_plan():
    agent = progress.make_episode(None, 0).agent
    problem, module = agent.problem()
    first = solve(agent.domain, agent.streams, problem, module, SolveOptions(defer=True))
    assert first.solved
    return agent, problem, first


def test_the_policy_uses_the_solvers_replanning_state():
    assert policy.ReplanState is solver.ReplanState
    # a call reads solve(domain, streams, problem, module, options, state)
    params = list(inspect.signature(solve).parameters)
    assert params == ["domain", "streams", "problem", "module", "options", "state"]


def test_state_gives_what_the_kept_facts_added_by_hand_give():
    agent, problem, first = _first_plan()
    grasps = {o for r in first.evaluated if r.instance.stream == "sample-grasp" for o in r.outputs}
    constants = frozenset({o.name for o in problem.objects if agent.is_constant(o.name)} | grasps)
    facts, values = constant_facts(first, problem, constants.__contains__)
    tail = [(s.name, tuple(s.args)) for s in first.plan]
    state = ReplanState(tail, constants, facts, values)

    # s ∪ f_prev by hand, then a state with the tail and constants only
    _, module = agent.problem()
    kept_problem, kept_module = with_kept(problem, module, state)
    by_keywords = solve(
        agent.domain,
        agent.streams,
        kept_problem,
        kept_module,
        SolveOptions(defer=True),
        ReplanState(tail, constants),
    )
    _, module = agent.problem()
    by_state = solve(agent.domain, agent.streams, problem, module, SolveOptions(defer=True), state)
    assert by_state.solved and _outcome(by_state) == _outcome(by_keywords)
    assert [s.name for s in by_state.plan] == [name for name, _ in tail]  # the tail's structure


def test_evaluated_results_and_values_travel_in_the_state():
    agent, problem, first = _first_plan()
    kept = [r for r in first.evaluated if not r.optimistic]
    _, module = agent.problem()
    by_keywords = solve(
        agent.domain,
        agent.streams,
        problem,
        module,
        state=ReplanState(evaluated=kept, values=first.values),
    )
    _, module = agent.problem()
    state = ReplanState(evaluated=kept, values=first.values)
    by_state = solve(agent.domain, agent.streams, problem, module, state=state)
    assert by_state.solved and _outcome(by_state) == _outcome(by_keywords)
    assert by_state.values is first.values and by_state.evaluated[: len(kept)] == kept
