"""The existential split of derived predicates (compile/split_axioms.py) and the fd backend's
use of it when its heuristics' negated axioms would be large (planners/fd_negation.py)."""

from __future__ import annotations

from ssr_compile import syntax as S
from ssr_compile.compile.split_axioms import negatively_needed, split_axioms
from ssr_compile.parse import parse_domain, parse_problem
from ssr_compile.printer import to_text

# A camera sees the goal unless a box stands at a pose that hides it; every box has one such
# pose among its poses.  ``look`` reads ``(not (occluded))``: Fast Downward's heuristics need
# the negation of occluded's rules, one per combination of every box's other poses.
DOMAIN = """
(define (domain clutter)
  (:requirements :strips :negative-preconditions :derived-predicates
                 :existential-preconditions :equality :action-costs)
  (:predicates (at ?o ?p) (pose ?o ?p) (hides ?o ?p) (box ?o) (seen) (occluded) (stuck ?o)
               (ontop ?o2 ?p2 ?o))
  (:functions (total-cost) - number)
  (:derived (occluded)
    (exists (?o2 ?p2) (and (box ?o2) (at ?o2 ?p2) (hides ?o2 ?p2))))
  (:derived (stuck ?o)
    (exists (?o2 ?p2) (and (box ?o) (box ?o2) (not (= ?o ?o2)) (at ?o2 ?p2) (ontop ?o2 ?p2 ?o))))
  (:action move
    :parameters (?o ?p1 ?p2)
    :precondition (and (box ?o) (at ?o ?p1) (pose ?o ?p2) (not (stuck ?o)))
    :effect (and (at ?o ?p2) (not (at ?o ?p1)) (increase (total-cost) 1)))
  (:action look
    :parameters ()
    :precondition (not (occluded))
    :effect (and (seen) (increase (total-cost) 1))))
"""


def problem_text(boxes: int, poses: int, hiding: int = 1) -> str:
    """``boxes`` boxes of ``poses`` poses each; pose 0 hides, the last stands on the next box;
    the first ``hiding`` boxes start at pose 0, the others at pose 1."""
    objects, init = [], []
    for b in range(boxes):
        objects.append(f"b{b}")
        init.append(f"(box b{b}) (hides b{b} p{b}-0) (at b{b} p{b}-{0 if b < hiding else 1})")
        # its last pose stands on the next box, which cannot move then
        init.append(f"(ontop b{b} p{b}-{poses - 1} b{(b + 1) % boxes})")
        for p in range(poses):
            objects.append(f"p{b}-{p}")
            init.append(f"(pose b{b} p{b}-{p})")
    return (
        f"(define (problem clutter-{boxes}) (:domain clutter) (:objects {' '.join(objects)})\n"
        f"  (:init {' '.join(init)} (= (total-cost) 0))\n"
        "  (:goal (seen)) (:metric minimize (total-cost)))"
    )


def test_the_split_writes_each_existential_at_the_object_its_fluent_atom_is_about():
    domain = parse_domain(DOMAIN)
    problem = parse_problem(problem_text(3, 3))
    assert negatively_needed(domain, problem) == {"occluded", "stuck"}
    split = split_axioms(domain, problem)
    bodies = {ax.name: ax.body for ax in split.domain.axioms}
    assert set(bodies) == {"occluded", "occluded-per-o2", "stuck", "stuck-per-o2"}
    # occluded: exists ?o2 of the helper, the helper keeps exists ?p2 and the conditions
    assert bodies["occluded"] == S.Exists(
        (S.Typed("?o2"),), S.Atom("occluded-per-o2", (S.Var("?o2"),))
    )
    helper = next(ax for ax in split.domain.axioms if ax.name == "stuck-per-o2")
    assert [p.name for p in helper.parameters] == ["?o", "?o2"]
    assert isinstance(helper.body, S.Exists) and [p.name for p in helper.body.params] == ["?p2"]
    assert {p.name for p in split.domain.predicates} >= {"occluded-per-o2", "stuck-per-o2"}
    # the text reads back as it was written
    assert parse_domain(to_text(split.domain)) == split.domain


