"""What unified-planning's Fast Downward engine cannot go below: the driver command it runs.

For each problem (the optimistic task of a shipped example at its level, ground as the ``up:*``
backends receive it), three things are timed in turn, N times each, interleaved:

* ``fd``: this project's backend on the lifted task (translator in a pre-forked worker, search
  binary started beside it), compilation excluded;
* ``driver``: the command unified-planning's ``fast-downward`` engine runs for one call --
  ``python fast-downward.py --plan-file ... domain problem --search S``, from the engine's own
  package, on the files ``up:fast-downward`` hands it (the ground task written as PDDL), with
  the same search string S -- with no unified-planning code around it;
* ``up:fast-downward``: the whole backend (unified-planning's modelling API, PDDL writer,
  engine, plan reading), compilation excluded.

The ratio ``driver / fd`` is the least ``up:fast-downward / fd`` can be, whatever the backend
does: the driver starts two Python interpreters (itself, then the translator) per call.
Figures only, no assertions.

    python bench/up_floor.py                 # 5 calls each, three problems (under a minute)
    python bench/up_floor.py --full          # every shipped problem, 9 calls each
    python bench/up_floor.py --calls 9 --problems tamp2d-routes,kitchen
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ssr_compile.compile.pipeline import compile_problem
from ssr_compile.examples import SHIPPED_PROBLEMS, load_example
from ssr_compile.parse import parse_file
from ssr_compile.planners import get_planner
from ssr_compile.printer import to_text

DEFAULT = "tamp2d/problem,belief-detect/problem-occluded,kitchen/problem-inspect"


def driver_command(folder: Path, search: str) -> list[str]:
    import up_fast_downward

    script = Path(up_fast_downward.__file__).parent / "downward" / "fast-downward.py"
    return [
        sys.executable,
        str(script),
        "--plan-file",
        str(folder / "plan"),
        str(folder / "domain.pddl"),
        str(folder / "problem.pddl"),
        "--search",
        search,
    ]


def timed(fn, *args, **kwargs) -> float:
    start = time.perf_counter()
    fn(*args, **kwargs)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=None, help="calls per problem (default 5)")
    ap.add_argument("--problems", default=None, help="comma-separated example/problem filters")
    ap.add_argument("--full", action="store_true", help="every shipped problem, 9 calls each")
    args = ap.parse_args()
    args.calls = args.calls or (9 if args.full else 5)
    args.problems = args.problems or ("" if args.full else DEFAULT)
    from ssr_compile.planners.up import COST_AWARE_SEARCH

    fd, up = get_planner("fd"), get_planner("up:fast-downward")
    wanted = args.problems.split(",")  # "" matches every problem
    print(
        f"{'problem':32s} {'fd s':>7s} {'driver s':>9s} {'up s':>7s} {'driver/fd':>10s} {'up/fd':>7s}"
    )
    for example, pfile, level in SHIPPED_PROBLEMS:
        label = f"{example}/{pfile.removesuffix('.pddl')}"
        if not any(w in label for w in wanted):
            continue
        ex = load_example(example)
        problem = parse_file(ex.folder / pfile)
        lifted = compile_problem(ex.domain, ex.streams, problem, caps=fd.capabilities, level=level)
        ground = compile_problem(ex.domain, ex.streams, problem, caps=up.capabilities, level=level)
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            (folder / "domain.pddl").write_text(to_text(ground.domain))
            (folder / "problem.pddl").write_text(to_text(ground.problem))
            cmd = driver_command(folder, COST_AWARE_SEARCH)
            fd.solve(lifted.domain, lifted.problem, time_limit=60)  # warm: the worker forks
            up.solve(ground.domain, ground.problem, time_limit=60)  # warm: imports
            times: dict[str, list[float]] = {"fd": [], "driver": [], "up": []}
            for _ in range(args.calls):
                times["fd"].append(timed(fd.solve, lifted.domain, lifted.problem, time_limit=60))
                times["driver"].append(
                    timed(
                        subprocess.run,
                        cmd,
                        cwd=folder,
                        stdout=subprocess.DEVNULL,
                        stderr=subprocess.DEVNULL,
                        check=True,
                    )
                )
                times["up"].append(timed(up.solve, ground.domain, ground.problem, time_limit=60))
        m = {k: statistics.median(v) for k, v in times.items()}
        print(
            f"{label:32s} {m['fd']:7.3f} {m['driver']:9.3f} {m['up']:7.3f} "
            f"{m['driver'] / m['fd']:9.1f}x {m['up'] / m['fd']:6.1f}x"
        )


if __name__ == "__main__":
    main()
