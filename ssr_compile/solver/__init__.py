"""The PDDLStream solver: :func:`solve` with the Focused loop or adaptive sampling (paper §IV,
§VII), its options and replanning state, and the solution it returns.

Modules: :mod:`.options` (what a call is given), :mod:`.results` (what it returns),
:mod:`.preimage` (a plan's preimage and stream plan), :mod:`.deferral` (which results to
evaluate now, §VII), :mod:`.evaluation` and :mod:`.plan_evaluation` (calling the streams),
:mod:`.loop` (what the loops share), :mod:`.focused` and :mod:`.adaptive` (the loops),
:mod:`.dispatch` (the registry of algorithms), :mod:`.report` (a solution as text).
"""

from .dispatch import LOOPS, solve
from .options import ALGORITHMS, EAGER_COST, RESAMPLE, ReplanState, SolveOptions, with_kept
from .report import print_solution
from .results import SOLVED, Solution, Statistics, Step, StreamStats

__all__ = [
    "ALGORITHMS",
    "EAGER_COST",
    "LOOPS",
    "RESAMPLE",
    "SOLVED",
    "ReplanState",
    "Solution",
    "SolveOptions",
    "Statistics",
    "Step",
    "StreamStats",
    "print_solution",
    "solve",
    "with_kept",
]
