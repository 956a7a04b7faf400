"""Planner backends (docs/design.md §4 "Planner backend") and their registry.

Backends are found through the entry-point group ``ssr_compile.planners``; the built-ins
(``fd``, ``pyperplan``, ``up``) are registered there too, so a third-party package adds a
planner by declaring an entry point whose object is a *factory*::

    [project.entry-points."ssr_compile.planners"]
    myplanner = "my_package.planner:make_planner"

    def make_planner(variant: str | None = None, **options) -> Planner: ...

A spec ``NAME:VARIANT`` calls the factory of ``NAME`` with ``VARIANT`` (``fd:opt``,
``up:fast-downward``); ``NAME`` alone passes ``None``.  A factory may also have a
``describe()`` function returning a list of dicts (one per variant worth listing), which
:func:`describe_planners` then uses instead of building the default planner.
"""

from __future__ import annotations

import functools
from importlib.metadata import EntryPoint, entry_points

from ..errors import SSRError
from .base import (
    ERROR,
    SOLVED,
    TIMEOUT,
    UNSOLVABLE,
    Capabilities,
    GroundAction,
    Planner,
    PlanResult,
)

GROUP = "ssr_compile.planners"

# The built-in backends.  Their names are reserved: :func:`get_planner` loads them without
# reading the installed entry points (a scan of every distribution's metadata, 6-10 ms that a
# solve naming ``fd`` would otherwise pay), and they are listed even from a checkout that was
# never installed.
_BUILTINS = {
    "fd": "ssr_compile.planners.fd:make_planner",
    "pyperplan": "ssr_compile.planners.pyperplan_backend:make_planner",
    "up": "ssr_compile.planners.up:make_planner",
}

__all__ = [
    "Capabilities",
    "ERROR",
    "GROUP",
    "GroundAction",
    "PlanResult",
    "Planner",
    "SOLVED",
    "TIMEOUT",
    "UNSOLVABLE",
    "available_planners",
    "describe_planners",
    "get_planner",
]


@functools.lru_cache(maxsize=1)
def _installed() -> tuple[EntryPoint, ...]:
    """The group's entry points, read once per process: reading them scans every installed
    distribution's metadata (about 10 ms, paid by every solve that names its planner)."""
    return tuple(entry_points(group=GROUP))


def available_planners() -> dict[str, EntryPoint]:
    """The installed backends by name (entry points of the group ``ssr_compile.planners``)."""
    found = {ep.name: ep for ep in _installed()}
    for name, value in _BUILTINS.items():
        found[name] = EntryPoint(name=name, value=value, group=GROUP)
    return dict(sorted(found.items()))


def _factory(name: str, spec: str):
    if name in _BUILTINS:
        planners = {name: EntryPoint(name=name, value=_BUILTINS[name], group=GROUP)}
    else:
        planners = available_planners()
    if name not in planners:
        raise SSRError(
            f"unknown planner {spec!r}; installed planners: {', '.join(planners)} "
            "(a variant follows a colon, e.g. fd:opt or up:fast-downward)"
        )
    try:
        return planners[name].load()
    except Exception as e:  # a broken third-party package must not look like our bug
        raise SSRError(f"planner {name!r} failed to load ({planners[name].value}): {e}") from e


def get_planner(spec: str, **options) -> Planner:
    """The backend named by ``spec`` (``fd``, ``fd:opt``, ``pyperplan``, ``up:ENGINE``...).

    ``options`` go to the backend's factory.  Unknown names raise :class:`SSRError` listing the
    installed planners.
    """
    name, _, variant = spec.strip().lower().partition(":")
    factory = _factory(name, spec)
    return factory(variant or None, **options)


def _summary(planner: Planner, name: str) -> dict:
    doc = (type(planner).__doc__ or "").strip().splitlines()
    return {
        "name": name,
        "planner": planner.name,
        "capabilities": planner.capabilities.as_dict(),
        "description": doc[0] if doc else "",
    }


def describe_planners() -> list[dict]:
    """One dict per listed backend: ``name`` (a spec for :func:`get_planner`), ``entry_point``,
    ``capabilities`` (feature -> bool), ``description``, and ``error`` when it cannot load."""
    out: list[dict] = []
    for name, ep in available_planners().items():
        try:
            factory = ep.load()
            describe = getattr(factory, "describe", None)
            rows = describe() if callable(describe) else [_summary(factory(None), name)]
        except Exception as e:  # noqa: BLE001 - listed with the reason it is unusable
            rows = [{"name": name, "capabilities": {}, "description": "", "error": str(e)}]
        for row in rows:
            out.append({"entry_point": ep.value, **row})
    return out
