"""A solution as text, for people (``ssr-compile solve``)."""

from __future__ import annotations

import sys
from typing import Any

from .results import Solution


def print_solution(solution: Solution, out=sys.stdout) -> None:
    """A human-readable report: plan with values, cost, statistics."""
    st = solution.stats
    if solution.plan is not None:
        print(f"plan ({len(solution.plan)} actions, cost {solution.cost:g}):", file=out)
        if solution.costs_ignored_by:
            print(
                f"  (costs ignored: {solution.costs_ignored_by} plans with unit costs, so a "
                "cheaper plan may exist; the cost above is the plan's under the problem's metric)",
                file=out,
            )
        for i, step in enumerate(solution.plan, 1):
            vals = ", ".join(
                f"{a}={_short(v)}"
                for a, v in zip(step.args, step.values)
                if v is not None and not (isinstance(v, str) and v == a)  # any type (numpy)
            )
            mark = f"  [deferred: {' '.join(step.deferred)}]" if step.deferred else ""
            print(f"  {i:2d}. {step}{mark}", file=out)
            if vals:
                print(f"      {vals}", file=out)
    else:
        print(f"no plan: {solution.message}", file=out)
    print(
        f"iterations {st.iterations}, levels {st.levels[0] if st.levels else 0}..{max(st.levels, default=0)}, "
        f"planner calls {st.planner_calls} ({st.planner_time:.3f} s), streams {st.stream_time:.3f} s, "
        f"total {st.total_time:.3f} s",
        file=out,
    )
    if st.sizes:
        big = max(st.sizes, key=lambda z: (z[1], z[0]))
        print(
            f"largest compiled problem: {big[0]} objects, {big[1]} facts, {big[2]} values"
            + (f", {big[3]} ground actions" if big[3] is not None else "")
            + f"; compilation {st.compile_time:.3f} s",
            file=out,
        )
    for name, s in sorted(st.streams.items()):
        print(
            f"  {name:24s} calls {s.calls:4d}  ok {s.successes:4d}  failed {s.failures:4d}  {s.time:8.4f} s",
            file=out,
        )


def _short(v: Any) -> str:
    text = repr(v)
    if isinstance(v, tuple) and all(isinstance(x, float) for x in v):
        text = "(" + ", ".join(f"{x:.3g}" for x in v) + ")"
    return text if len(text) <= 60 else text[:57] + "..."
