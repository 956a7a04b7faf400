"""The names of Table I (paper §VIII): the kitchen's tasks (its rows) and the policy's variants
(its columns), defined here once for the simulator, the policy, the CLI and the sweep.

Imports nothing, so that naming a task or a variant does not load PyBullet or the solver.
"""

from __future__ import annotations

# The four tasks of the paper's appendix, in Table I's row order.
TASKS = ("inspect", "stow", "swap", "cook")

# The policy's variants, in Table I's column order:
# name -> (plan constraints, deferred streams).
VARIANTS: dict[str, tuple[bool, bool]] = {
    "neither": (False, False),
    "constraints": (True, False),
    "deferred": (False, True),
    "both": (True, True),
}

__all__ = ["TASKS", "VARIANTS"]
