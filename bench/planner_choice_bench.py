"""Which planner should be the default?  Plan cost and time of each candidate on the shipped
problems, for ``solve`` (the Focused algorithm: real streams, the certified plan's cost) and
``plan`` (one optimistic plan).

    python bench/planner_choice_bench.py           # the small examples (under a minute)
    python bench/planner_choice_bench.py --full    # also the kitchen's four tasks (minutes)

Each cell runs ``ssr-compile ... --json`` in a process of its own and prints status, actions,
cost and wall time; the README's "Default planners" states what these numbers chose.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "domains" / "pddl"
SMALL = [
    ("tamp2d", "problem"),
    ("tamp2d", "blocked"),
    ("tamp2d-routes", "problem"),
    ("progress", "problem"),
    ("belief-detect", "occluded"),
    ("belief-detect", "clear"),
]
KITCHEN = [("kitchen", t) for t in ("inspect", "swap", "cook", "stow")]
PLANNERS = ["fd", "fd:opt"]


def cell(command: str, example: str, problem: str, planner: str, limit: float) -> dict:
    argv = [sys.executable, "-m", "ssr_compile.cli", command, str(EXAMPLES / example)]
    argv += ["--problem", problem, "--planner", planner, "--time-limit", f"{limit:g}", "--json"]
    start = time.monotonic()
    r = subprocess.run(argv, capture_output=True, text=True, timeout=limit * 3 + 60)
    wall = time.monotonic() - start
    try:
        result = json.loads(r.stdout)["results"][0]
    except (ValueError, KeyError, IndexError):
        return {
            "status": f"error (exit {r.returncode})",
            "actions": None,
            "cost": None,
            "wall": wall,
        }
    return {
        "status": result["status"],
        "actions": len(result["plan"]) if result["status"] == "solved" else None,
        "cost": result["cost"],
        "wall": wall,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--full", action="store_true", help="also the kitchen's tasks (minutes)")
    ap.add_argument("--time-limit", type=float, default=120.0, help="per cell (default 120 s)")
    ap.add_argument(
        "--commands", default="solve,plan", help="solve and/or plan (default solve,plan)"
    )
    args = ap.parse_args(argv)
    problems = SMALL + (KITCHEN if args.full else [])
    print(f"{'command':7} {'problem':26} " + " ".join(f"{p:>28}" for p in PLANNERS))
    print(" " * 35 + " ".join(f"{'status  acts   cost    wall':>28}" for _ in PLANNERS))
    for command in args.commands.split(","):
        for example, problem in problems:
            row = []
            for planner in PLANNERS:
                c = cell(command, example, problem, planner, args.time_limit)
                acts = "-" if c["actions"] is None else str(c["actions"])
                cost = "-" if not isinstance(c["cost"], (int, float)) else f"{c['cost']:.2f}"
                row.append(f"{c['status'][:8]:>8} {acts:>5} {cost:>7} {c['wall']:6.1f}s")
            print(f"{command:7} {example + '/' + problem:26} " + " ".join(f"{x:>28}" for x in row))
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
