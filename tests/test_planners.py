"""Planner backends: each built-in on small fixtures, costs, axioms, unsolvable tasks, time
limits, name mapping, cost bounds and the entry-point registry."""

from __future__ import annotations

import importlib.metadata
import time
from pathlib import Path

import pytest

from ssr_compile.compile.rename import rename_task
from ssr_compile.errors import SSRError
from ssr_compile.parse import parse_text
from ssr_compile.planners import (
    GROUP,
    Capabilities,
    PlanResult,
    _installed,
    available_planners,
    describe_planners,
    get_planner,
)
from ssr_compile.planners.validate import validate_plan

FIXTURES = Path(__file__).parent / "fixtures" / "planners"
BUILTINS = ["fd", "fd:opt", "pyperplan", "up:fast-downward", "up:pyperplan"]
_CACHE: dict[str, object] = {}


def load(domain: str, problem: str):
    return (
        parse_text((FIXTURES / f"{domain}-domain.pddl").read_text(), f"{domain}-domain.pddl"),
        parse_text((FIXTURES / f"{problem}-problem.pddl").read_text(), f"{problem}-problem.pddl"),
    )


def planner(spec: str):
    if spec not in _CACHE:
        _CACHE[spec] = get_planner(spec)
    return _CACHE[spec]


def assert_valid(domain, problem, result: PlanResult) -> None:
    assert result.status == "solved", result.message
    ok, why = validate_plan(domain, problem, result.actions)
    assert ok, f"{result.planner} returned an invalid plan: {why}\n{result.plan_text()}"


@pytest.mark.parametrize("spec", BUILTINS)
def test_blocks_solved_and_valid(spec):
    domain, problem = load("blocks", "blocks")
    result = planner(spec).solve(domain, problem, time_limit=20)
    assert_valid(domain, problem, result)
    assert result.cost == len(result.actions) == 6
    assert result.planner == spec and result.time > 0


@pytest.mark.parametrize("spec", ["fd", "pyperplan", "up:fast-downward"])
def test_goal_already_true_gives_empty_plan(spec):
    domain, problem = load("blocks", "blocks-solved")
    result = planner(spec).solve(domain, problem, time_limit=20)
    assert (result.status, result.actions, result.cost) == ("solved", [], 0)


@pytest.mark.parametrize("spec", ["fd", "fd:opt", "up:fast-downward-opt"])
def test_cheaper_plan_chosen_with_static_cost_function(spec):
    domain, problem = load("travel", "travel")
    result = planner(spec).solve(domain, problem, time_limit=20)
    assert_valid(domain, problem, result)
    assert [name for name, _ in result.actions] == ["drive"] * 3
    assert result.cost == 4


def test_up_fast_downward_runs_the_cost_aware_search_of_fd():
    """unified-planning's engine defaults to LAMA's first iteration, which plans with unit
    costs and flies (one action, cost 10); the backend asks it for fd's cost-aware search,
    which drives (three actions, cost 4).  With the engine's own alias it flies again, and the
    reported cost is still the metric's, priced from the problem's cost function values."""
    from ssr_compile.planners.costs import plan_cost

    domain, problem = load("travel", "travel")
    result = planner("up:fast-downward").solve(domain, problem, time_limit=20)
    assert_valid(domain, problem, result)
    assert [name for name, _ in result.actions] == ["drive"] * 3
    assert result.cost == 4
    lama = get_planner("up:fast-downward", params={"fast_downward_alias": "lama-first"})
    result = lama.solve(domain, problem, time_limit=20)
    assert_valid(domain, problem, result)
    assert result.actions == [("fly", ("home", "d"))]
    assert result.cost == plan_cost(domain, problem, result.actions) == 10


def test_fd_derived_predicate():
    domain, problem = load("reach", "reach")
    result = planner("fd").solve(domain, problem, time_limit=20)
    assert result.status == "solved", result.message
    assert result.actions == [("move", ("p1", "p2")), ("move", ("p2", "p3"))]
    opt = planner("fd:opt").solve(domain, problem, time_limit=20)  # LM-cut falls back to blind
    assert opt.status == "solved" and opt.cost == 2, opt.message


