"""Compile at scale (issue: linear where the output is linear; the instance cap checked while
building): time and peak memory of `ssr-compile compile` on generated problems.

    python bench/scale_bench.py            # gripper 1k/5k objects, tamp2d 100/1000 blocks
    python bench/scale_bench.py --full     # also gripper 20k and tamp2d 5000

Each size runs in a fresh process (`/usr/bin/time`-style: wall seconds and the child's peak
resident memory from getrusage); the generated files live in a temporary folder.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

GRIPPER = """(define (domain gripper) (:requirements :strips)
  (:predicates (room ?r) (ball ?b) (gripper ?g) (at-robby ?r) (at ?b ?r) (free ?g) (carry ?o ?g))
  (:action move :parameters (?from ?to) :precondition (and (room ?from) (room ?to) (at-robby ?from))
    :effect (and (at-robby ?to) (not (at-robby ?from))))
  (:action pick :parameters (?obj ?room ?g)
    :precondition (and (ball ?obj) (room ?room) (gripper ?g) (at ?obj ?room) (at-robby ?room) (free ?g))
    :effect (and (carry ?obj ?g) (not (at ?obj ?room)) (not (free ?g))))
  (:action drop :parameters (?obj ?room ?g)
    :precondition (and (ball ?obj) (room ?room) (gripper ?g) (carry ?obj ?g) (at-robby ?room))
    :effect (and (at ?obj ?room) (free ?g) (not (carry ?obj ?g)))))
"""
EMPTY_STREAMS = "(define (stream none))"


def gripper_problem(n: int) -> str:
    balls = " ".join(f"b{i}" for i in range(n))
    init = " ".join(f"(ball b{i}) (at b{i} rooma)" for i in range(n))
    goal = " ".join(f"(at b{i} roomb)" for i in range(min(n, 4)))
    return (
        f"(define (problem g{n}) (:domain gripper) (:objects rooma roomb left right {balls})"
        f" (:init (room rooma) (room roomb) (gripper left) (gripper right) (free left)"
        f" (free right) (at-robby rooma) {init}) (:goal (and {goal})))"
    )


def tamp2d_problem(n: int) -> str:
    """tamp2d with ``n`` blocks on the table; block b0 to the goal region."""
    blocks = " ".join(f"b{i} p{i}" for i in range(n))
    init = " ".join(
        f"(Block b{i}) (Pose b{i} p{i}) (AtPose b{i} p{i}) (Contained b{i} p{i} rtable)"
        for i in range(n)
    )
    return (
        f"(define (problem t{n}) (:domain tamp2d) (:objects {blocks} q0 rtable rgoal)"
        f" (:init (Region rtable) (Region rgoal) (Conf q0) (AtConf q0) (HandEmpty) {init}"
        f" (= (total-cost) 0)) (:goal (In b0 rgoal)) (:metric minimize (total-cost)))"
    )


def check_rate(domain: Path, problem: Path) -> tuple[float, float, float]:
    """`ssr-compile check` on a big problem: seconds, MB/s, peak MB per MB of input."""
    size = problem.stat().st_size / 1e6
    cmd = [sys.executable, "-m", "ssr_compile.cli", "check", str(domain), str(problem)]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    if proc.returncode != 0:
        raise SystemExit(proc.stderr)
    return wall, size / wall, peak / size


def run(domain: Path, stream: Path, problem: Path, level: int) -> tuple[float, float, str]:
    out = Path(tempfile.mkdtemp(prefix="ssr-scale-out-"))
    cmd = [sys.executable, "-m", "ssr_compile.cli", "compile", str(domain), str(stream),
           str(problem), "-o", str(out / "o"), "--level", str(level)]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    what = "ok" if proc.returncode == 0 else (proc.stderr.strip().splitlines() or ["?"])[-1]
    return wall, max(peak, before) / 1024, what[:90]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--full", action="store_true")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="ssr-scale-"))
    (tmp / "gripper.pddl").write_text(GRIPPER)
    (tmp / "none.pddl").write_text(EMPTY_STREAMS)
    tamp = ROOT / "domains" / "pddl" / "tamp2d"
    print(f"{'problem':22s} {'size':>7s} {'wall s':>8s} {'peak MB':>8s}  outcome")
    sizes = [1000, 5000] + ([20000] if args.full else [])
    for n in sizes:
        path = tmp / f"gripper-{n}.pddl"
        path.write_text(gripper_problem(n))
        wall, mb, what = run(tmp / "gripper.pddl", tmp / "none.pddl", path, 1)
        print(f"{'gripper (no streams)':22s} {n:7d} {wall:8.2f} {mb:8.0f}  {what}")
    for n in [100, 1000] + ([5000] if args.full else []):
        path = tmp / f"tamp2d-{n}.pddl"
        path.write_text(tamp2d_problem(n))
        wall, mb, what = run(tamp / "domain.pddl", tamp / "stream.pddl", path, 1)
        print(f"{'tamp2d, level 1':22s} {n:7d} {wall:8.2f} {mb:8.0f}  {what}")
    print("peak MB: the largest resident size of any compile so far (getrusage of children)")
    print()
    print(f"{'check, gripper':22s} {'MB':>7s} {'wall s':>8s} {'MB/s':>8s} {'peak MB/MB':>10s}")
    for n in [20000] + ([200000] if args.full else []):
        path = tmp / f"gripper-check-{n}.pddl"
        path.write_text(gripper_problem(n))
        wall, rate, per = check_rate(tmp / "gripper.pddl", path)
        print(f"{'':22s} {path.stat().st_size / 1e6:7.1f} {wall:8.2f} {rate:8.2f} {per:10.1f}")


if __name__ == "__main__":
    main()
