"""Issue 9 items 3 and 4: one base class for planners run outside the process (a backend is
its command line and its plan reader), and renaming for planners done once, in compile/."""

from __future__ import annotations

import sys

from ssr_compile.compile.rename import rename_task
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.planners import Capabilities
from ssr_compile.planners.external import ExternalPlanner, Stop, read_plan_file

DOMAIN = """(define (domain move)
  (:requirements :strips :action-costs)
  (:predicates (at ?x) (link ?x ?y))
  (:functions (total-cost))
  (:action go :parameters (?x ?y) :precondition (and (at ?x) (link ?x ?y))
   :effect (and (at ?y) (not (at ?x)) (increase (total-cost) 2))))"""
PROBLEM = """(define (problem {name}) (:domain move) (:objects a b)
  (:init (at a) (link a b) (= (total-cost) 0)) (:goal (at b))
  (:metric minimize (total-cost)))"""

WRITER = "import sys; open(sys.argv[1], 'w').write('(go a b)\\n; cost = 2\\n')"


class EchoPlanner(ExternalPlanner):
    """A third-party backend in a few lines: a command line and a plan reader."""

    name = "echo"
    capabilities = Capabilities(
        costs=True,
        axioms=False,
        negative_preconditions=False,
        disjunction=False,
        quantifiers=False,
        conditional_effects=False,
    )

    def command(self, job):
        return [sys.executable, "-c", WRITER, job.plan]

    def read_plan(self, job):
        return read_plan_file(job.plan)


def _task(name="move-1"):
    return parse_domain(DOMAIN), parse_problem(PROBLEM.format(name=name))


def test_a_backend_is_a_command_and_a_plan_reader(tmp_path):
    result = EchoPlanner().solve(*_task(), time_limit=30)
    assert result.solved and result.actions == [("go", ("a", "b"))] and result.cost == 2
    refused = EchoPlanner().solve(*_task(), time_limit=30, cost_bound=2)
    assert refused.status == "unsolvable"  # plans must cost less than the bound


def test_time_limit_and_crash_are_answers_not_exceptions():
    class Sleeper(EchoPlanner):
        def command(self, job):
            return [sys.executable, "-c", "import time; time.sleep(30)"]

    class Crasher(EchoPlanner):
        def command(self, job):
            return [sys.executable, "-c", "raise SystemExit('segfault, say')"]

    slow = Sleeper().solve(*_task(), time_limit=0.5)
    assert slow.status == "timeout" and slow.time < 10
    crash = Crasher().solve(*_task(), time_limit=30)
    assert crash.status == "error" and "exited with code 1" in crash.message
    assert "segfault, say" in crash.detail


def test_stop_answers_with_its_status():
    class Refuser(EchoPlanner):
        def run(self, job):
            raise Stop("unsolvable", "proved unsolvable")

    r = Refuser().solve(*_task(), time_limit=30)
    assert (r.status, r.message) == ("unsolvable", "proved unsolvable")


def test_unsafe_problem_name_is_renamed():
    domain, problem = _task("37")
    renamed = rename_task(domain, problem)
    assert renamed.problem.name == "x37" and renamed.renaming
    same = rename_task(*_task())
    assert same.problem.name == "move-1" and not same.renaming


def test_renaming_lives_in_compile_and_backends_do_not_rename():
    import pathlib

    import ssr_compile.planners as planners

    folder = pathlib.Path(planners.__file__).parent
    assert not (folder / "rename.py").exists()
    callers = {p.name for p in folder.glob("*.py") if "rename_task(" in p.read_text()}
    assert callers <= {"external.py", "validate.py"}  # the base class, once; not a backend
