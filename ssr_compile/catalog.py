"""The names of Table I (paper §VIII): the kitchen's tasks (its rows) and the policy's variants
(its columns), defined here once for the simulator, the policy, the CLI and the sweep; and the
range of a seed, the same for every command.

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

# A seed, for every command and example.toml: a whole number from 0 to 2**32 - 1 (the rule
# and its reason: ``ssr_compile.cli.options.SEED_RULE``).
SEED_MAX = 2**32 - 1

__all__ = ["SEED_MAX", "TASKS", "VARIANTS"]
