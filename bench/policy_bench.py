"""The online policy (Algorithm 1) on the small environments: per environment and variant,
success rate, cycles, planning time per cycle, how often the constrained attempt held, the
ratio of constrained to unconstrained planning time on the same cycles, and the policy's own
overhead per cycle.

    python bench/policy_bench.py                 # progress and belief-detect, 3 seeds each
    python bench/policy_bench.py --full          # 10 seeds each (a few minutes)
    python bench/policy_bench.py --seeds 20 --envs progress

Two passes per (environment, variant): the first gives the outcomes (nothing but the policy
runs); the second, on the variants with constraints, also solves each cycle whose constrained
attempt held without constraints, to time both on the same problem (streams with global
random state may then draw differently, so its outcomes are not reported).
"""

from __future__ import annotations

import argparse
import statistics
import time

from ssr_compile.catalog import VARIANTS
from ssr_compile.examples import load_example
from ssr_compile.policy import PolicySettings, run_policy


def episode_for(env: str, seed: int):
    return load_example(env).environment_factory()(None, seed)


def run(env: str, variant: str, seeds: range, compare: bool):
    results = []
    for seed in seeds:
        episode = episode_for(env, seed)
        try:
            settings = PolicySettings(variant=variant, max_cycles=30, compare_unconstrained=compare)
            results.append(run_policy(episode, settings))
        finally:
            episode.close()
    return results


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 (default 3)")
    ap.add_argument("--full", action="store_true", help="10 seeds (overrides --seeds)")
    ap.add_argument("--envs", default="progress,belief-detect", help="comma-separated examples")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated variants")
    args = ap.parse_args()
    seeds = range(10 if args.full else args.seeds)
    print(
        f"{'environment':14s} {'variant':11s} {'success':>8s} {'cycles':>7s} "
        f"{'plan s/cycle':>12s} {'held':>6s} {'c/u time':>9s} {'overhead':>9s} {'wall s':>7s}"
    )
    for env in args.envs.split(","):
        for variant in args.variants.split(","):
            start = time.perf_counter()
            results = run(env, variant, seeds, compare=False)
            wall = time.perf_counter() - start
            cycles = [c for r in results for c in r.cycles]
            ok = sum(r.success for r in results)
            per_cycle = median([c.planning_time for c in cycles])
            attempts = [c for c in cycles if c.constrained != "-"]
            held = (
                f"{sum(c.constrained == 'held' for c in attempts)}/{len(attempts)}"
                if attempts
                else "-"
            )
            ratio = "-"
            if VARIANTS[variant][0]:
                compared = [
                    c
                    for r in run(env, variant, seeds, compare=True)
                    for c in r.cycles
                    if c.comparison_time
                ]
                if compared:
                    ratio = (
                        f"{median([c.constrained_time / c.comparison_time for c in compared]):.2f}"
                    )
            overhead = median(
                [
                    c.overhead_time
                    / (c.overhead_time + c.planning_time + c.execution_time + c.update_time)
                    for c in cycles
                    if c.planning_time > 0
                ]
            )
            print(
                f"{env:14s} {variant:11s} {ok:>4d}/{len(results):<3d} "
                f"{median([len(r.cycles) for r in results]):>7.1f} {per_cycle:>12.3f} {held:>6s} "
                f"{ratio:>9s} {100 * overhead:>8.2f}% {wall:>7.1f}"
            )
    print(
        "success: goal in the true state; cycles: median per episode; plan s/cycle: median; "
        "held: constrained attempts that held / made; c/u time: median ratio of constrained "
        "to unconstrained planning time on the same held cycles; overhead: median share of a "
        "cycle spent in the policy itself (not planning, executing or updating the belief)"
    )


if __name__ == "__main__":
    main()