@pytest.mark.parametrize("spec", ["pyperplan", "up:fast-downward"])
def test_unsupported_features_give_an_error_result(spec):
    domain, problem = load("reach", "reach")
    result = planner(spec).solve(domain, problem, time_limit=20)
    assert result.status == "error" and "derived predicates" in result.message


@pytest.mark.parametrize("spec", ["fd", "fd:opt", "pyperplan", "up:fast-downward"])
@pytest.mark.parametrize("problem", ["blocks-unreachable", "pigeons-small"])
def test_unsolvable(spec, problem):
    domain, task = load(problem.split("-")[0], problem)
    result = planner(spec).solve(domain, task, time_limit=20)
    assert result.status == "unsolvable", result.message
    assert result.actions is None and result.message


@pytest.mark.parametrize("spec", ["fd", "pyperplan", "up:fast-downward"])
def test_time_limit_honoured(spec):
    domain, problem = load("pigeons", "pigeons-hard")
    limit = 1.5
    start = time.monotonic()
    result = planner(spec).solve(domain, problem, time_limit=limit)
    elapsed = time.monotonic() - start
    assert result.status == "timeout", result.message
    assert limit - 0.1 <= elapsed <= limit + 1.0
    assert result.time == pytest.approx(elapsed, abs=0.2)


@pytest.mark.parametrize("spec", ["fd", "up:fast-downward", "up:pyperplan", "pyperplan"])
def test_clashing_names_mapped_back(spec):
    domain, problem = load("clash", "clash")
    result = planner(spec).solve(domain, problem, time_limit=20)
    assert_valid(domain, problem, result)
    names = {name for name, _ in result.actions}
    assert "carry" in names and names <= {"carry", "drop", "walk"}
    assert {a for _, args in result.actions for a in args} <= {"box", "drop", "kitchen", "walk"}


def test_renaming_separates_namespaces_and_maps_back():
    domain, problem = load("clash", "clash")
    renamed = rename_task(domain, problem)
    dom, renaming = renamed.domain, renamed.renaming
    names = [a.name for a in dom.actions] + [p.name for p in dom.predicates]
    names += [t.name for t in dom.types]
    assert len(names) == len(set(names))
    renamed = [(renaming.actions.get("carry", "carry"), (renaming.objects["box"], "kitchen"))]
    assert renaming.plan_back(renamed) == [("carry", ("box", "kitchen"))]


@pytest.mark.parametrize("spec", ["fd", "fd:opt", "up:fast-downward-opt"])
def test_cost_bound(spec):
    domain, problem = load("travel", "travel")
    below = planner(spec).solve(domain, problem, time_limit=20, cost_bound=5)
    assert below.status == "solved" and below.cost == 4
    tight = planner(spec).solve(domain, problem, time_limit=20, cost_bound=4)
    assert tight.status == "unsolvable" and "bound" in tight.message


def test_cost_bound_checked_after_the_fact_for_pyperplan():
    domain, problem = load("blocks", "blocks")
    result = planner("pyperplan").solve(domain, problem, time_limit=20, cost_bound=6)
    assert result.status == "unsolvable" and "bound" in result.message


def test_unknown_planner_lists_installed():
    with pytest.raises(SSRError) as err:
        get_planner("no-such-planner")
    assert "fd" in str(err.value) and "pyperplan" in str(err.value)
    with pytest.raises(SSRError):
        get_planner("up:no-such-engine")
    with pytest.raises(SSRError):
        get_planner("fd:no-such-search")


class _Echo:
    """A third-party planner that returns a fixed plan."""

    name = "echo"
    capabilities = Capabilities(False, False, False, False, False, False)

    def solve(self, domain, problem, time_limit=60.0, cost_bound=None):
        return PlanResult("solved", [], 0, 0.0, self.name)


def make_echo(variant=None, **options):
    return _Echo()


