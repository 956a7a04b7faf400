"""Fast Downward on a kitchen episode's task whose heuristics need the most negated axiom rules:
the task as written against the task with its derived predicates' existentials split
(ssr_compile/compile/split_axioms.py; the fd backend's second translation).

The episode (a kitchen task or a task file, one seed) runs with the policy of ``ssr-compile
run`` for ``--time-limit`` seconds of planning; every task handed to ``fd`` is kept when the
estimate of its negated rules (ssr_compile/planners/fd_negation.py) is the largest so far.  That
task is then solved ``--runs`` times each way, interleaved: as written (no second translation)
and as the backend solves it (split above ``fd.NEGATED_RULES``).  Medians are printed with the
ratio written/split.  Counts (negated rules, ground actions, plan cost) do not depend on the
machine.

Run: python bench/negation_bench.py                        # cook, seed 0, 60 s, 3 runs each
     python bench/negation_bench.py --full                 # 300 s of the episode, 5 runs each
     ssr-compile tasks generate --kind cook --objects 8 --hiders 6 -o /tmp/k6.toml
     python bench/negation_bench.py --task /tmp/k6.toml --seed 0 --time-limit 100
"""

from __future__ import annotations

import argparse
import math
import statistics


def capture(task: str, seed: int, time_limit: float) -> tuple | None:
    """``(domain, problem, estimated negated rules)`` of the episode's task with the most
    negated rules as written, or None when fd was not called."""
    from ssr_compile.streams.environments.kitchen import make_episode

    from ssr_compile.planners import fd
    from ssr_compile.policy import PolicySettings, run_policy

    best: list = [None]
    solve = fd.FastDownward.solve

    def recording(self, domain, problem, *args, **kwargs):
        result = solve(self, domain, problem, *args, **kwargs)
        rules = self.last_negated_rules
        if rules is not None and (best[0] is None or rules > best[0][2]):
            best[0] = (domain, problem, rules)
        return result

    fd.FastDownward.solve = recording
    episode = make_episode(task, seed)
    try:
        result = run_policy(episode, PolicySettings(variant="both", budget=time_limit))
        print(
            f"episode: {result.reason}, {len(result.cycles)} cycles, "
            f"{result.planning_time:.1f} s of planning"
        )
    finally:
        episode.close()
        fd.FastDownward.solve = solve
    return best[0]


def solve_once(captured: tuple, split: bool, time_limit: float) -> dict:
    from ssr_compile.planners import fd

    domain, problem, _ = captured
    saved = fd.NEGATED_RULES
    fd.NEGATED_RULES = saved if split else math.inf
    try:
        planner = fd.FastDownward()
        result = planner.solve(domain, problem, time_limit=time_limit)
    finally:
        fd.NEGATED_RULES = saved
    rules = planner.last_split[1] if planner.last_split else planner.last_negated_rules
    return {
        "status": result.status,
        "rules": rules or 0,
        "operators": planner.last_operators or 0,
        "cost": result.cost,
        "translate": result.translate_time,
        "search": result.search_time,
        "total": result.time,
    }


def main() -> None:
    from hubs_bench import episode_arguments  # bench/, beside this script

    def planner_limit(ap: argparse.ArgumentParser) -> None:
        ap.add_argument(
            "--planner-limit", type=float, default=300.0, help="time limit of each run (300 s)"
        )

    args = episode_arguments(__doc__.split("\n\n")[0], 60.0, planner_limit)
    captured = capture(args.task, args.seed, args.time_limit)
    if captured is None:
        print("fd was not called")
        return
    print(
        f"task with the most negated rules: {captured[2]:,.0f} as written, "
        f"{len(captured[1].objects)} objects"
    )
    runs: dict[bool, list[dict]] = {False: [], True: []}
    for i in range(args.runs):
        for split in (False, True):
            r = solve_once(captured, split, args.planner_limit)
            runs[split].append(r)
            print(
                f"  run {i + 1} {'split  ' if split else 'written'}: {r['status']}, "
                f"{r['rules']:,.0f} negated rules, cost {r['cost']}, translate "
                f"{r['translate']:.2f} s, search {r['search']:.2f} s, planner {r['total']:.2f} s"
            )
    # medians of the times; the counts are the same every run
    header = ("task", "status", "negated rules", "ground actions", "cost", "translate s",
              "search s", "planner s")  # fmt: skip
    table = [header]
    for split, rs in runs.items():
        times = [statistics.median(r[k] for r in rs) for k in ("translate", "search", "total")]
        first = rs[0]
        table.append(
            ("split" if split else "written", first["status"], f"{first['rules']:,.0f}",
             str(first["operators"]), str(first["cost"]), *(f"{t:.2f}" for t in times))
        )  # fmt: skip
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for row in table:
        print(
            "  ".join(
                cell.rjust(w) if i > 1 else cell.ljust(w)
                for i, (cell, w) in enumerate(zip(row, widths))
            )
        )
    written, split = (statistics.median(r["total"] for r in runs[k]) for k in (False, True))
    if split > 0:
        print(f"planner time written/split: {written / split:.2f}")


if __name__ == "__main__":
    main()
