"""Self-loop determinization (paper §V-A): the deterministic cost of a stochastic action."""

from __future__ import annotations

import math


def self_loop_cost(cost: float, recovery_cost: float, probability: float) -> float:
    """Determinized cost of an action that succeeds with probability ``probability``.

    Self-loop determinization (paper §V-A): a failed attempt costs ``recovery_cost`` and leaves
    the state unchanged, so the expected cost of reaching the intended outcome is
    ``c + sum_{t>=1} c' (1-p)^t = c + c'/p - c'``.  ``probability`` must be a lower bound on the
    probability of success; a probability of 0 gives an infinite cost (never plan on it).
    """
    if cost < 0 or recovery_cost < 0:
        raise ValueError(f"costs must be non-negative, got c={cost}, c'={recovery_cost}")
    if not 0.0 <= probability <= 1.0 or math.isnan(probability):
        raise ValueError(f"probability must lie in [0, 1], got {probability}")
    if probability == 0.0:
        return math.inf
    return cost + recovery_cost / probability - recovery_cost
