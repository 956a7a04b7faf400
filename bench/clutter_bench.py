"""The family of harder kitchens (issue 40) over N objects and K hiders: how the online policy
scales with clutter.

For each N (objects, 2-12) and K (boxes that may hide the block, 1-6, K < N) the task file
of ``ssr-compile tasks generate --kind KIND --objects N --hiders K`` is written to a temporary
folder, and each seed runs as one episode in a process of its own (``--one``): the policy of
``ssr-compile run FILE --seed S`` (variant ``both``), with every planner call's compiled problem
size recorded.  Printed per N, K: successes in the true world, mean planning time of the
successes, mean cycles, mean planner calls, the largest optimistic problem any planner call
saw (facts / objects), and the peak resident memory of an episode's process tree.

    python bench/clutter_bench.py --objects 2 --hiders 1 --seeds 0      # smoke run
    python bench/clutter_bench.py --kind cook --objects 2 4 6 8 12 --hiders 1 2 4 6 --seeds 0-9
    python bench/clutter_bench.py --full    # N 2-12 (even), K 1, 2, 4, 6, seeds 0-9: days
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path


def seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def one(path: str, seed: int, variant: str, budget: float, max_cycles: int) -> dict:
    """One episode in this process: its outcome, counts and the largest compiled problem."""
    import resource

    from ssr_compile.streams.environments.kitchen import make_episode

    from ssr_compile.policy import PolicySettings, run_policy
    from ssr_compile.solver.loop import SolverLoop

    sizes: list[tuple] = []
    call_planner = SolverLoop.call_planner

    def recorded(self, *args, **kwargs):
        result, size = call_planner(self, *args, **kwargs)
        sizes.append(size)
        return result, size

    SolverLoop.call_planner = recorded  # type: ignore[method-assign]
    episode = make_episode(path, seed)
    try:
        settings = PolicySettings(variant=variant, budget=budget, max_cycles=max_cycles)
        result = run_policy(episode, settings)
    finally:
        episode.close()
    out = result.as_dict()
    big = max(sizes, key=lambda z: (z[1], z[0]), default=(0, 0, 0, None))
    out["largest"] = {"objects": big[0], "facts": big[1], "values": big[2]}
    peak = max(
        resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss,
    )
    out["peak_mib"] = round(peak / 1024, 1)  # ru_maxrss is in KiB on Linux
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kind", choices=("cook", "inspect"), default="cook")
    ap.add_argument("--objects", type=int, nargs="+", default=[2, 4, 6], metavar="N")
    ap.add_argument("--hiders", type=int, nargs="+", default=[1, 2], metavar="K")
    ap.add_argument("--seeds", type=seeds, default=[0], help="e.g. 0-9 or 0,3,5")
    ap.add_argument("--variant", default="both")
    ap.add_argument("--budget", type=float, default=600.0, help="planning time per episode, s")
    ap.add_argument("--max-cycles", type=int, default=100)
    ap.add_argument("--jsonl", help="append one JSON line per episode to this file")
    ap.add_argument(
        "--full",
        action="store_true",
        help="N = 2, 4, ..., 12, K = 1, 2, 4, 6, seeds 0-9, budget 600 s (days of CPU)",
    )
    ap.add_argument("--one", nargs=2, metavar=("FILE", "SEED"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        out = one(args.one[0], int(args.one[1]), args.variant, args.budget, args.max_cycles)
        print(json.dumps(out))
        return 0
    if args.full:
        args.objects, args.hiders = [2, 4, 6, 8, 10, 12], [1, 2, 4, 6]
        args.seeds, args.budget = list(range(10)), 600.0

    from ssr_compile.sim.task_family import generate

    journal = open(args.jsonl, "a") if args.jsonl else None  # noqa: SIM115
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.objects:
            for k in args.hiders:
                if k >= n:
                    continue
                path = Path(tmp) / f"{args.kind}_n{n}_k{k}.toml"
                path.write_text(generate(args.kind, n, k))
                runs = []
                for seed in args.seeds:
                    cmd = [sys.executable, __file__, "--one", str(path), str(seed)]
                    cmd += ["--variant", args.variant, "--budget", str(args.budget)]
                    cmd += ["--max-cycles", str(args.max_cycles)]
                    proc = subprocess.run(cmd, capture_output=True, text=True, env=os.environ)
                    try:
                        run = json.loads(proc.stdout.strip().splitlines()[-1])
                    except (json.JSONDecodeError, IndexError):
                        run = {"success": False, "reason": f"exit {proc.returncode}: "
                               + proc.stderr.strip()[-200:]}  # fmt: skip
                    run.update(kind=args.kind, objects=n, hiders=k, seed=seed)
                    print(
                        f"N={n} K={k} seed {seed}: success {run.get('success')}, "
                        f"{run.get('cycles', '-')} cycles, planning {run.get('planning_time', '-')} s, "
                        f"planner calls {run.get('planner_calls', '-')} ({run.get('reason')})",
                        file=sys.stderr,
                        flush=True,
                    )
                    if journal:
                        journal.write(json.dumps(run) + "\n")
                        journal.flush()
                    runs.append(run)
                rows.append((n, k, runs))
    print(
        f"{'N':>3s} {'K':>3s} {'success':>8s} {'plan s':>8s} {'cycles':>7s} {'planner':>8s} "
        f"{'largest (facts/objects)':>24s} {'peak MiB':>9s}"
    )
    for n, k, runs in rows:
        ok = [r for r in runs if r.get("success")]
        done = [r for r in runs if "cycles" in r]

        def mean(key, among):
            return sum(r[key] for r in among) / len(among) if among else float("nan")

        big = max((r["largest"] for r in done), key=lambda z: z["facts"], default=None)
        largest = f"{big['facts']}/{big['objects']}" if big else "-"
        print(
            f"{n:3d} {k:3d} {len(ok):>4d}/{len(runs):<3d} {mean('planning_time', ok):8.1f} "
            f"{mean('cycles', done):7.1f} {mean('planner_calls', done):8.1f} "
            f"{largest:>24s} "
            f"{max((r['peak_mib'] for r in done), default=float('nan')):9.0f}"
        )
    if journal:
        journal.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
