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
    python bench/clutter_bench.py --objects 8 --hiders 6 --seeds 0-9 --unconstrained-time 120

``--unconstrained-time S`` runs the policy with another limit of each unconstrained attempt
(``ssr-compile run --unconstrained-time``; default 300 s), kept in each episode's record.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path


def one(
    path: str,
    seed: int,
    variant: str,
    budget: float,
    max_cycles: int,
    unconstrained_time: float | None,
) -> dict:
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
        if unconstrained_time is not None:
            settings = replace(settings, unconstrained_time=unconstrained_time)
        result = run_policy(episode, settings)
    finally:
        episode.close()
    out = result.as_dict()
    big = max(sizes, key=lambda z: (z[1], z[0]), default=(0, 0, 0, None))
    out["largest"] = {
        "objects": big[0],
        "facts": big[1],
        "values": big[2],
        "ground_actions": max((z[3] or 0 for z in sizes), default=0),
    }
    peak = max(
        resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss,
    )
    out["peak_mib"] = round(peak / 1024, 1)  # ru_maxrss is in KiB on Linux
    if unconstrained_time is not None:
        out["unconstrained_time"] = unconstrained_time
    return out


def run_episode(path: Path, seed: int, args) -> dict:
    """One episode in a fresh process (``--one``): its record, or a failure with the reason."""
    cmd = [sys.executable, __file__, "--one", str(path), str(seed)]
    cmd += ["--variant", args.variant, "--budget", str(args.budget)]
    cmd += ["--max-cycles", str(args.max_cycles)]
    if args.unconstrained_time is not None:
        cmd += ["--unconstrained-time", str(args.unconstrained_time)]
    try:
        proc = subprocess.run(
            cmd, capture_output=True, text=True, env=os.environ, timeout=2 * args.budget + 300
        )
        run = json.loads(proc.stdout.strip().splitlines()[-1])
    except subprocess.TimeoutExpired:
        run = {"success": False, "reason": "the episode's process outlived 2 x budget + 300 s"}
    except (json.JSONDecodeError, IndexError):
        run = {"success": False, "reason": f"exit {proc.returncode}: " + proc.stderr.strip()[-300:]}
    return run


def mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else float("nan")


def summarize(records: list[dict]) -> list[dict]:
    """Per (N, K): successes, mean planning time of the successes, mean cycles and planner
    calls, the largest optimistic problem and the peak memory of any episode."""
    cells: dict[tuple[int, int], list[dict]] = {}
    for r in records:
        cells.setdefault((r["objects"], r["hiders"]), []).append(r)
    rows = []
    for (n, k), runs in sorted(cells.items()):
        ok = [r for r in runs if r.get("success")]
        done = [r for r in runs if "cycles" in r]
        big = max((r["largest"] for r in done), key=lambda z: z["facts"], default=None)
        rows.append(
            {
                "N": n,
                "K": k,
                "episodes": len(runs),
                "successes": len(ok),
                "planning_s": mean([r["planning_time"] for r in ok]),
                "cycles": mean([r["cycles"] for r in done]),
                "planner_calls": mean([r["planner_calls"] for r in done]),
                "objects": big["objects"] if big else None,
                "ground_actions": big.get("ground_actions") if big else None,
                "facts": big["facts"] if big else None,
                "peak_mib": max((r["peak_mib"] for r in done), default=None),
                "failed_seeds": sorted(r["seed"] for r in runs if not r.get("success")),
            }
        )
    return rows


def growth(rows: list[dict], k: int, lo: int = 2, hi: int = 8) -> str | None:
    """The mean planning time of the successes against N (``lo``..``hi``) for ``k`` hiders:
    the least-squares line and the exponent of a power law (log-log slope; at most 1 is
    "no faster than linear")."""
    import numpy as np

    pts = [(r["N"], r["planning_s"]) for r in rows if r["K"] == k and lo <= r["N"] <= hi]
    pts = [(n, t) for n, t in pts if t == t and t > 0]
    if len(pts) < 2:
        return None
    n, t = np.array(pts, dtype=float).T
    slope, icept = np.polyfit(n, t, 1)
    power = np.polyfit(np.log(n), np.log(t), 1)[0]
    return (
        f"K={k}, N {int(n.min())}-{int(n.max())}: planning s = {slope:.2f} N {icept:+.2f} "
        f"(least squares); as a power law N^{power:.2f}"
    )


