"""Example folders: ``domain.pddl``, ``stream.pddl``, problems and ``example.toml``.

``example.toml`` keys: ``streams`` (the streams module, an import path or a ``.py`` file),
``problems`` (file names), optional solver settings (:data:`SOLVER_KEYS`: ``planner``,
``time_limit``, ``level``, ``max_level``, ...) and, for the online policy, ``environment``: a
factory ``"module:function"`` called as ``function(problem, seed)`` that returns an
:class:`ssr_compile.policy.Episode` (an environment and the agent acting in it).

An example is found (:func:`resolve_folder`) and its ``example.toml`` read
(:func:`read_settings`) here only: ``solve``, ``run`` and ``experiment`` all come through here.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from . import syntax as S
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


@dataclass(frozen=True)
class ExampleSettings:
    """What an example folder's ``example.toml`` says, and where each value came from.

    Values are kept as written; ``ssr-compile solve`` validates the solver settings as it
    validates its options.  ``file`` is None for no example (files named one by one).
    """

    file: Path | None = None
    streams: str | None = None
    problems: Sequence[str] | None = None
    environment: str | None = None
    solver: Mapping[str, Any] = field(default_factory=dict)
    sources: Mapping[str, str] = field(default_factory=dict)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], file: Path | None = None) -> ExampleSettings:
        """The settings of a parsed ``example.toml`` (``file``: where it was read)."""
        return cls(
            file=file,
            streams=table.get("streams"),
            problems=table.get("problems"),
            environment=table.get("environment"),
            solver={k: table[k] for k in SOLVER_KEYS if k in table},
            sources={k: SETTINGS_FILE for k in table},
        )

    def source(self, key: str) -> str | None:
        """Where ``key``'s value came from (None: not given)."""
        return self.sources.get(key)


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
        """The ``environment`` factory of ``example.toml``; bad input if absent or broken."""
        spec = self.settings.environment
        if not spec:
            raise SSRError(
                f"the example '{self.name}' names no environment in example.toml "
                '(environment = "module:function"); `run` needs one',
                file=str(self.folder / "example.toml"),
            )
        module_name, _, func = str(spec).partition(":")
        try:
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
        return factory


def resolve_folder(name: str | Path) -> Path | None:
    """A folder path, or the name of a shipped example."""
    path = Path(name)
    if path.is_dir():
        return path
    from .resources import domains_dir

    shipped = domains_dir() / str(name)
    return shipped if shipped.is_dir() else None


def read_settings(folder: Path) -> ExampleSettings:
    """Read ``folder``'s example.toml (bad input if it is missing or not TOML)."""
    config_file = folder / SETTINGS_FILE
    if not config_file.exists():
        raise SSRError(
            f"no example.toml in {folder} (it names the streams module: "
            'streams = "ssr_compile.streams.x")',
            file=str(folder),
        )
    try:
        table = tomllib.loads(config_file.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise SSRError(f"not valid TOML: {e}", file=str(config_file)) from None
    return ExampleSettings.from_table(table, config_file)


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


@lru_cache(maxsize=32)
def _load(folder: Path) -> Example:
    from .inputs import load_inputs

    settings = read_settings(folder)
    domain, streams, _ = load_inputs(
        str(folder / "domain.pddl"), str(folder / "stream.pddl"), None, []
    )
    return Example(folder, settings, domain, streams)
