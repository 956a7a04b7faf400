"""What a planner backend accepts: the one ``Capabilities`` type of the compiler and the
backends (the lowering fits a task to it; a backend declares it)."""

from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Capabilities:
    """The PDDL features a backend accepts (and whether its plans are cost-optimal).

    The defaults accept everything: ``Capabilities()`` compiles for Fast Downward-like
    backends and for artifacts."""

    costs: bool = True
    axioms: bool = True
    negative_preconditions: bool = True
    disjunction: bool = True
    quantifiers: bool = True
    conditional_effects: bool = True
    optimal: bool = False
    # Give the backend a ground task (compile/ground.py): for planners that cannot take
    # quantifiers and axioms, and for readers that enumerate every grounding themselves.
    ground: bool = False

    def as_dict(self) -> dict[str, bool]:
        return asdict(self)
