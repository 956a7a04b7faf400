"""Example folders: ``domain.pddl``, ``stream.pddl``, problems and ``example.toml``.

``example.toml`` keys (:data:`KEYS`): ``streams`` (the streams module, an import path or a
``.py`` file of the folder), ``problems`` (file names), optional solver settings
(:data:`SOLVER_KEYS`: ``planner``, ``time_limit``, ``level``, ``max_level``, ...) and, for the
online policy, ``environment``: a factory ``"module:function"`` called as
``function(problem, seed)`` that returns an :class:`ssr_compile.policy.Episode` (an
environment and the agent acting in it).

An example is found (:func:`resolve_folder`) and its ``example.toml`` read and checked
(:func:`read_settings`, :func:`check_table`: an unknown key, a wrong type or range is bad
input) here only: ``solve``, ``run`` and ``experiment`` all come through here, and resolve
flags against it alike (:meth:`ExampleSettings.resolve`).  An example folder is
self-contained: its modules import by name while its streams module or environment factory
is imported or called (:func:`example_imports`; the folder does not stay on ``sys.path``).
"""

from __future__ import annotations

import difflib
import functools
import importlib
import importlib.util
import math
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import syntax as S
from .catalog import SEED_MAX
from .errors import SSRError

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]


# Every shipped example problem with the instantiation level at which it has an optimistic
# plan (Stow and Cook need deeper stream chains): the backend matrix (tests, bench) runs these.
SHIPPED_PROBLEMS: tuple[tuple[str, str, int], ...] = (
    ("tamp2d", "problem.pddl", 3),
    ("tamp2d", "problem-blocked.pddl", 3),
    ("tamp2d-routes", "problem.pddl", 3),
    ("belief-detect", "problem-occluded.pddl", 3),
    ("belief-detect", "problem-clear.pddl", 3),
    ("progress", "problem.pddl", 3),
    ("kitchen", "problem-inspect.pddl", 3),
    ("kitchen", "problem-swap.pddl", 3),
    ("kitchen", "problem-stow.pddl", 5),
    ("kitchen", "problem-cook.pddl", 5),
)


# The solver settings example.toml may give (``ssr-compile solve`` has a flag for each).
SOLVER_KEYS = (
    "planner",
    "time_limit",
    "level",
    "max_level",
    "max_cost",
    "defer",
    "algorithm",
    "resample",
    "seed",
)
SETTINGS_FILE = "example.toml"
# Every key example.toml may hold, and what its value must be (said when it is not).
KEYS: dict[str, str] = {
    "streams": "the streams module: an import path or a .py file of the folder (a string)",
    "problems": "a list of the folder's problem files",
    "environment": 'the episode factory, "module:function" (a string)',
    "planner": "a planner backend's name (`ssr-compile planners`)",
    "time_limit": "a finite number of seconds greater than 0",
    "level": "a whole number >= 0",
    "max_level": "a whole number >= 0",
    "max_cost": "a number greater than 0 (inf: no bound)",
    "defer": "true or false",
    "algorithm": "focused or adaptive",
    "resample": "a whole number >= 0",
    "seed": "a whole number from 0 to 2**32 - 1",
}


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _check_value(key: str, value: Any, folder: Path | None) -> Any:
    """``value`` as ``key`` takes it; ValueError (what is wrong) when it is not one."""
    if key in ("streams", "environment", "planner", "algorithm"):
        if not isinstance(value, str) or not value.strip():
            raise ValueError(f"expected {KEYS[key]}")
    if key == "streams" and folder is not None:
        _check_streams_spec(value, folder)
    elif key == "environment":
        module, _, func = value.partition(":")
        if not module.strip() or (":" in value and not func.strip()):
            raise ValueError(f"expected {KEYS[key]}")
    elif key == "planner":
        from .planners import get_planner

        get_planner(value)  # SSRError: unknown backend, the installed ones listed
    elif key == "algorithm":
        from .solver.options import ALGORITHMS

        if value not in ALGORITHMS:
            raise ValueError(f"expected one of {', '.join(ALGORITHMS)}")
    elif key == "problems":
        if not isinstance(value, list) or not all(isinstance(x, str) and x for x in value):
            raise ValueError(f"expected {KEYS[key]}")
        missing = [x for x in value if folder is not None and not (folder / x).is_file()]
        if missing:
            raise ValueError(f"no file '{missing[0]}' in {folder}")
        return tuple(value)
    elif key == "time_limit":
        if not _is_number(value) or not (math.isfinite(value) and value > 0):
            raise ValueError(f"expected {KEYS[key]}")
        return float(value)
    elif key == "max_cost":
        if not _is_number(value) or math.isnan(value) or value <= 0:
            raise ValueError(f"expected {KEYS[key]}")
        return float(value)
    elif key in ("level", "max_level", "resample"):
        if not _is_int(value) or value < 0:
            raise ValueError(f"expected {KEYS[key]}")
    elif key == "seed":
        if not _is_int(value) or not 0 <= value <= SEED_MAX:
            raise ValueError(f"expected {KEYS[key]}")
    elif key == "defer":
        if not isinstance(value, bool):
            raise ValueError(f"expected {KEYS[key]}")
    return value