def test_third_party_entry_point(monkeypatch, request):
    real = importlib.metadata.entry_points
    extra = importlib.metadata.EntryPoint(name="echo", value=f"{__name__}:make_echo", group=GROUP)

    def entry_points(**params):
        found = list(real(**params))
        return found + [extra] if params.get("group") == GROUP else found

    monkeypatch.setattr("ssr_compile.planners.entry_points", entry_points)
    _installed.cache_clear()  # entry points are read once per process
    request.addfinalizer(_installed.cache_clear)
    assert "echo" in available_planners() and "fd" in available_planners()
    echo = get_planner("echo")
    domain, problem = load("blocks", "blocks-solved")
    assert echo.solve(domain, problem).status == "solved"
    rows = {row["name"]: row for row in describe_planners()}
    assert rows["echo"]["entry_point"].endswith(":make_echo")


def test_a_builtin_name_loads_without_reading_entry_points_and_cannot_be_shadowed(
    monkeypatch, request
):
    read = []
    shadow = importlib.metadata.EntryPoint(name="fd", value=f"{__name__}:make_echo", group=GROUP)

    def entry_points(**params):
        read.append(params)
        return [shadow] if params.get("group") == GROUP else []

    monkeypatch.setattr("ssr_compile.planners.entry_points", entry_points)
    _installed.cache_clear()
    request.addfinalizer(_installed.cache_clear)
    assert get_planner("fd").name == "fd" and get_planner("fd:opt").name == "fd:opt"
    assert read == []  # the metadata scan is for third-party names only
    assert available_planners()["fd"].value == "ssr_compile.planners.fd:make_planner"
    with pytest.raises(SSRError, match="unknown planner 'nope'"):
        get_planner("nope")
    assert read  # an unknown name does look at what is installed


def test_describe_lists_builtins_with_capabilities():
    rows = {row["name"]: row for row in describe_planners()}
    assert {"fd", "fd:opt", "pyperplan", "up:fast-downward"} <= set(rows)
    assert rows["fd"]["capabilities"]["axioms"] is True
    assert rows["pyperplan"]["capabilities"]["negative_preconditions"] is False
    assert rows["fd:opt"]["capabilities"]["optimal"] is True


def test_validator_rejects_a_bad_plan():
    domain, problem = load("blocks", "blocks")
    ok, why = validate_plan(domain, problem, [("stack", ("a", "b"))])
    assert not ok
    assert "INAPPLICABLE_ACTION" in why and "stack(a, b)" in why  # which step fails, and why


def test_fd_refuses_fractional_costs_with_a_message():
    domain, problem = load("travel", "travel")
    text = (FIXTURES / "travel-problem.pddl").read_text().replace("c d) 2)", "c d) 2.5)")
    problem = parse_text(text, "travel-fractional.pddl")
    result = planner("fd").solve(domain, problem, time_limit=20)
    assert result.status == "error" and "integer costs" in result.message


def _nap(seconds):
    time.sleep(seconds)
    return seconds


def test_forked_worker_killed_on_timeout_and_replaced():
    from ssr_compile.planners.proc import ForkedWorker

    worker = ForkedWorker(_nap)
    try:
        assert worker.call((0.0,), timeout=5) == ("ok", 0.0)
        first = worker.pid
        start = time.monotonic()
        assert worker.call((30,), timeout=0.5) == ("timeout", None)
        assert time.monotonic() - start < 1.5 and worker.pid is None
        assert worker.call((0.0,), timeout=5) == ("ok", 0.0) and worker.pid != first
    finally:
        worker.close()


def test_fd_first_call_with_a_fresh_translator_worker():
    """The search binary is started while the translator works; a translator worker forked
    meanwhile must not keep the binary's input open (it waited for the end of its input until
    the time limit)."""
    from ssr_compile.planners import fd

    domain, problem = load("blocks", "blocks")
    for _ in range(3):
        fd._TRANSLATOR.close()  # the next call forks the worker during the call
        result = planner("fd").solve(domain, problem, time_limit=10)
        assert_valid(domain, problem, result)


