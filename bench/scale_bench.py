"""Compile at scale (issue: linear where the output is linear; the instance cap checked while
building): time and peak memory of `ssr-compile compile` on generated problems.

    python bench/scale_bench.py            # gripper 1k/5k objects, tamp2d 100/1000 blocks
    python bench/scale_bench.py --full     # also gripper 20k and tamp2d 5000
    python bench/scale_bench.py --outfit   # only the footwear-sized classical task (issue 41)

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


# A footwear-sized classical domain (the shape of pddlgym's footwear: four types, unary static
# kinds, a static pairing of socks, actions of 2-6 parameters whose trips need two worn items of
# a kind; plus a negative precondition, which STRIPS targets turn into a complement predicate).
OUTFIT = """(define (domain outfit) (:requirements :strips :typing :negative-preconditions)
  (:types sock shoe foot place)
  (:predicates (plain ?s - sock) (pattern ?s - sock) (pair ?a - sock ?b - sock) (sock-free ?s - sock)
    (formal ?h - shoe) (runner ?h - shoe) (hiker ?h - shoe) (slipper ?h - shoe) (shoe-free ?h - shoe)
    (bare ?f - foot) (socked ?f - foot) (shod ?f - foot) (sock-worn ?s - sock) (shoe-worn ?h - shoe)
    (sock-on ?s - sock ?f - foot) (shoe-on ?h - shoe ?f - foot)
    (home ?p - place) (office ?p - place) (gym ?p - place) (trail ?p - place) (pool ?p - place)
    (at ?p - place) (met-at ?p - place) (trained-at ?p - place) (hiked-at ?p - place)
    (swam-at ?p - place))
  (:action don-sock :parameters (?f - foot ?s - sock ?p - place)
    :precondition (and (at ?p) (home ?p) (bare ?f) (sock-free ?s))
    :effect (and (not (bare ?f)) (not (sock-free ?s)) (socked ?f) (sock-worn ?s) (sock-on ?s ?f)))
  (:action doff-sock :parameters (?f - foot ?s - sock ?p - place)
    :precondition (and (at ?p) (home ?p) (sock-on ?s ?f))
    :effect (and (bare ?f) (sock-free ?s) (not (socked ?f)) (not (sock-worn ?s)) (not (sock-on ?s ?f))))
  (:action don-shoe :parameters (?f - foot ?h - shoe ?p - place)
    :precondition (and (at ?p) (home ?p) (socked ?f) (shoe-free ?h))
    :effect (and (not (socked ?f)) (not (shoe-free ?h)) (shod ?f) (shoe-worn ?h) (shoe-on ?h ?f)))
  (:action doff-shoe :parameters (?f - foot ?s - sock ?h - shoe ?p - place)
    :precondition (and (at ?p) (home ?p) (sock-on ?s ?f) (shoe-on ?h ?f))
    :effect (and (not (shod ?f)) (not (shoe-worn ?h)) (not (shoe-on ?h ?f)) (socked ?f)
      (shoe-free ?h)))
  (:action go-home :parameters (?from - place ?to - place)
    :precondition (and (at ?from) (home ?to) (not (at ?to)))
    :effect (and (not (at ?from)) (at ?to)))
  (:action go-office :parameters (?from - place ?to - place ?s1 - sock ?s2 - sock ?h1 - shoe ?h2 - shoe)
    :precondition (and (at ?from) (office ?to) (not (at ?to)) (pair ?s1 ?s2) (sock-worn ?s1)
      (sock-worn ?s2) (formal ?h1) (formal ?h2) (shoe-worn ?h1) (shoe-worn ?h2))
    :effect (and (not (at ?from)) (at ?to) (met-at ?to)))
  (:action go-gym :parameters (?from - place ?to - place ?h1 - shoe ?h2 - shoe)
    :precondition (and (at ?from) (gym ?to) (not (at ?to)) (runner ?h1) (runner ?h2)
      (shoe-worn ?h1) (shoe-worn ?h2))
    :effect (and (not (at ?from)) (at ?to) (trained-at ?to)))
  (:action go-trail :parameters (?from - place ?to - place ?h1 - shoe ?h2 - shoe)
    :precondition (and (at ?from) (trail ?to) (not (at ?to)) (hiker ?h1) (hiker ?h2)
      (shoe-worn ?h1) (shoe-worn ?h2))
    :effect (and (not (at ?from)) (at ?to) (hiked-at ?to)))
  (:action go-pool :parameters (?from - place ?to - place ?h1 - shoe ?h2 - shoe)
    :precondition (and (at ?from) (pool ?to) (not (at ?to)) (slipper ?h1) (slipper ?h2)
      (shoe-worn ?h1) (shoe-worn ?h2))
    :effect (and (not (at ?from)) (at ?to) (swam-at ?to))))
