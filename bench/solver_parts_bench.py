"""The solver's in-process parts on a kitchen episode's own inputs: optimistic instantiation and
plan preimages (figures, no assertions).

``--capture FILE``: run an episode of the online policy (*both*) for ``--cycles`` cycles and
keep the inputs and results of every ``instantiate`` and ``plan_preimage`` call it made (a
pickle).  ``--replay FILE``: run those calls again in this process, ``--runs`` times each,
and print the best total time per part and how many results differ from the captured ones (a
change meant to keep behaviour must give 0).  Replay one capture with two versions of the
code to compare them on the same inputs:

    python bench/solver_parts_bench.py --capture cook0.pkl --task cook --seed 0 --cycles 12
    python bench/solver_parts_bench.py --replay cook0.pkl
    PYTHONPATH=OTHER_CHECKOUT python bench/solver_parts_bench.py --replay cook0.pkl
    python bench/solver_parts_bench.py --capture cook0.pkl --replay cook0.pkl --full  # whole episode

A task file (``ssr-compile tasks generate ... > F.toml``) is accepted as ``--task F.toml``.
Python's garbage collector is paused during the replayed calls, as the compiler pauses it.
"""

from __future__ import annotations

import argparse
import gc
import pickle
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# last: a checkout named by PYTHONPATH (the version to time) comes first
sys.path.append(str(ROOT))

# the largest instantiations kept in a capture (they are most of the time; the file stays small)
KEEP_INSTANTIATIONS = 40


def capture(path: Path, task: str, seed: int, cycles: int) -> None:
    from ssr_compile.streams.environments.kitchen import make_episode

    import ssr_compile.compile.pipeline as pipeline
    import ssr_compile.solver.focused as focused
    import ssr_compile.solver.loop as loop
    from ssr_compile.policy import PolicySettings, run_policy

    calls: dict[str, list] = {"instantiate": [], "plan_preimage": []}

    def recording(name, fn, key=None):
        # the result as it is returned (the solver goes on to change some of it in place)
        # and the inputs as they are given (the solver's lists and sets grow after the call)
        def wrapper(*args, **kwargs):
            given = pickle.dumps((args, kwargs))
            start = time.perf_counter()
            try:
                out = fn(*args, **kwargs)
            except Exception as e:  # a plan that does not hold: its error is the result
                calls[name].append((time.perf_counter() - start, given, repr(e)))
                raise
            took = time.perf_counter() - start
            calls[name].append((took, given, out if key is None else key(out)))
            return out

        return wrapper

    pipeline.instantiate = recording("instantiate", pipeline.instantiate, _instantiation_key)
    preimage = recording("plan_preimage", loop.plan_preimage)
    loop.plan_preimage = focused.plan_preimage = preimage
    sys.setrecursionlimit(100000)
    episode = make_episode(task, seed)
    try:
        res = run_policy(episode, PolicySettings(variant="both", max_cycles=cycles))
    finally:
        episode.close()
    biggest = sorted(calls["instantiate"], key=lambda c: -c[0])[:KEEP_INSTANTIATIONS]
    kept = {
        "instantiate": [(given, out) for _t, given, out in biggest],
        "plan_preimage": [(given, out) for _t, given, out in calls["plan_preimage"]],
    }
    with open(path, "wb") as f:
        pickle.dump(kept, f)
    print(
        f"{task} seed {seed}: {len(res.cycles)} cycles; kept {len(kept['instantiate'])} of "
        f"{len(calls['instantiate'])} instantiations, {len(kept['plan_preimage'])} preimages "
        f"-> {path}"
    )


def _instantiation_key(out) -> object:
    """What an instantiation's result is, compared between versions (names, facts, results)."""
    if isinstance(out, str):
        return out
    from ssr_compile.printer import to_text

    return (
        to_text(out.domain),
        to_text(out.problem),
        [(r.instance, r.outputs, r.certified, r.domain, r.level) for r in out.results],
        sorted((k, str(v.instance)) for k, v in out.objects.items()),
        sorted((str(k), [str(r.instance) for r in v]) for k, v in out.facts.items()),
        out.saturated,
        # the stream predicates whose absent atoms a plan may have checked (made lazily)
        sorted(getattr(out.negated, "preds", out.negated)),
        sorted(out.merged),
        sorted(out.shared),
    )


def replay(path: Path, runs: int) -> None:
    from ssr_compile.compile.instantiate import instantiate
    from ssr_compile.solver.preimage import PlanInvalid, plan_preimage

    sys.setrecursionlimit(100000)
    with open(path, "rb") as f:
        kept = pickle.load(f)
    for name in kept:
        kept[name] = [(*pickle.loads(given), out) for given, out in kept[name]]

    def one(fn, args, kwargs, key):
        try:
            out = fn(*args, **kwargs)
        except (PlanInvalid, Exception) as e:  # noqa: B014 (the captured result is its repr)
            out = repr(e)
        return out if key is None else key(out)

    parts = (
        ("instantiate", instantiate, _instantiation_key),
        ("plan_preimage", plan_preimage, None),
    )
    print(f"{'part':15s} {'calls':>6s} {'best of ' + str(runs):>10s} {'differ':>7s}")
    for name, fn, key in parts:
        calls = kept[name]
        differ = sum(one(fn, a, k, key) != out for a, k, out in calls)
        best = float("inf")
        for _ in range(runs):
            gc.disable()
            start = time.perf_counter()
            try:
                for a, k, _out in calls:
                    try:
                        fn(*a, **k)
                    except Exception:  # noqa: BLE001 (a plan that does not hold)
                        pass
            finally:
                gc.enable()
            best = min(best, time.perf_counter() - start)
        print(f"{name:15s} {len(calls):6d} {best:9.3f}s {differ:7d}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--capture", type=Path, metavar="FILE", help="run an episode, keep its calls")
    ap.add_argument("--replay", type=Path, metavar="FILE", help="time the calls of a capture")
    ap.add_argument("--task", default="cook", help="kitchen task or task file (default cook)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cycles", type=int, default=12, help="cycles of the episode captured")
    ap.add_argument("--runs", type=int, default=3, help="replays of each call (best is kept)")
    ap.add_argument(
        "--full", action="store_true", help="the whole episode (100 cycles) and 5 replays"
    )
    args = ap.parse_args(argv)
    if args.full:
        args.cycles, args.runs = 100, 5
    if not args.capture and not args.replay:
        ap.error("give --capture FILE and/or --replay FILE")
    if args.capture:
        capture(args.capture, args.task, args.seed, args.cycles)
    if args.replay:
        replay(args.replay, args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