def plot(rows: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for k in sorted({r["K"] for r in rows}):
        mine = [r for r in rows if r["K"] == k]
        ns = [r["N"] for r in mine]
        a.plot(ns, [100 * r["successes"] / r["episodes"] for r in mine], "o-", label=f"K={k}")
        b.plot(ns, [r["planning_s"] for r in mine], "o-", label=f"K={k}")
    a.set(xlabel="objects N", ylabel="success in the true world (%)", ylim=(0, 105))
    b.set(xlabel="objects N", ylabel="mean planning time of successes (s)")
    a.axhline(90, color="grey", lw=0.5, ls="--")
    for ax in (a, b):
        ax.legend()
        ax.grid(alpha=0.3)
    fig.suptitle("The kitchen with clutter (bench/clutter_bench.py)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def print_rows(rows: list[dict]) -> None:
    print(
        f"{'N':>3s} {'K':>3s} {'success':>8s} {'plan s':>8s} {'cycles':>7s} {'planner':>8s} "
        f"{'largest (objects/actions)':>26s} {'peak MiB':>9s}  failed seeds"
    )
    for r in rows:
        largest = f"{r['objects']}/{r['ground_actions']}" if r["objects"] is not None else "-"
        peak = r["peak_mib"] if r["peak_mib"] is not None else float("nan")
        print(
            f"{r['N']:3d} {r['K']:3d} {r['successes']:>4d}/{r['episodes']:<3d} "
            f"{r['planning_s']:8.1f} {r['cycles']:7.1f} {r['planner_calls']:8.1f} "
            f"{largest:>26s} {peak:9.0f}  {','.join(map(str, r['failed_seeds'])) or '-'}"
        )
    for k in sorted({r["K"] for r in rows}):
        line = growth(rows, k)
        if line:
            print(line)


def main(argv: list[str] | None = None) -> int:
    from ssr_compile.cli.options import seed_list

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kind", choices=("cook", "inspect"), default="cook")
    ap.add_argument("--objects", type=int, nargs="+", default=[2, 4, 6], metavar="N")
    ap.add_argument("--hiders", type=int, nargs="+", default=[1, 2], metavar="K")
    ap.add_argument("--seeds", type=seed_list, default=[0], help="e.g. 0-9 or 0,3,5")
    ap.add_argument("--variant", default="both")
    ap.add_argument("--budget", type=float, default=600.0, help="planning time per episode, s")
    ap.add_argument("--max-cycles", type=int, default=100)
    ap.add_argument(
        "--unconstrained-time",
        type=float,
        metavar="S",
        help="limit of each unconstrained planning attempt (default: the policy's, 300 s)",
    )
    ap.add_argument("--workers", type=int, default=1, help="episodes at once (one core each)")
    ap.add_argument(
        "--jsonl",
        help="one JSON line per episode, appended as each ends; run again to resume (the "
        "episodes on file are not run again)",
    )
    ap.add_argument("--report", action="store_true", help="only the table of --jsonl's episodes")
    ap.add_argument("--plot", help="write the curves (success and planning time against N) here")
    ap.add_argument(
        "--full",
        action="store_true",
        help="N = 2, 4, ..., 12, K = 1, 2, 4, 6, seeds 0-9, budget 600 s (days of CPU)",
    )
    ap.add_argument("--one", nargs=2, metavar=("FILE", "SEED"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.unconstrained_time is not None and not args.unconstrained_time > 0:
        ap.error(f"--unconstrained-time must be positive (got {args.unconstrained_time:g})")
    if args.one:
        out = one(
            args.one[0], int(args.one[1]), args.variant, args.budget, args.max_cycles,
            args.unconstrained_time,
        )  # fmt: skip
        print(json.dumps(out))
        return 0
    if args.full:
        args.objects, args.hiders = [2, 4, 6, 8, 10, 12], [1, 2, 4, 6]
        args.seeds, args.budget = list(range(10)), 600.0

    from concurrent.futures import ThreadPoolExecutor

    from ssr_compile.sim.task_family import generate

    records: list[dict] = []
    if args.jsonl and Path(args.jsonl).is_file():
        with open(args.jsonl) as f:
            records = [json.loads(line) for line in f if line.strip()]
    if not args.report:
        other = {r.get("unconstrained_time") for r in records} - {args.unconstrained_time}
        if other:
            named = sorted("default" if t is None else f"{t:g}" for t in other)
            ap.error(
                f"{args.jsonl} holds episodes run with another --unconstrained-time "
                f"({', '.join(named)}); resume them with the same setting or write another file"
            )
        done = {(r["kind"], r["objects"], r["hiders"], r["seed"]) for r in records}
        journal = open(args.jsonl, "a") if args.jsonl else None  # noqa: SIM115
        with tempfile.TemporaryDirectory() as tmp:
            files = {}
            for n in args.objects:
                for k in args.hiders:
                    if k < n:
                        files[n, k] = Path(tmp) / f"{args.kind}_n{n}_k{k}.toml"
                        files[n, k].write_text(generate(args.kind, n, k))
            # seed by seed across the family: a run stopped early has every N and K
            todo = [
                (path, n, k, s)
                for s in args.seeds
                for (n, k), path in files.items()
                if (args.kind, n, k, s) not in done
            ]

            def work(item):
                path, n, k, seed = item
                run = run_episode(path, seed, args)
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
                return run

            with ThreadPoolExecutor(max(args.workers, 1)) as pool:
                records += list(pool.map(work, todo))
        if journal:
            journal.close()
    mine = [r for r in records if r.get("kind", args.kind) == args.kind]
    if not args.report:
        wanted = {(n, k, s) for n in args.objects for k in args.hiders for s in args.seeds}
        mine = [r for r in mine if (r["objects"], r["hiders"], r["seed"]) in wanted]
    rows = summarize(mine)
    print_rows(rows)
    if args.plot and rows:
        plot(rows, args.plot)
        print(f"wrote {args.plot}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