"""


def outfit_problem(places: int = 7, socks: int = 22, shoes: int = 16) -> str:
    """``places`` places of each of four kinds and a home, ``socks`` socks in matching pairs,
    ``shoes`` shoes of four kinds (the defaults: a 3 KB problem, whose ground task is about
    the 28 MB of issue 41's footwear problem; (13, 38, 34) is about pddlgym's largest)."""
    kinds = ["office", "gym", "trail", "pool"]
    objs = ["home - place", "f1 - foot", "f2 - foot"]
    init = ["(at home)", "(home home)", "(bare f1)", "(bare f2)"]
    for k in kinds:
        for i in range(places):
            objs.append(f"{k}{i} - place")
            init.append(f"({k} {k}{i})")
    for i in range(socks):
        objs.append(f"s{i} - sock")
        init += [f"(sock-free s{i})", f"({'plain' if i % 3 else 'pattern'} s{i})"]
        mate = i + 1 if i % 2 == 0 else i - 1
        if mate < socks:
            init.append(f"(pair s{i} s{mate})")
    shoe_kinds = ["formal", "runner", "hiker", "slipper"]
    for i in range(shoes):
        objs.append(f"h{i} - shoe")
        init += [f"(shoe-free h{i})", f"({shoe_kinds[(i // 2) % 4]} h{i})"]
    return (
        f"(define (problem outfit-{places}-{socks}-{shoes}) (:domain outfit)\n"
        f"  (:objects {' '.join(objs)})\n  (:init {' '.join(init)})\n"
        f"  (:goal (and (trained-at gym{places // 2}) (hiked-at trail{places - 2}))))\n"
    )


def compile_size(domain: Path, stream: Path, problem: Path, target: str):
    """`compile --for TARGET` in a fresh process: wall seconds, output KB (domain + problem +
    the JSON maps), and the outcome."""
    out = Path(tempfile.mkdtemp(prefix="ssr-scale-out-"))
    cmd = [sys.executable, "-m", "ssr_compile.cli", "compile", str(domain), str(stream),
           str(problem), "-o", str(out / "o"), "--for", target]  # fmt: skip
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        return wall, 0.0, (proc.stderr.strip().splitlines() or ["?"])[-1][:90]
    size = sum(p.stat().st_size for p in (out / "o").iterdir()) / 1e3
    pddl = sum(p.stat().st_size for p in (out / "o").glob("*.pddl")) / 1e3
    return wall, size, f"ok, PDDL {pddl:.0f} KB"


def outfit_rows(tmp: Path) -> None:
    (tmp / "outfit.pddl").write_text(OUTFIT)
    print(f"{'outfit (footwear-sized)':26s} {'target':18s} {'wall s':>7s} {'out KB':>9s}  outcome")
    for sizes in [(7, 22, 16), (13, 38, 34)]:
        path = tmp / f"outfit-{'-'.join(map(str, sizes))}.pddl"
        path.write_text(outfit_problem(*sizes))
        kb = path.stat().st_size / 1e3
        for target in ["up:fast-downward", "pyperplan"]:
            wall, size, what = compile_size(tmp / "outfit.pddl", tmp / "none.pddl", path, target)
            print(f"{f'{sizes}, {kb:.1f} KB':26s} {target:18s} {wall:7.2f} {size:9.0f}  {what}")


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
    ap.add_argument("--outfit", action="store_true", help="only the footwear-sized task")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="ssr-scale-"))
    (tmp / "gripper.pddl").write_text(GRIPPER)
    (tmp / "none.pddl").write_text(EMPTY_STREAMS)
    outfit_rows(tmp)
    if args.outfit:
        return
    print()
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
