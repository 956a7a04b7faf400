"""Optimistic stand-ins (:attr:`~ssr_compile.stream.StreamInfo.optimistic`): the values that
optimistic instantiation gives the outputs of a stream instance, the outcome of a test and the
value of a cost function, computed by the user's stand-in over the values of their inputs --
real values, or the stand-in values of optimistic objects (pddlstream's ``opt_gen_fn``).

:class:`StandIns` calls the stand-ins; :func:`~ssr_compile.compile.instantiate.instantiate`
keeps the stand-in value of each optimistic object it makes (``Instantiation.standins``)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from ..errors import StreamError, StreamFailure
from ..stream import StreamsModule, _as_tuple, _key, call_function, call_test

# an input with no stand-in value (an optimistic output of a stream without a stand-in)
MISSING = object()


class StandIns:
    """The stand-ins of one streams module; ``value(name)``: a real object's Python value."""

    def __init__(self, fns: Mapping[str, Callable], value: Callable[[str], Any]):
        self.fns = dict(fns)
        self.value = value

    @classmethod
    def of(cls, module: StreamsModule, value: Callable[[str], Any]) -> StandIns | None:
        """The stand-ins ``module``'s stream info declares (None when there are none)."""
        fns = {n: i.optimistic for n, i in module.info.items() if i.optimistic is not None}
        return cls(fns, value) if fns else None

    def __contains__(self, name: str) -> bool:
        return name in self.fns

    def outputs(self, name: str, args: tuple, arity: int) -> tuple | None:
        """The stand-in values of the outputs of stream ``name`` over ``args`` (None: none)."""
        try:
            out = _as_tuple(self.fns[name](*args), name, "(its optimistic stand-in) returned")
        except StreamError as e:
            raise StreamFailure(name, e.message) from e
        except Exception as e:
            raise StreamFailure(
                name, f"stream '{name}': its optimistic stand-in raised {type(e).__name__}: {e}"
            ) from e
        if out is not None and len(out) != arity:
            raise StreamFailure(
                name,
                f"stream '{name}': its optimistic stand-in returned {len(out)} output(s), its "
                f"declaration has {arity}",
            )
        return out

    def test(self, name: str, args: tuple) -> bool:
        """Whether the optimistic fact of test ``name`` over ``args`` holds."""
        try:
            return call_test(self.fns[name], args, name)
        except StreamError as e:
            raise StreamFailure(name, f"the optimistic stand-in of {e.message}") from e

    def cost(self, name: str, args: tuple) -> float:
        """The optimistic value of cost function ``name`` over ``args`` (inf: not applicable)."""
        try:
            value = call_function(self.fns[name], args, name)
        except StreamError as e:
            raise StreamFailure(name, f"the optimistic stand-in of {e.message}") from e
        return math.inf if value is None else value


def value_key(value: Any):
    """What equal stand-in values share (None: a value that cannot be compared)."""
    return _key(value)
