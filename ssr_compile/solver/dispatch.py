"""One call of the solver: the loop of the chosen algorithm, from a registry."""

from __future__ import annotations

from .. import syntax as S
from ..stream import StreamsModule
from .adaptive import AdaptiveLoop
from .focused import FocusedLoop
from .loop import SolverLoop
from .options import ALGORITHMS, ReplanState, SolveOptions, with_kept
from .results import Solution

# algorithm name (``SolveOptions.algorithm``) -> the loop that runs one call of :func:`solve`
LOOPS: dict[str, type[SolverLoop]] = {"focused": FocusedLoop, "adaptive": AdaptiveLoop}
assert tuple(LOOPS) == ALGORITHMS


def solve(
    domain: S.Domain,
    streams: S.StreamFile,
    problem: S.Problem,
    module: StreamsModule,
    options: SolveOptions | None = None,
    state: ReplanState | None = None,
) -> Solution:
    """Solve a PDDLStream problem with ``options.algorithm`` (:class:`SolveOptions`).

    ``state`` is what a replanning call inherits from the last (Algorithm 1,
    :class:`ReplanState`): its kept facts join the problem (``s ∪ f_prev``), its tail and
    constants constrain the plan's structure (Algorithm 2), its evaluated results and values
    table are kept.
    Returns a :class:`Solution` with status "solved", "unsolvable" or "timeout".
    """
    options = options or SolveOptions()
    state = state or ReplanState()
    problem, module = with_kept(problem, module, state)
    loop = LOOPS[options.algorithm](domain, streams, problem, module, state, options)
    return loop.run()