def _check_streams_spec(spec: str, folder: Path) -> None:
    """A streams module that can be found: a file of the folder, or an importable name."""
    if _is_file_spec(spec):
        if not (folder / spec).is_file():
            raise ValueError(f"no streams module file '{spec}' in {folder}")
        return
    top = spec.split(".")[0]
    if _in_folder(folder, top):
        return
    try:
        found = importlib.util.find_spec(spec)
    except (ImportError, ValueError):
        found = None
    if found is None:
        raise ValueError(
            f"no streams module '{spec}': neither a module of {folder} nor an importable one"
        )


def _is_file_spec(spec: str) -> bool:
    return spec.endswith(".py") or "/" in spec


def _in_folder(folder: Path, top: str) -> bool:
    """Whether the top-level module name ``top`` is a module or package of ``folder``."""
    return (folder / f"{top}.py").is_file() or (folder / top).is_dir()


def _key_line(text: str | None, key: str) -> int | None:
    """The line of ``text`` that sets ``key`` (first match), for the message."""
    if text is None:
        return None
    name = rf"[\"']?{re.escape(key)}[\"']?"
    pattern = re.compile(rf"^\s*(?:{name}\s*=|\[+\s*{name}\s*\])")
    for i, line in enumerate(text.splitlines(), 1):
        if pattern.match(line):
            return i
    return None