def test_only_predicates_read_false_are_split_and_a_domain_without_them_is_returned_as_is():
    domain = parse_domain(
        DOMAIN.replace("(not (occluded))", "(seen)").replace("(not (stuck ?o))", "(box ?o)")
    )
    problem = parse_problem(problem_text(2, 2))
    assert negatively_needed(domain, problem) == set()
    assert split_axioms(domain, problem).domain is domain
    # a body with two fluent atoms is left whole: the split would not be over one variable
    two = parse_domain(
        DOMAIN.replace("(hides ?o2 ?p2))))\n  (:derived (stuck", "(seen))))\n  (:derived (stuck")
    )
    split = split_axioms(two, problem)
    assert "occluded-per-o2" not in {ax.name for ax in split.domain.axioms}
    assert "stuck-per-o2" in {ax.name for ax in split.domain.axioms}


def test_fd_translates_again_split_when_the_negated_rules_would_be_many():
    from ssr_compile.planners import fd

    planner = fd.FastDownward()
    domain = parse_domain(DOMAIN)
    # seven boxes of eight poses: 7^7 negated rules for occluded as written
    big = parse_problem(problem_text(7, 8, hiding=2))
    result = planner.solve(domain, big, time_limit=60)
    assert result.status == "solved"
    assert result.cost == 3  # move the two boxes that hide, look
    before, after = planner.last_split
    assert before > fd.NEGATED_RULES > after
    assert before >= 7**7


def test_the_split_task_has_the_plans_of_the_task_as_written(monkeypatch):
    from ssr_compile.planners import fd

    domain = parse_domain(DOMAIN)
    for boxes, poses, hiding in ((4, 3, 2), (3, 4, 3), (4, 4, 2), (5, 4, 2)):
        problem = parse_problem(problem_text(boxes, poses, hiding))
        costs = {}
        for limit in (0, float("inf")):
            monkeypatch.setattr(fd, "NEGATED_RULES", limit)
            planner = fd.FastDownward("opt")
            result = planner.solve(domain, problem, time_limit=60)
            assert result.status == "solved"
            assert (planner.last_split is not None) == (limit == 0)
            costs[limit] = result.cost
        assert costs[0] == costs[float("inf")] == hiding + 1


def test_compile_split_axioms_writes_the_split_task(tmp_path):
    # `ssr-compile compile --split-axioms`: what the fd backend plans on, for a user who runs
    # Fast Downward on the written files.  The same actions and problem, helper axioms for
    # the predicates read false, and Fast Downward's translator finds the same ground actions.
    from ssr_compile.cli.app import main
    from ssr_compile.planners.fd import _translate

    dirs = {}
    for split in (False, True):
        out = tmp_path / ("split" if split else "written")
        args = ["compile", "kitchen", "--problem", "cook", "--for", "fd", "--level", "5"]
        args += ["-o", str(out)]
        assert main(args + (["--split-axioms"] if split else [])) == 0
        dirs[split] = out
    written = parse_domain((dirs[False] / "domain.pddl").read_text())
    split = parse_domain((dirs[True] / "domain.pddl").read_text())
    assert (dirs[False] / "problem.pddl").read_text() == (dirs[True] / "problem.pddl").read_text()
    assert [a.name for a in split.actions] == [a.name for a in written.actions]
    helpers = {ax.name for ax in split.axioms} - {ax.name for ax in written.axioms}
    assert {"unsafe-per-o2", "boccluded-per-o2"} <= helpers
    info = {
        k: _translate(str(d / "domain.pddl"), str(d / "problem.pddl"), str(tmp_path / f"{k}.sas"))
        for k, d in dirs.items()
    }
    assert info[True]["operators"] == info[False]["operators"] > 0  # (309 at level 5)
    assert info[True]["unsolvable"] is None
    # (on a task this small the split has more negated rules, 25 against 2: the fd backend
    # splits only above fd.NEGATED_RULES, and keeps the translation with fewer)