def test_fd_opt_search_chosen_after_translation_when_the_guess_was_wrong(monkeypatch):
    """A derived predicate the goal never needs is dropped by the translator: the binary
    started for the blind search (axioms expected) is killed unused and LM-cut's runs."""
    from ssr_compile.planners import proc

    text = (FIXTURES / "reach-domain.pddl").read_text()
    domain = parse_text(text.replace("(not (arrived))", "(conn ?a ?b)"), "reach-domain.pddl")
    problem = parse_text(
        (FIXTURES / "reach-problem.pddl")
        .read_text()
        .replace("(:goal (arrived))", "(:goal (at p4))"),
        "reach-problem.pddl",
    )
    started: list = []
    real = proc.StartedCommand

    class Recording(real):
        def __init__(self, cmd, **kw):
            super().__init__(cmd, **kw)
            started.append((cmd, self))

    monkeypatch.setattr(proc, "StartedCommand", Recording)
    result = get_planner("fd:opt").solve(domain, problem, time_limit=20)
    assert result.status == "solved", result.message
    assert result.actions == [
        ("move", ("p1", "p2")),
        ("move", ("p2", "p3")),
        ("move", ("p3", "p4")),
    ]
    ((cmd, command),) = started
    assert "astar(blind())" in cmd
    assert command.proc.returncode is not None and command.proc.returncode != 0  # killed


def test_started_command_fed_later_killed_at_its_limit_or_unused(tmp_path):
    from ssr_compile.planners.proc import StartedCommand

    data = tmp_path / "input"
    data.write_bytes(b"x" * 200_000)  # more than a pipe holds: fed while it is read
    log = tmp_path / "log"
    counting = StartedCommand(["wc", "-c"], cwd=str(tmp_path), log_path=str(log))
    assert counting.finish(str(data), 10) == 0
    assert log.read_text().split() == ["200000"]

    slow = StartedCommand(["sleep", "30"], cwd=str(tmp_path))
    start = time.monotonic()
    assert slow.finish(str(data), 0.3) is None
    assert time.monotonic() - start < 5 and slow.proc.returncode is not None

    unused = StartedCommand(["cat"], cwd=str(tmp_path))
    unused.cancel()
    assert unused.proc.returncode is not None
    unused.cancel()  # twice is harmless


def test_fd_translator_timeout_kills_the_started_search_too():
    """A task whose translation outlasts the limit (a four-parameter action over 40 objects:
    2.5 million ground actions): a timeout within the limit, and neither the translator nor
    the search binary started beside it is left running."""
    import os

    from ssr_compile.planners.proc import _descendants

    objects = " ".join(f"o{i}" for i in range(40))
    domain = parse_text(
        "(define (domain wide) (:requirements :strips) (:predicates (p ?a ?b ?c ?d) (done))"
        " (:action a :parameters (?a ?b ?c ?d) :precondition (and)"
        " :effect (and (p ?a ?b ?c ?d))))",
        "wide-domain.pddl",
    )
    problem = parse_text(
        f"(define (problem w) (:domain wide) (:objects {objects}) (:init) (:goal (done)))",
        "wide-problem.pddl",
    )
    start = time.monotonic()
    result = get_planner("fd").solve(domain, problem, time_limit=1.0)
    assert result.status == "timeout" and "translator" in result.message, result.message
    assert time.monotonic() - start < 3.0
    names = []
    for pid in _descendants(os.getpid()):
        try:
            names.append(open(f"/proc/{pid}/comm").read().strip())
        except OSError:
            pass
    assert "downward" not in names, names


def test_fd_reports_its_translation_and_search_within_the_call():
    domain, problem = load("blocks", "blocks")
    result = get_planner("fd").solve(domain, problem, time_limit=20)
    assert result.solved
    assert result.translate_time > 0 and result.search_time > 0
    assert result.translate_time + result.search_time <= result.time
    other = planner("pyperplan").solve(domain, problem, time_limit=20)
    assert other.solved and other.translate_time == other.search_time == 0.0
