"""The kitchen in closed loop (issue 11): tasks x variants x seeds under the online policy.

Each episode is ``run_policy(make_episode(task, seed), PolicySettings(variant=...))`` in the
PyBullet true world; success is the goal in the true state.  Prints one line per episode and a
table per (task, variant): successes, mean cycles, mean planning time of the successful
episodes, constrained attempts that held, fallbacks.  ``--jsonl FILE`` saves every episode.

Then the planning time's split per (task, variant), over every episode run: planner calls per
cycle, and the mean seconds per cycle with their share of the planning time of Fast Downward's
translator, its search, the rest of the planner calls (writing the task, the worker's round
trip), stream evaluation, compiling the optimistic problems (stream instantiation included),
and the rest (preimages, stream plans, the solver's own work).

    python bench/kitchen_bench.py                      # Inspect, variant both, seed 0 (< 1 min)
    python bench/kitchen_bench.py --full               # 4 tasks x 4 variants x seeds 0-9, 600 s
    python bench/kitchen_bench.py --tasks inspect stow swap cook --variants neither \\
        constraints deferred both --seeds 0-9 --budget 600

``--streams`` also prints, per task, each stream's calls and seconds (the solver's
``Statistics.streams`` summed over every attempt) and its share of the stream time.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace

from ssr_compile.streams.environments.kitchen import make_episode

import ssr_compile.policy as policy
from ssr_compile.catalog import TASKS, VARIANTS
from ssr_compile.episode_record import SPLIT
from ssr_compile.policy import PolicySettings, run_policy

# The split's columns: (heading, how to get its seconds from the sums of an episode's cycles).
COLUMNS = (
    ("translate", lambda t: t["translate_time"]),
    ("search", lambda t: t["search_time"]),
    ("planner other", lambda t: t["planner_time"] - t["translate_time"] - t["search_time"]),
    ("streams", lambda t: t["stream_time"]),
    ("compile", lambda t: t["compile_time"]),
    ("rest", lambda t: t["planning_time"] - t["planner_time"] - t["stream_time"]
     - t["compile_time"]),
)  # fmt: skip


def split(res) -> dict:
    """An episode's planning time and its parts (sums over its cycles), with its planner calls."""
    keys = ("planning_time", "planner_calls", *SPLIT)
    return {k: round(sum(getattr(c, k) for c in res.cycles), 4) for k in keys}


def print_split(rows: dict) -> None:
    """Per (task, variant): planner calls per cycle, seconds per cycle and share per part."""
    print()
    print("planning time per cycle (all episodes): seconds, share of the planning time")
    print(f"{'task':8s} {'variant':11s} {'cycles':>6s} {'calls/c':>7s} {'plan s/c':>8s}  "
          + "  ".join(f"{h:>18s}" for h, _ in COLUMNS))  # fmt: skip
    for (task, variant), ds in rows.items():
        total = {k: sum(d["split"][k] for d in ds) for k in ds[0]["split"]}
        cycles = sum(d["cycles"] for d in ds) or 1
        plan = total["planning_time"]
        cells = []
        for _, get in COLUMNS:
            part = get(total)
            share = 100 * part / plan if plan > 0 else 0.0
            cells.append(f"{part / cycles:8.3f} s {share:5.1f} %")
        print(f"{task:8s} {variant:11s} {cycles:6d} {total['planner_calls'] / cycles:7.2f} "
              f"{plan / cycles:8.3f}  " + "  ".join(f"{c:>18s}" for c in cells))  # fmt: skip


class StreamTimes:
    """Per stream name: [calls, seconds] summed over every solve of the policy, by task (wraps
    ``ssr_compile.policy.solve`` while in use)."""

    def __init__(self) -> None:
        self.by_task: dict[str, dict[str, list]] = {}
        self.task = ""
        self._solve = policy.solve

    def __enter__(self) -> StreamTimes:
        def counted(*args, **kwargs):
            sol = self._solve(*args, **kwargs)
            sums = self.by_task.setdefault(self.task, {})
            for name, st in sol.stats.streams.items():
                row = sums.setdefault(name, [0, 0.0])
                row[0] += st.calls
                row[1] += st.time
            return sol

        policy.solve = counted
        return self

    def __exit__(self, *exc) -> None:
        policy.solve = self._solve

    def print(self) -> None:
        for task, sums in self.by_task.items():
            total = sum(t for _, t in sums.values()) or 1.0
            print(f"\nstreams of {task} (all episodes): calls, seconds, share of the stream time")
            for name, (calls, t) in sorted(sums.items(), key=lambda kv: -kv[1][1]):
                print(f"  {name:24s} {calls:6d} {t:9.2f} s {100 * t / total:5.1f} %")


def seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            out += list(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tasks", nargs="+", default=["inspect"], choices=TASKS)
    ap.add_argument("--variants", nargs="+", default=["both"], choices=list(VARIANTS))
    ap.add_argument("--seeds", type=seeds, default=[0], help="e.g. 0-9 or 0,3,5")
    ap.add_argument("--budget", type=float, default=120.0, help="planning time per episode, s")
    ap.add_argument("--constrained-time", type=float, default=10.0)
    ap.add_argument("--unconstrained-time", type=float, default=60.0)
    ap.add_argument("--max-cycles", type=int, default=40)
    ap.add_argument(
        "--full",
        action="store_true",
        help="every task and variant, seeds 0-9, budget 600 s (hours)",
    )
    ap.add_argument("--jsonl", help="append one JSON line per episode to this file")
    ap.add_argument("-v", "--verbose", action="store_true", help="print every cycle")
    ap.add_argument("--streams", action="store_true", help="print each stream's calls, seconds")
    args = ap.parse_args(argv)
    times = StreamTimes()
    if args.streams:
        with times:
            code = run(args, times)
        times.print()
        return code
    return run(args)


def run(args, times: StreamTimes | None = None) -> int:
    rows: dict[tuple[str, str], list[dict]] = {}
    if args.full:
        args.tasks, args.variants = list(TASKS), list(VARIANTS)
        args.seeds, args.budget = list(range(10)), 600.0
    out = open(args.jsonl, "a") if args.jsonl else None
    shared = PolicySettings(
        budget=args.budget,
        constrained_time=args.constrained_time,
        unconstrained_time=args.unconstrained_time,
        max_cycles=args.max_cycles,
    )
    for task in args.tasks:
        if times is not None:
            times.task = task
        for variant in args.variants:
            settings = replace(shared, variant=variant)
            for seed in args.seeds:
                ep = make_episode(task, seed)
                start, cpu = time.monotonic(), time.process_time()
                try:
                    res = run_policy(
                        ep,
                        settings,
                        on_cycle=(lambda c: print("   ", c.line())) if args.verbose else None,
                    )
                finally:
                    ep.close()
                d = {"task": task, "variant": variant, "seed": seed, **res.as_dict()}
                d["reason"] = res.reason
                d["actions_executed"] = res.actions
                d["wall"] = round(time.monotonic() - start, 2)
                d["cpu"] = round(time.process_time() - cpu, 2)  # this process (not the planner's)
                d["split"] = split(res)
                rows.setdefault((task, variant), []).append(d)
                print(
                    f"{task:8s} {variant:11s} seed {seed:2d}  "
                    f"{'SUCCESS' if d['success'] else 'failure'}  cycles {d['cycles']:3d}  "
                    f"planning {d['planning_time']:7.1f} s  held {d['constrained_held']:2d}  "
                    f"fallbacks {d['fallbacks']:2d}  cpu {d['cpu']:6.1f} s  ({res.reason})",
                    flush=True,
                )
                if out:
                    out.write(json.dumps(d) + "\n")
                    out.flush()
    if out:
        out.close()
    print()
    print(f"{'task':8s} {'variant':11s} {'success':>9s} {'cycles':>7s} {'planning s':>11s} "
          f"{'held':>5s} {'fallbacks':>9s}")  # fmt: skip
    for (task, variant), ds in rows.items():
        ok = [d for d in ds if d["success"]]
        plan = sum(d["planning_time"] for d in ok) / len(ok) if ok else float("nan")
        cyc = sum(d["cycles"] for d in ds) / len(ds)
        held = sum(d["constrained_held"] for d in ds) / len(ds)
        fb = sum(d["fallbacks"] for d in ds) / len(ds)
        print(f"{task:8s} {variant:11s} {len(ok):4d}/{len(ds):<4d} {cyc:7.1f} {plan:11.1f} "
              f"{held:5.1f} {fb:9.1f}")  # fmt: skip
    print_split(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
