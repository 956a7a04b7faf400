"""Focused solver: median solve time over 5 runs, planner calls and stream calls, with and
without deferred evaluation (paper §VII), for every example folder in ``domains/pddl/`` and the
compiler test fixture ``tests/fixtures/compile/pp1d`` (DESIGN §2: figures, no assertions).

Run: python bench/solve_bench.py [--runs N] [--time-limit S]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from ssr_compile.focused import solve  # noqa: E402
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file  # noqa: E402
from ssr_compile.stream import module_for_problem  # noqa: E402

FIXTURES = {
    "pp1d (fixture)": (
        ROOT / "tests/fixtures/compile/pp1d",
        {
            "streams": str(ROOT / "tests/fixtures/compile/pp1d/streams.py"),
            "problems": ["problem.pddl", "problem-blocked.pddl"],
            "level": 3,
        },
    )
}


def examples():
    for folder in sorted((ROOT / "domains/pddl").iterdir()):
        config_file = folder / "example.toml"
        if config_file.exists():
            yield folder.name, (folder, tomllib.loads(config_file.read_text()))
    yield from FIXTURES.items()


def run_once(folder: Path, config: dict, problem: str, defer: bool, time_limit: float):
    d = parse_domain((folder / "domain.pddl").read_text())
    s = parse_stream_file((folder / "stream.pddl").read_text())
    p = parse_problem((folder / problem).read_text())
    module = module_for_problem(config["streams"], folder / problem, 0, search=[ROOT])
    start = time.perf_counter()
    sol = solve(
        d,
        s,
        p,
        module,
        planner=config.get("planner", "fd"),
        time_limit=time_limit,
        defer=defer,
        initial_level=int(config.get("level", 1)),
        max_level=int(config.get("max_level", 8)),
    )
    elapsed = time.perf_counter() - start
    calls = sum(st.calls for st in sol.stats.streams.values())
    return sol.status, elapsed, sol.stats.planner_calls, calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--time-limit", type=float, default=60.0)
    args = ap.parse_args()
    head = f"{'example':22s} {'problem':24s} {'defer':5s} {'status':10s} {'median s':>9s} {'planner':>8s} {'streams':>8s}"
    print(head)
    print("-" * len(head))
    for name, (folder, config) in examples():
        problems = config.get("problems") or sorted(x.name for x in folder.glob("problem*.pddl"))
        for problem in problems:
            for defer in (False, True):
                rows = []
                try:
                    rows = [
                        run_once(folder, config, problem, defer, args.time_limit)
                        for _ in range(args.runs)
                    ]
                except Exception as e:  # noqa: BLE001 - a broken example is a row, not a crash
                    print(f"{name:22s} {problem:24s} {str(defer):5s} error: {e}")
                    continue
                statuses = {r[0] for r in rows}
                print(
                    f"{name:22s} {problem:24s} {str(defer):5s} {'/'.join(sorted(statuses)):10s} "
                    f"{statistics.median(r[1] for r in rows):9.3f} "
                    f"{statistics.median(r[2] for r in rows):8.0f} "
                    f"{statistics.median(r[3] for r in rows):8.0f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
