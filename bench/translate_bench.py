"""Fast Downward's translator on the tasks a kitchen episode hands the planner (figures, no
assertions).

The planner time of a kitchen replan is mostly the translator's (the search on these tasks
takes milliseconds).  This script runs an episode of the online policy for a few cycles and
keeps every task the ``fd`` backend was given (``--capture DIR``), then replays the tasks
through the translator and the search binary, in this process, interleaved task by task:
for each folder given (``--replay DIR [DIR ...]``: captures of different code, the same
episode) and each invariant-synthesis setting (``--invariants on,auto``; ``auto`` is the
backend's default: off for plan-constrained tasks), the total translation and search time
(medians of ``--runs`` per task) over the constrained and the other tasks, and how many plans
agree with the first column's (same actions and cost).

    python bench/translate_bench.py                          # capture Swap seed 0, 13 cycles; replay
    python bench/translate_bench.py --full                   # the whole episode, 5 runs per task
    python bench/translate_bench.py --capture /tmp/swap0 --task swap --seed 0 --cycles 13
    python bench/translate_bench.py --replay /tmp/old /tmp/new --invariants on,auto --runs 3
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def capture(folder: Path, task: str, seed: int, cycles: int, variant: str) -> int:
    """Run the episode; every task the fd backend solves is copied to ``folder/NNN``."""
    from ssr_compile.examples import load_example
    from ssr_compile.planners import external
    from ssr_compile.policy import PolicySettings, run_policy

    folder.mkdir(parents=True, exist_ok=True)
    original = external.ExternalPlanner.write
    count = [0]

    def write(self, job, domain, problem):
        original(self, job, domain, problem)
        count[0] += 1
        dst = folder / f"{count[0]:03d}"
        dst.mkdir(exist_ok=True)
        shutil.copy(job.domain, dst / "domain.pddl")
        shutil.copy(job.problem, dst / "problem.pddl")

    external.ExternalPlanner.write = write
    try:
        episode = load_example("kitchen").environment_factory()(task, seed)
        try:
            outcome = run_policy(episode, PolicySettings(variant=variant, max_cycles=cycles))
        finally:
            getattr(episode, "close", lambda: None)()
    finally:
        external.ExternalPlanner.write = original
    print(
        f"captured {count[0]} tasks of {task} seed {seed} ({variant}, {len(outcome.cycles)} "
        f"cycles) in {folder}"
    )
    return count[0]


def _translate(domain: str, problem: str, sas: str, invariants: bool) -> float:
    from ssr_compile.planners.fd import _translate as translate

    start = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        translate(domain, problem, sas, invariants)
    return time.perf_counter() - start


def _search(sas: str, plan: str) -> tuple[float, str | None]:
    from ssr_compile.planners.fd import SEARCHES, search_binary

    if os.path.exists(plan):
        os.remove(plan)
    search = SEARCHES["default"].replace("{bound}", "")
    start = time.perf_counter()
    with open(sas, "rb") as f:
        subprocess.run(
            [str(search_binary()), "--search", search, "--internal-plan-file", plan],
            stdin=f,
            capture_output=True,
            check=False,
        )
    elapsed = time.perf_counter() - start
    return elapsed, (Path(plan).read_text() if os.path.exists(plan) else None)


def _shape(plan: str | None):
    """A plan's action names and its cost line (arguments aside: captures of different code
    may name the same step with fewer arguments)."""
    if plan is None:
        return None
    lines = plan.splitlines()
    return [ln.split()[0] for ln in lines if ln.startswith("(")], lines[-1:]


def replay(folders: list[Path], settings: list[str], runs: int) -> None:
    from ssr_compile.compile.constraints import is_chained
    from ssr_compile.parse import parse_domain

    names = sorted(
        set.intersection(*({p.name for p in f.iterdir() if p.is_dir()} for f in folders))
    )
    columns = [(f, s) for f in folders for s in settings]
    totals = {c: {"c": [0.0, 0.0, 0], "u": [0.0, 0.0, 0]} for c in columns}
    agree = dict.fromkeys(columns, 0)
    scratch = tempfile.mkdtemp(prefix="ssr-translate-bench-")
    try:
        for n, name in enumerate(names, 1):
            first = None
            for col in columns:
                folder, setting = col
                d, p = str(folder / name / "domain.pddl"), str(folder / name / "problem.pddl")
                chained = is_chained(parse_domain(Path(d).read_text()))
                invariants = setting == "on" or (setting == "auto" and not chained)
                sas, out = os.path.join(scratch, "output.sas"), os.path.join(scratch, "plan")
                t_tr = statistics.median(_translate(d, p, sas, invariants) for _ in range(runs))
                t_search, plan = _search(sas, out)
                kind = "c" if chained else "u"
                totals[col][kind][0] += t_tr
                totals[col][kind][1] += t_search
                totals[col][kind][2] += 1
                shape = _shape(plan)
                if first is None:
                    first = shape
                agree[col] += shape == first
            print(f"\r{n}/{len(names)} tasks", end="", file=sys.stderr, flush=True)
        print(file=sys.stderr)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print(f"{len(names)} tasks, median of {runs} translations each; times are sums over the tasks")
    header = f"{'capture':<28} {'invariants':<10} {'kind':<12} {'tasks':>5} {'translate s':>12} {'search s':>9} {'plans as col 1':>15}"
    print(header)
    print("-" * len(header))
    for col in columns:
        folder, setting = col
        for kind, label in (("c", "constrained"), ("u", "other")):
            tr, se, k = totals[col][kind]
            print(
                f"{str(folder)[-28:]:<28} {setting:<10} {label:<12} {k:>5} {tr:>12.2f} {se:>9.2f} "
                f"{'' if kind == 'u' else f'{agree[col]}/{len(names)}':>15}"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--capture", type=Path, help="capture an episode's tasks into this folder")
    ap.add_argument("--replay", type=Path, nargs="+", help="replay the tasks of these folders")
    ap.add_argument("--task", default="swap", help="kitchen task to capture (default swap)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cycles", type=int, default=13, help="cycles of the captured episode")
    ap.add_argument("--variant", default="both")
    ap.add_argument("--invariants", default="on,auto", help="settings to replay (on, off, auto)")
    ap.add_argument("--runs", type=int, default=3, help="translations per task and setting")
    ap.add_argument(
        "--full", action="store_true", help="the whole episode (up to 100 cycles), 5 runs per task"
    )
    args = ap.parse_args()
    if args.full:
        args.cycles, args.runs = 100, 5
    settings = [s.strip() for s in args.invariants.split(",") if s.strip()]
    bad = [s for s in settings if s not in ("on", "off", "auto")]
    if bad or args.runs < 1 or args.cycles < 1:
        ap.error(
            f"--invariants takes on, off, auto (got {', '.join(bad) or args.invariants}); "
            "--runs and --cycles at least 1"
        )
    if args.capture is not None:
        capture(args.capture, args.task, args.seed, args.cycles, args.variant)
        if not args.replay:
            return
    if args.replay:
        for f in args.replay:
            if not f.is_dir():
                ap.error(f"no such folder: {f}")
        replay(args.replay, settings, args.runs)
        return
    tmp = Path(tempfile.mkdtemp(prefix="ssr-capture-"))
    try:
        capture(tmp, args.task, args.seed, args.cycles, args.variant)
        replay([tmp], settings, args.runs)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
