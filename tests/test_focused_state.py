"""The replanning state (Algorithm 1's ``a_prev`` and ``f_prev``, and what the solver already
evaluated) has one type, :class:`ssr_compile.focused.ReplanState`: ``solve(state=...)`` gives
what the keywords it replaces give, and the policy uses the solver's type."""

from __future__ import annotations

import inspect

from ssr_compile.streams.environments import progress

from ssr_compile import focused, policy
from ssr_compile.focused import ReplanState, solve, with_kept
from ssr_compile.policy import constant_facts


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
    first = solve(agent.domain, agent.streams, problem, module, defer=True)
    assert first.solved
    return agent, problem, first


def test_the_policy_uses_the_solvers_replanning_state():
    assert policy.ReplanState is focused.ReplanState
    assert policy._with_kept is focused.with_kept
    # the older keywords still work beside the state
    params = inspect.signature(solve).parameters
    for name in ("plan_tail", "is_constant", "evaluated", "values", "state"):
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY


def test_state_gives_what_the_separate_keywords_give():
    agent, problem, first = _first_plan()
    grasps = {o for r in first.evaluated if r.instance.stream == "sample-grasp" for o in r.outputs}
    constants = frozenset({o.name for o in problem.objects if agent.is_constant(o.name)} | grasps)
    facts, values = constant_facts(first, problem, constants.__contains__)
    tail = [(s.name, tuple(s.args)) for s in first.plan]
    state = ReplanState(tail, constants, facts, values)

    # the policy's older way: s ∪ f_prev by hand, then the tail and constants as keywords
    _, module = agent.problem()
    kept_problem, kept_module = with_kept(problem, module, state)
    by_keywords = solve(
        agent.domain,
        agent.streams,
        kept_problem,
        kept_module,
        defer=True,
        plan_tail=tail,
        is_constant=constants.__contains__,
    )
    _, module = agent.problem()
    by_state = solve(agent.domain, agent.streams, problem, module, defer=True, state=state)
    assert by_state.solved and _outcome(by_state) == _outcome(by_keywords)
    assert [s.name for s in by_state.plan] == [name for name, _ in tail]  # the tail's structure


def test_evaluated_results_and_values_travel_in_the_state():
    agent, problem, first = _first_plan()
    kept = [r for r in first.evaluated if not r.optimistic]
    _, module = agent.problem()
    by_keywords = solve(
        agent.domain, agent.streams, problem, module, evaluated=kept, values=first.values
    )
    _, module = agent.problem()
    state = ReplanState(evaluated=kept, values=first.values)
    by_state = solve(agent.domain, agent.streams, problem, module, state=state)
    assert by_state.solved and _outcome(by_state) == _outcome(by_keywords)
    assert by_state.values is first.values and by_state.evaluated[: len(kept)] == kept
