"""The one contract of the compile passes (unified-planning's compilers are the model: their
``CompilerResult`` is the new problem plus a map back to the original actions).

Every pass takes a task (a domain and a problem) and returns a :class:`PassResult`: the task it
made and :meth:`PassResult.map_plan`, which turns a plan of that task into a plan of the task
the pass was given.  A pass that needs to say more subclasses it with fields of its own (the
instantiation's provenance, the costs' scale, the renaming...).  :func:`map_back` chains the
map-backs of passes run one after the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from .. import syntax as S

# A plan: (action name, arguments) per step.
Plan = list[tuple[str, tuple[str, ...]]]


@dataclass
class PassResult:
    """A pass's output task, and the map from its plans back to plans of the pass's input."""

    domain: S.Domain
    problem: S.Problem | None

    @property
    def task(self) -> tuple[S.Domain, S.Problem | None]:
        """``(domain, problem)``: the next pass's input."""
        return self.domain, self.problem

    def map_plan(self, plan: Sequence[tuple[str, Sequence[str]]]) -> Plan:
        """A plan of :attr:`domain` and :attr:`problem` as a plan of the pass's input.

        The default is for passes that rename no action and change no argument: the same
        steps (arguments as tuples)."""
        return [(name, tuple(args)) for name, args in plan]


def map_back(results: Sequence[PassResult], plan: Sequence[tuple[str, Sequence[str]]]) -> Plan:
    """A plan of the last of ``results`` (passes in the order they ran) as a plan of the first
    pass's input: each pass's :meth:`~PassResult.map_plan`, last pass first."""
    out = [(name, tuple(args)) for name, args in plan]
    for result in reversed(results):
        out = result.map_plan(out)
    return out
