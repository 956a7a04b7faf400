"""The Python stream API (paper §IV; docs/design.md §4 "Streams").

A stream declared in a stream file is implemented by a Python callable bound by name:

* generator stream — ``f(*inputs)`` returns an iterable (possibly endless, possibly lazy) of
  output tuples;
* function stream — returns one output tuple, or ``None`` when it fails (a stream whose
  :class:`StreamInfo` says ``kind="function"``, or any callable that returns a tuple or None);
* test stream (no outputs) — returns a bool;
* cost function (``:function``) — returns a number (``None`` or infinity: not applicable).

An output value is any Python value but None, an iterator, or a number that is not finite
(NaN, infinity; also inside tuples, lists, dicts and numpy arrays): such a value, an output
that is not a tuple, or a value ``return``-ed from a generator function is the stream's
error (:class:`StreamError`; the solver reports it as the stream's fault, exit 3), raised at
the draw that produced it.

A *streams module* binds them.  The plain form always works: a Python module (import path or
file path) with a dict ``STREAMS`` (stream name -> callable), an optional dict ``STREAM_INFO``
(name -> :class:`StreamInfo` or a dict of its fields) and an optional dict ``VALUES`` (object
name of the problem -> Python value; objects not in ``VALUES`` are passed as their names).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import math
import sys
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from . import syntax as S
from .errors import StreamError


@dataclass(frozen=True)
class StreamInfo:
    """What the solver knows of a stream before calling it.

    ``deferrable``: may its evaluation wait until the next replanning (paper §VII)?  Mark only
    streams that are expensive *and* almost always succeed (motion planning).
    ``p_success``: probability that a call succeeds (orders the stream plan: likely failures
    first).  0: the stream is instantiated over real inputs only, never over an optimistic
    one (pddlstream's ``p_success=0``, whose effort is infinite: continuous_tamp's
    ``t-region``, which a placement drawn for another region fails).  ``cost``: expected
    cost of a call, in seconds or any consistent unit.
    ``optimistic_value``: for a cost function, the value planned with before evaluation (a
    lower bound; default 1).  ``kind``: "generator" (default for streams with outputs),
    "function" (at most one output tuple), or "test".  ``constant_outputs``: the outputs are
    *constants* in the sense of paper §VI-A (grasps: still valid after new observations; not
    poses, configurations or trajectories); the online policy keeps them and their facts
    from one replanning cycle to the next (Algorithm 1's ``ConstantFacts``).
    ``redraw_inputs``: when the stream finds nothing and cannot be asked again (a function),
    its failure is its inputs' fault (tamp2d's ik of a placement out of reach): the input
    drawn last in the stream plan is drawn again at once, as after a test's rejection.  Off
    by default: re-drawing an input re-evaluates everything downstream of it, which costs
    more than planning again where that includes motion planning (the kitchen).
    ``eager``: the Focused solver evaluates the stream (one draw) as soon as its domain holds
    in the real facts, before planning, as it does cheap tests; a failure is then never
    planned with.  For a stream whose instances are few, cheap, and fail often where a plan
    would use them (the kitchen's streams acting from the configuration the robot is in:
    otherwise each failure cost a planner call).
    ``optimistic``: the stream's optimistic stand-in (pddlstream's ``opt_gen_fn``, and a
    function's ``FunctionInfo`` ``opt_fn``), a callable taking the same arguments as the
    stream.  Optimistic instantiation calls it on the values of an instance's inputs -- real
    values, or the stand-in values of optimistic objects -- instead of assuming the best:
    for a stream with outputs, it returns the tuple of values that stand in for the outputs
    (or None: no optimistic output; optimistic outputs with equal stand-in values are one
    object), so later streams, tests and cost functions see them; for a test, whether the
    optimistic fact holds (False: not certified, so no plan relies on it); for a cost
    function, the value planned with (None or infinity: not applicable).  An input without
    a stand-in value (an output of a stream that has no ``optimistic``) falls back to the
    defaults.  The real stream is still called on real values only; a stand-in just guides
    the planner, and should be optimistic (a noise-free belief update, a cost not above the
    real one) so no solution is pruned.
    """

    deferrable: bool = False
    p_success: float = 1.0
    cost: float = 1.0
    optimistic_value: float | None = None
    kind: str | None = None
    constant_outputs: bool = False
    redraw_inputs: bool = False
    eager: bool = False
    optimistic: Callable | None = None

    def __post_init__(self):
        p = self.p_success
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 <= p <= 1.0:
            raise ValueError(f"StreamInfo p_success must be a number from 0 to 1, not {p!r}")

    @classmethod
    def of(cls, value: StreamInfo | Mapping[str, Any] | None, name: str) -> StreamInfo:
        if value is None:
            return cls()
        if isinstance(value, StreamInfo):
            return value
        if isinstance(value, Mapping):
            known = {f.name for f in fields(cls)}
            unknown = set(value) - known
            if unknown:
                raise StreamError(
                    f"STREAM_INFO['{name}'] has unknown field(s) {sorted(unknown)}; expected {sorted(known)}"
                )
            try:
                return cls(**value)
            except ValueError as e:
                raise StreamError(f"STREAM_INFO['{name}']: {e}") from None
        raise StreamError(
            f"STREAM_INFO['{name}'] must be a StreamInfo or a dict, not {type(value).__name__}"
        )


@dataclass
class StreamsModule:
    """Stream implementations, their info, and the Python values of problem objects."""

    name: str
    streams: dict[str, Callable] = field(default_factory=dict)
    info: dict[str, StreamInfo] = field(default_factory=dict)
    values: dict[str, Any] = field(default_factory=dict)
    module: Any = None
    _checked: set = field(default_factory=set, repr=False, compare=False)

    def info_for(self, name: str) -> StreamInfo:
        return self.info.get(name, StreamInfo())

    def check_against(self, stream_file: S.StreamFile, filename: str | None = None) -> None:
        """Every stream and function the file declares must have a callable (checked once per
        stream file: the CLI checks with the file's name, the solver again without)."""
        if stream_file in self._checked:
            return
        declared = [s.name for s in stream_file.streams] + [f.name for f in stream_file.functions]
        declared += [p.name for p in stream_file.predicates]
        missing = [n for n in declared if n not in self.streams]
        if missing:
            first = next(
                x
                for x in (*stream_file.streams, *stream_file.functions, *stream_file.predicates)
                if x.name == missing[0]
            )
            raise StreamError(
                f"the streams module '{self.name}' does not implement {', '.join(missing)} "
                f"(its STREAMS has: {', '.join(sorted(self.streams)) or 'nothing'})",
                file=filename,
                line=first.span.line if first.span else None,
                col=first.span.col if first.span else None,
            )
        for name, fn in self.streams.items():
            if not callable(fn):
                raise StreamError(f"STREAMS['{name}'] in '{self.name}' is not callable")
        known = set(declared) | set(self.streams)
        unknown = [k for k in self.info if k not in known]
        if unknown:  # a misspelled name would otherwise be silently ignored
            raise StreamError(
                f"STREAM_INFO in '{self.name}' names {', '.join(repr(k) for k in unknown)}, "
                f"which {'is' if len(unknown) == 1 else 'are'} neither declared in "
                f"{filename or 'the stream file'} nor in its STREAMS (the names that exist: "
                f"{', '.join(sorted(known)) or 'none'})",
                file=filename,
            )
        predicates = {p.name for p in stream_file.predicates}
        for name, info in self.info.items():
            if info.optimistic is None:
                continue
            if not callable(info.optimistic):
                raise StreamError(
                    f"STREAM_INFO['{name}'] in '{self.name}': its optimistic stand-in is "
                    f"{_brief(info.optimistic)} ({type(info.optimistic).__name__}); expected a "
                    "callable taking the stream's arguments",
                    file=filename,
                )
            if name in predicates:
                raise StreamError(
                    f"STREAM_INFO['{name}'] in '{self.name}' gives an optimistic stand-in to "
                    f"the :predicate '{name}'; expected one for a stream, a test or a cost "
                    "function only (a predicate over optimistic values keeps its permissive "
                    "value and is checked in the stream plan)",
                    file=filename,
                )
        self._checked.add(stream_file)


def load_streams_module(spec: str, *, search: list[Path] | None = None) -> StreamsModule:
    """Import a streams module by import path (``ssr_compile.streams.tamp2d``) or file path (``x/y.py``)."""
    try:
        if spec.endswith(".py") or "/" in spec or Path(spec).exists():
            path = Path(spec)
            if not path.exists():
                raise StreamError(f"streams module file '{spec}' does not exist")
            mod_name = f"_ssr_streams_{path.stem}_{abs(hash(str(path.resolve())))}"
            loader_spec = importlib.util.spec_from_file_location(mod_name, path)
            if loader_spec is None or loader_spec.loader is None:
                raise StreamError(f"cannot import '{spec}' as a Python module")
            module = importlib.util.module_from_spec(loader_spec)
            sys.modules[mod_name] = module
            loader_spec.loader.exec_module(module)
        else:
            added = []
            for p in search or []:
                if str(p) not in sys.path:
                    sys.path.insert(0, str(p))
                    added.append(str(p))
            try:
                module = importlib.import_module(spec)
            finally:
                for p in added:
                    sys.path.remove(p)
    except StreamError:
        raise
    except ModuleNotFoundError as e:
        raise StreamError(f"cannot import streams module '{spec}': {e}") from None
    except Exception as e:  # the module itself failed while importing
        raise StreamError(
            f"streams module '{spec}' failed to import: {type(e).__name__}: {e}"
        ) from None
    except SystemExit as e:  # sys.exit() in the module's top level: its fault, not a success
        raise StreamError(
            f"streams module '{spec}' called sys.exit({e.code!r}) while being imported"
        ) from None
    return from_module(module, spec)


def module_for_problem(
    spec: str, problem_path: str | Path, seed: int = 0, *, search: list[Path] | None = None
) -> StreamsModule:
    """The streams module ``spec`` made ready for one problem.

    A module whose streams depend on the seed or the problem provides a factory
    ``make_module(seed, problem)`` (``problem``: the problem file's path) returning the
    :class:`StreamsModule` to use -- no module globals.  Older protocols still work:
    ``for_problem(path, seed)``, and a ``seed(n)`` hook called before the module's
    ``STREAMS`` are read.
    """
    module = load_streams_module(spec, search=search)
    make = getattr(module.module, "make_module", None)
    if callable(make) and _takes(make, "seed", "problem"):
        factory = lambda: make(seed=seed, problem=str(problem_path))  # noqa: E731
    elif callable(getattr(module.module, "for_problem", None)):
        factory = lambda: module.module.for_problem(problem_path, seed)  # noqa: E731
    else:
        seed_fn = getattr(module.module, "seed", None)
        if callable(seed_fn):
            seed_fn(seed)
        return module
    try:
        made = factory()
    except (ValueError, OSError) as e:
        raise StreamError(f"streams module '{spec}' cannot serve {problem_path}: {e}") from None
    if not isinstance(made, StreamsModule):
        raise StreamError(
            f"streams module '{spec}': its factory returned {type(made).__name__}, "
            "expected a StreamsModule"
        )
    return made


def _takes(fn: Callable, *names: str) -> bool:
    """Whether ``fn`` accepts every one of ``names`` as a keyword argument."""
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return all(n in params and params[n].kind in kinds for n in names)


def from_module(module, name: str | None = None) -> StreamsModule:
    """Read ``STREAMS``, ``STREAM_INFO`` and ``VALUES`` from an imported module (or object)."""
    name = name or getattr(module, "__name__", "streams")
    streams = getattr(module, "STREAMS", None)
    if not isinstance(streams, Mapping):
        raise StreamError(f"streams module '{name}' has no dict STREAMS (stream name -> callable)")
    info_raw = getattr(module, "STREAM_INFO", {}) or {}
    if not isinstance(info_raw, Mapping):
        raise StreamError(f"STREAM_INFO in '{name}' must be a dict")
    values = getattr(module, "VALUES", {}) or {}
    if not isinstance(values, Mapping):
        raise StreamError(f"VALUES in '{name}' must be a dict")
    known = {str(k).lower() for k in streams}
    unknown = [str(k) for k in info_raw if str(k).lower() not in known]
    if unknown:  # a misspelled name would otherwise be silently ignored
        raise StreamError(
            f"STREAM_INFO in '{name}' names {', '.join(repr(k) for k in unknown)}, which "
            f"{'is' if len(unknown) == 1 else 'are'} not in its STREAMS (the names that exist: "
            f"{', '.join(sorted(known)) or 'none'})"
        )
    return StreamsModule(
        name,
        {k.lower(): v for k, v in streams.items()},
        {k.lower(): StreamInfo.of(v, k) for k, v in info_raw.items()},
        {k.lower(): v for k, v in values.items()},
        module,
    )


# ---------------------------------------------------------------- values and names


class ValueTable:
    """Python values keyed by object name (docs/design.md §4 "Values and names").

    Objects of the problem map to their ``VALUES`` entry (or to their own name); every new
    value a stream produces gets a fresh name ``v<N>`` (equal hashable values share a name).
    """

    def __init__(self, values: Mapping[str, Any], taken: set[str]):
        self._by_name: dict[str, Any] = dict(values)
        self._by_value: dict[Any, str] = {}
        self._taken = set(taken) | set(values)
        self._count = 0
        for n, v in self._by_name.items():
            key = _key(v)
            if key is not None:
                self._by_value.setdefault(key, n)

    def value(self, name: str) -> Any:
        return self._by_name.get(name, name)

    def __contains__(self, name: str) -> bool:
        return name in self._by_name

    def name_for(self, value: Any, hint: str = "v") -> str:
        key = _key(value)
        if key is not None and key in self._by_value:
            return self._by_value[key]
        prefix = "".join(ch for ch in hint.lstrip("?").lower() if ch.isalnum() or ch == "-") or "v"
        if not prefix[0].isalpha():
            prefix = "v" + prefix
        while True:
            self._count += 1
            name = f"{prefix}-{self._count}"
            if name not in self._taken:
                break
        self._taken.add(name)
        self._by_name[name] = value
        if key is not None:
            self._by_value[key] = name
        return name

    def names(self) -> list[str]:
        return list(self._by_name)


def _key(value: Any):
    try:
        hash(value)
    except TypeError:
        return None
    if isinstance(value, float) and math.isnan(value):
        return None
    return (type(value).__name__, value)


# ---------------------------------------------------------------- calling streams


class Generator:
    """The outputs of one stream instance, drawn one tuple at a time (lazily)."""

    def __init__(self, fn: Callable, args: tuple, kind: str, name: str):
        self.fn = fn
        self.args = args
        self.kind = kind
        self.name = name
        self.calls = 0
        self.exhausted = False
        self._it: Iterator | None = None

    def next(self) -> tuple | None:
        """The next output tuple, or None (failure now; ``exhausted`` says if for good)."""
        self.calls += 1
        if self.exhausted:
            return None
        try:
            if self.kind == "function":
                self.exhausted = True
                out = self.fn(*self.args)
                return _as_tuple(out, self.name, "returned")
            if self._it is None:
                produced = self.fn(*self.args)
                if produced is None:
                    self.exhausted = True
                    return None
                if isinstance(produced, tuple) or not (
                    inspect.isgenerator(produced) or hasattr(produced, "__iter__")
                ):
                    # A callable that returns one tuple behaves as a function stream.
                    self.exhausted = True
                    return _as_tuple(produced, self.name, "returned")
                self._it = iter(produced)
            out = next(self._it)
        except StopIteration as e:
            self.exhausted = True
            if e.value is not None:  # `return x` in a generator function: x is lost
                raise StreamError(
                    f"stream '{self.name}' returned {_brief(e.value)} "
                    f"({type(e.value).__name__}) from its generator, where the value is lost; "
                    "expected it to yield output tuples (a bare `return` ends it)"
                ) from None
            return None
        except StreamError:
            raise
        except Exception as e:
            raise StreamError(f"stream '{self.name}' raised {type(e).__name__}: {e}") from e
        except SystemExit as e:
            raise _exited(f"stream '{self.name}'", e) from None
        if out is None:  # a generator may yield None to say "nothing this time"
            return None
        return _as_tuple(out, self.name, "yielded")


def _as_tuple(out, name: str, how: str = "produced") -> tuple | None:
    """A stream's output tuple, its values checked (:func:`bad_value`): anything else is the
    stream's error, naming the stream, what it produced and what was expected."""
    if out is None:
        return None
    if isinstance(out, list):
        out = tuple(out)
    if not isinstance(out, tuple):
        raise StreamError(
            f"stream '{name}' {how} {_brief(out)} ({type(out).__name__}); expected a tuple "
            "of its output values, e.g. (x,) for one output"
        )
    for i, value in enumerate(out):
        wrong = bad_value(value)
        if wrong:
            raise StreamError(
                f"stream '{name}' {how} {_brief(out)}: its output {i + 1} is {wrong}; "
                "expected a value (finite numbers only, no None, no iterators)"
            )
    return out


def bad_value(value: Any, depth: int = 0) -> str | None:
    """What makes ``value`` no value a stream may produce, or None when it is one: None, a
    NaN or an infinity (in a number, a numpy array, or nested in tuples, lists and dicts),
    or an iterator (to be drawn from, not a value).  Other objects are taken as they are."""
    if value is None:
        return "None"
    kind = type(value)
    if kind is float:
        return None if math.isfinite(value) else f"the non-finite number {value}"
    if kind in (int, bool, str, bytes) or depth > 6:
        return None
    if isinstance(value, (tuple, list)):
        for x in value:
            wrong = bad_value(x, depth + 1)
            if wrong:
                return f"{_brief(value)}, which holds {wrong}"
        return None
    if isinstance(value, Mapping):
        return bad_value(tuple(value.values()), depth)
    if kind.__module__ == "numpy":
        return _bad_numpy(value)
    if isinstance(value, float):  # a float subclass
        return None if math.isfinite(value) else f"the non-finite number {value}"
    if isinstance(value, Iterator):
        return f"an iterator ({kind.__name__})"
    return None


def _bad_numpy(value: Any) -> str | None:
    np = sys.modules["numpy"]
    dtype = getattr(value, "dtype", None)
    if dtype is None or dtype.kind not in "fc":
        return None
    if np.all(np.isfinite(value)):
        return None
    what = "an array" if getattr(value, "ndim", 0) else "the number"
    return f"{what} with a non-finite number ({_brief(value)})"


def _exited(what: str, e: SystemExit) -> StreamError:
    """A stream that calls sys.exit() (or raises SystemExit) has failed, it does not end ssr-compile."""
    return StreamError(
        f"{what} called sys.exit({e.code!r}); a stream must return (or raise), not exit"
    )


def _brief(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def call_test(fn: Callable, args: tuple, name: str, what: str = "test stream") -> bool:
    """A test stream's answer: True or False (a numpy bool counts); anything else is an error
    of the stream (a string such as "False" is not taken as true).  ``what``: how errors name
    it (a stream-file ``:predicate`` is checked alike)."""
    try:
        value = fn(*args)
    except Exception as e:
        raise StreamError(f"{what} '{name}' raised {type(e).__name__}: {e}") from e
    except SystemExit as e:
        raise _exited(f"{what} '{name}'", e) from None
    if isinstance(value, bool):
        return value
    kind = type(value)
    if kind.__module__ == "numpy" and kind.__name__ in ("bool_", "bool"):
        return bool(value)
    raise StreamError(
        f"{what} '{name}' returned {_brief(value)} ({kind.__name__}); "
        f"a {what} must return True or False"
    )


def call_function(fn: Callable, args: tuple, name: str) -> float | None:
    """A cost function's value; None and infinity mean not applicable.  NaN, a negative
    cost or a value that is not a number (a bool, a string) is an error of the function."""
    try:
        value = fn(*args)
    except Exception as e:
        raise StreamError(f"cost function '{name}' raised {type(e).__name__}: {e}") from e
    except SystemExit as e:
        raise _exited(f"cost function '{name}'", e) from None
    if value is None:
        return None
    if isinstance(value, (bool, str, bytes)) or (
        type(value).__module__ == "numpy"
        and getattr(value, "dtype", None) is not None
        and value.dtype.kind not in "iuf"
    ):
        raise StreamError(
            f"cost function '{name}' returned {_brief(value)} ({type(value).__name__}), "
            "expected a number"
        )
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise StreamError(f"cost function '{name}' returned {value!r}, expected a number") from None
    if math.isnan(value):
        raise StreamError(
            f"cost function '{name}' returned nan, expected a number (None or inf: not applicable)"
        )
    if math.isinf(value):
        return None
    if value < 0:
        raise StreamError(f"cost function '{name}' returned the negative cost {value}")
    return value