def check_table(
    table: Mapping[str, Any], file: Path | None = None, text: str | None = None
) -> dict[str, Any]:
    """example.toml's table with each value checked (and a number as its key takes it).

    An unknown key, a value of the wrong type or out of range is bad input naming the file,
    the key and (when ``text``, the file's text, is given) its line."""
    where = str(file) if file is not None else SETTINGS_FILE
    folder = file.parent if file is not None else None
    out: dict[str, Any] = {}
    for key, value in table.items():
        line = _key_line(text, key)
        if key not in KEYS:
            close = difflib.get_close_matches(key, list(KEYS), n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            raise SSRError(
                f"key '{key}': unknown key{hint} (known: {', '.join(KEYS)})",
                file=where, line=line, source=text,
            )  # fmt: skip
        try:
            out[key] = _check_value(key, value, folder)
        except ValueError as e:
            raise SSRError(f"{key} = {value!r}: {e}", file=where, line=line, source=text) from None
        except SSRError as e:
            raise SSRError(
                f"{key} = {value!r}: {e.message}", file=where, line=line, source=text
            ) from None
    return out


@dataclass(frozen=True)
class ExampleSettings:
    """What an example folder's ``example.toml`` says, and where each value came from.

    Every value is checked as it is read (:func:`check_table`): ``solve``, ``run`` and
    ``experiment`` see the same settings or the same error.  ``file`` is None for no example
    (files named one by one).
    """

    file: Path | None = None
    streams: str | None = None
    problems: Sequence[str] | None = None
    environment: str | None = None
    solver: Mapping[str, Any] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    @classmethod
    def from_table(
        cls, table: Mapping[str, Any], file: Path | None = None, text: str | None = None
    ) -> ExampleSettings:
        """The settings of a parsed ``example.toml`` (``file``: where it was read, ``text``:
        its text, for the line of an error); bad input if a key or value is wrong."""
        table = check_table(table, file, text)
        return cls(
            file=file,
            streams=table.get("streams"),
            problems=table.get("problems"),
            environment=table.get("environment"),
            solver={k: table[k] for k in SOLVER_KEYS if k in table},
            sources={k: SETTINGS_FILE for k in table},
        )

    @property
    def folder(self) -> Path | None:
        return self.file.parent if self.file is not None else None

    def source(self, key: str) -> str | None:
        """Where ``key``'s value came from (None: not given)."""
        return self.sources.get(key)

    def resolve(
        self,
        flags: Mapping[str, Any],
        defaults: Mapping[str, Any],
        flag_names: Mapping[str, str] | None = None,
    ) -> dict[str, tuple[Any, str]]:
        """{name: (value, source)} for each setting of ``defaults``: its flag's value (in
        ``flags``; None: not given), else example.toml's, else the default.

        One resolution for every command.  A flag always wins: a level from example.toml
        above a --max-level given on the command line is lowered to it (and a --level above
        example.toml's max_level raises that)."""
        names = flag_names or {}
        out: dict[str, tuple[Any, str]] = {}
        for name, default in defaults.items():
            value = flags.get(name)
            if value is not None:
                out[name] = (value, "flag " + names.get(name, "--" + name.replace("_", "-")))
            elif name in self.solver:
                out[name] = (self.solver[name], self.source(name) or SETTINGS_FILE)
            else:
                out[name] = (default, "default")
        if "level" in out and "max_level" in out:
            _reconcile_levels(out, self.file)
        return out

    def streams_module(self, problem: str | Path, seed: int = 0, spec: str | None = None):
        """The streams module made ready for one problem: ``spec`` (a command line's, as
        written), else example.toml's ``streams`` (a relative ``.py`` file is one of the
        folder).  Modules of the example folder import from it while it loads."""
        from .stream import module_for_problem

        folder = self.folder
        if not spec:
            spec = self.streams
            if not spec:
                raise SSRError(
                    'example.toml does not name a streams module (streams = "...")',
                    file=str(self.file) if self.file else None,
                )
            if folder is not None and _is_file_spec(spec):
                spec = str(folder / spec)
        if folder is None:
            return module_for_problem(spec, problem, seed)
        with example_imports(folder):
            return module_for_problem(spec, problem, seed)


def _reconcile_levels(out: dict[str, tuple[Any, str]], file: Path | None) -> None:
    (level, lsrc), (top, tsrc) = out["level"], out["max_level"]
    if level <= top:
        return
    if tsrc.startswith("flag") and not lsrc.startswith("flag"):
        out["level"] = (top, f"{lsrc}, lowered to --max-level")
    elif lsrc.startswith("flag") and not tsrc.startswith("flag"):
        out["max_level"] = (level, f"{tsrc}, raised to --level")
    else:
        where = SETTINGS_FILE if lsrc == tsrc == SETTINGS_FILE else None
        raise SSRError(
            f"the first level ({level}, {lsrc}) is above the last ({top}, {tsrc})",
            file=where and (str(file) if file else SETTINGS_FILE),
        )


# Example folders whose modules were imported: a module name one of them used is imported
# afresh from the next folder that has a module of that name (two folders, two env.py).
_FOLDERS_USED: set[Path] = set()


@contextmanager
def example_imports(folder: Path) -> Iterator[None]:
    """While inside, modules of ``folder`` import by name (the folder is first on
    ``sys.path``); the folder leaves ``sys.path`` afterwards.  A module of the folder's that
    was imported before from another example folder (two folders, two ``env.py``) is dropped
    from ``sys.modules`` first, so that each folder gets its own."""
    folder = Path(folder).resolve()
    entry = str(folder)
    _forget_other_folders(folder)
    _FOLDERS_USED.add(folder)
    added = entry not in sys.path
    if added:
        sys.path.insert(0, entry)
    importlib.invalidate_caches()
    try:
        yield
    finally:
        if added and entry in sys.path:
            sys.path.remove(entry)


def _forget_other_folders(folder: Path) -> None:
    others = [f for f in _FOLDERS_USED if f != folder]
    if not others:
        return
    own = {p.stem if p.suffix == ".py" else p.name for p in folder.iterdir()}
    for name, module in list(sys.modules.items()):
        origin = getattr(module, "__file__", None)
        if name.split(".")[0] not in own or not origin:
            continue
        path = Path(origin).resolve()
        if any(other in path.parents for other in others):
            del sys.modules[name]


@dataclass(frozen=True)
class Example:
    folder: Path
    settings: ExampleSettings = field(hash=False, compare=False)
    domain: S.Domain = field(hash=False, compare=False)
    streams: S.StreamFile = field(hash=False, compare=False)

    @property
    def name(self) -> str:
        return self.folder.name

    def environment_factory(self) -> Callable[..., Any]:
        """The ``environment`` factory of ``example.toml``; bad input if absent or broken.
        Its module may sit in the example folder (and import the folder's other modules)."""
        spec = self.settings.environment
        if not spec:
            raise SSRError(
                f"the example '{self.name}' names no environment in example.toml "
                '(environment = "module:function"); `run` needs one',
                file=str(self.folder / "example.toml"),
            )
        module_name, _, func = str(spec).partition(":")
        try:
            with example_imports(self.folder):
                module = importlib.import_module(module_name)
        except ImportError as e:
            raise SSRError(
                f"cannot import the environment module '{module_name}': {e}",
                file=str(self.folder / "example.toml"),
            ) from None
        factory = getattr(module, func or "make_episode", None)
        if not callable(factory):
            raise SSRError(
                f"'{module_name}' has no function '{func or 'make_episode'}'",
                file=str(self.folder / "example.toml"),
            )
        folder = self.folder

        @functools.wraps(factory)
        def make_episode(*args: Any, **kwargs: Any) -> Any:
            with example_imports(folder):  # what it imports when called comes from there too
                return factory(*args, **kwargs)

        return make_episode


def resolve_folder(name: str | Path) -> Path | None:
    """A folder path, or the name of a shipped example."""
    path = Path(name)
    if path.is_dir():
        return path
    from .resources import domains_dir

    shipped = domains_dir() / str(name)
    return shipped if shipped.is_dir() else None


def read_settings(folder: Path) -> ExampleSettings:
    """Read and check ``folder``'s example.toml (bad input if it is missing, not TOML, or a
    key or value is wrong: :func:`check_table`)."""
    config_file = folder / SETTINGS_FILE
    if not config_file.exists():
        raise SSRError(
            f"no example.toml in {folder} (it names the streams module: "
            'streams = "ssr_compile.streams.x")',
            file=str(folder),
        )
    text = config_file.read_text(encoding="utf-8")
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SSRError(f"not valid TOML: {e}", file=str(config_file)) from None
    return ExampleSettings.from_table(table, config_file, text)


def example_files(folder: Path) -> list[Path]:
    """An example folder's domain, stream and problem files, in that order."""
    rest = sorted(p for p in folder.glob("*.pddl") if p.name not in ("domain.pddl", "stream.pddl"))
    return [folder / "domain.pddl", folder / "stream.pddl", *rest]


def load_example(name: str | Path) -> Example:
    """Parse and check an example folder's domain and stream files (cached per folder)."""
    folder = resolve_folder(name)
    if folder is None:
        raise SSRError(f"'{name}' is neither a folder nor a shipped example", file=str(name))
    return _load(folder.resolve())


@functools.lru_cache(maxsize=32)
def _load(folder: Path) -> Example:
    from .inputs import load_inputs

    settings = read_settings(folder)
    domain, streams, _ = load_inputs(
        str(folder / "domain.pddl"), str(folder / "stream.pddl"), None, []
    )
    return Example(folder, settings, domain, streams)
