"""Fingerprint what the shipped examples and a few kitchen episodes do, to compare two commits.

Usage: python tools/replay.py OUT.json [--kitchen TASK:SEED ...]
       python tools/replay.py --diff A.json B.json

For each shipped example, `ssr-compile solve NAME --json` is run and its plans (actions,
arguments, cost), stream calls and planner calls are kept; for each episode (`run --json`),
the outcome, cycles and every cycle's action, plan, stream and planner calls. Times are dropped:
two fingerprints of code that should behave alike must be equal.
"""

from __future__ import annotations

import json
import subprocess
import sys

EXAMPLES = ("tamp2d", "tamp2d-routes", "belief-detect")
EPISODES = ("progress:0", "belief-detect:0", "inspect:0", "stow:1")


def _json(cmd: list[str]) -> dict:
    out = subprocess.run(cmd, capture_output=True, text=True)
    try:
        return json.loads(out.stdout)
    except json.JSONDecodeError:
        return {"exit": out.returncode, "stderr": out.stderr[-400:]}


def _solve(name: str) -> dict:
    doc = _json(["ssr-compile", "solve", name, "--json"])
    keep = ("problem", "status", "cost")
    rows = []
    for r in doc.get("results", []):
        row = {k: r.get(k) for k in keep}
        row["problem"] = str(row["problem"]).rsplit("/", 1)[-1]
        stats = r.get("stats") or {}
        for k in ("iterations", "levels", "planner_calls", "resamples", "sizes"):
            row[k] = stats.get(k)
        row["streams"] = {n: s["calls"] for n, s in (stats.get("streams") or {}).items()}
        row["plan"] = [[s["action"], *s["args"]] for s in r.get("plan") or []]
        rows.append(row)
    return {"results": rows} if rows else doc


def _run(spec: str) -> dict:
    task, seed = spec.split(":")
    doc = _json(["ssr-compile", "run", task, "--seed", seed, "--json"])
    keep = (
        "success",
        "believed",
        "reason",
        "cycles",
        "actions",
        "constrained_held",
        "fallbacks",
        "stream_calls",
        "planner_calls",
    )
    out = {k: doc.get(k) for k in keep}
    out["trace"] = [
        {
            k: c.get(k)
            for k in (
                "action",
                "constrained",
                "stream_calls",
                "planner_calls",
                "plan",
                "cost",
                "failed",
            )
        }
        for c in doc.get("trace", [])
    ]
    return out if "trace" in doc else doc


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help") or (argv[0].startswith("-") and argv[0] != "--diff"):
        # (an option taken for OUT.json once wrote the fingerprint to a file named --help)
        print(__doc__)
        return 0 if argv[:1] in (["-h"], ["--help"]) else 2
    if argv[:1] == ["--diff"]:
        a, b = (json.load(open(p)) for p in argv[1:3])
        same = True
        for key in sorted(set(a) | set(b)):
            if a.get(key) != b.get(key):
                same = False
                print(f"DIFFERS: {key}")
        print("identical" if same else "differences above")
        return 0 if same else 1
    out_path, episodes = argv[0], list(EPISODES)
    if "--kitchen" in argv:
        episodes = argv[argv.index("--kitchen") + 1 :]
    result = {}
    for name in EXAMPLES:
        print(f"solve {name}", file=sys.stderr)
        result[f"solve:{name}"] = _solve(name)
    for spec in episodes:
        print(f"run {spec}", file=sys.stderr)
        result[f"run:{spec}"] = _run(spec)
    with open(out_path, "w") as f:
        json.dump(result, f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
