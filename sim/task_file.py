"""Task files: a kitchen task written as TOML (the appendix's table of each task, as data).

A task file states the objects (each of a kind the world can build, :data:`~.world.OBJECTS`,
optionally resized), where the seed puts each of them, the drawers' openings, the goal, the
prior and, optionally, which objects may hide one from the camera::

    name = "cook"                      # optional: the file's name without .toml
    goal = ["Cooked block", "StoveOff"]
    drawers = { top_drawer = "open" }  # optional: "open", "closed" or an opening in metres

    [objects]   # placed in this order, each at a random collision-free pose on its surface
    block = { kind = "block", on = "counter" }
    cracker_box = { kind = "cracker_box", on = "counter", size = [0.16, 0.06, 0.21] }
    sugar_box = { kind = "sugar_box", on = ["counter", "top_drawer"] }  # the seed picks one

    [prior]     # every object: uniform over these surfaces, or weighted
    block = ["counter"]
    cracker_box = { counter = 1.0 }
    sugar_box = { counter = 0.5, top_drawer = 0.5 }

    [hide]      # one of these, drawn from the seed, stands between the camera and the target
    target = "block"
    by = ["cracker_box", "sugar_box"]
    reachable = true  # optional: the one in front only where the robot can grasp it

Goal facts: ``On OBJECT SURFACE``, ``Closed DRAWER``, ``Cooked OBJECT``, ``StoveOff``.
:func:`load_task_file` reads and checks a file (bad input -- an unknown key, a wrong type, an
unknown kind, surface or predicate, a goal no object can satisfy, objects that cannot fit their
surface -- is an :class:`~ssr_compile.errors.SSRError` naming the file, the key and its line);
``sim.tasks.make_task`` builds the world of a :class:`TaskSpec` from a seed.  The paper's four
tasks are the files ``domains/pddl/kitchen/tasks/<task>.toml`` (:func:`shipped_task_file`).
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ssr_compile.errors import SSRError
from ssr_compile.resources import domains_dir

from .world import DRAWER_TRAVEL, DRAWERS, OBJECTS, TALL_HEIGHT, surface_rects

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

KEYS = ("name", "goal", "drawers", "objects", "prior", "hide")
OBJECT_KEYS = ("kind", "on", "size")
HIDE_KEYS = ("target", "by", "reachable")
SURFACES = tuple(surface_rects())
GOALS = {"On": 2, "Closed": 1, "Cooked": 1, "StoveOff": 0}
# Objects standing on one surface may cover at most this share of it (random placement of
# more fails too often: "cannot be placed without collision").
MAX_COVER = 0.5
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    kind: str
    on: tuple[str, ...]  # the seed picks one when there are several
    half: tuple[float, float, float]
    color: tuple[float, ...]

    @property
    def tall(self) -> bool:
        return 2 * self.half[2] > TALL_HEIGHT


@dataclass(frozen=True)
class TaskSpec:
    """A task as its file states it (see the module doc)."""

    name: str
    objects: tuple[ObjectSpec, ...]
    goal: tuple[tuple[str, ...], ...]
    prior: dict[str, list[tuple[str, float]]]
    drawers: dict[str, float] = field(default_factory=dict)
    hide: tuple[str, tuple[str, ...]] | None = None  # (target, the objects that may hide it)
    # ``hide.reachable``: the object in front of the target is drawn only where some grasp of
    # it is reached from some base, and the target (when the goal moves it) with that object
    # gone (:func:`~.tasks._clear_to_reach`)
    hide_reachable: bool = False
    file: str | None = None
    text: str | None = field(default=None, repr=False)

    def shapes(self) -> dict[str, tuple[tuple[float, float, float], tuple[float, ...]]]:
        """``World(objects=...)`` of this task: by kind in :data:`~.world.OBJECTS`' order, then
        in the file's (the bodies' order, which the streams iterate in, is the one a world of
        every kind had before task files, whatever order a file places its objects in)."""
        kinds = list(OBJECTS)
        ordered = sorted(self.objects, key=lambda o: kinds.index(o.kind))  # stable
        return {o.name: (o.half, o.color) for o in ordered}

    def error(self, key: str, message: str) -> SSRError:
        """Bad input at ``key`` (dotted: ``objects.block.on``) of this task's file."""
        return SSRError(
            f"{key}: {message}", file=self.file or f"task {self.name}",
            line=key_line(self.text, key), source=self.text,
        )  # fmt: skip


def shipped_task_file(name: str) -> Path:
    """The file of one of the paper's tasks (``inspect``, ``stow``, ``swap``, ``cook``)."""
    return domains_dir() / "kitchen" / "tasks" / f"{name}.toml"


def key_line(text: str | None, key: str) -> int | None:
    """The line of ``text`` that sets the dotted ``key`` (each part found after the last)."""
    if not text:
        return None
    lines = text.splitlines()
    start, found = 0, None
    for part in key.split("."):
        pat = re.compile(rf"(^|[\s{{,.\[])[\"']?{re.escape(part)}[\"']?\s*(=|\]|\.)")
        hit = next((i for i in range(start, len(lines)) if pat.search(lines[i])), None)
        if hit is None:
            break
        start = found = hit
    return None if found is None else found + 1


def load_task_file(path: str | Path) -> TaskSpec:
    """Read and check a task file (see the module doc); bad input is an SSRError."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise SSRError("no such task file" if not path.exists() else "not a file", file=where)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise SSRError(f"cannot read the task file: {e}", file=where) from None
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SSRError(f"not TOML: {e}", file=where) from None
    return parse_task(table, file=where, text=text, default_name=path.stem)


def _unknown(key: str, known: tuple[str, ...], what: str) -> str:
    close = difflib.get_close_matches(key, list(known), n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown {what} '{key}'{hint} (expected one of: {', '.join(known)})"


def parse_task(
    table: dict[str, Any], *, file: str | None = None, text: str | None = None,
    default_name: str = "task",
) -> TaskSpec:  # fmt: skip
    """A :class:`TaskSpec` from a task file's table, checked."""
    blank = TaskSpec(default_name, (), (), {}, file=file, text=text)

    def bad(key: str, message: str) -> SSRError:
        return blank.error(key, message)

    for key in table:
        if key not in KEYS:
            raise bad(key, _unknown(key, KEYS, "key"))
    for key in ("goal", "objects", "prior"):
        if key not in table:
            raise bad(key, "missing (a task file states its objects, goal and prior)")
    name = table.get("name", re.sub(r"[^A-Za-z0-9_]+", "_", default_name).strip("_") or "task")
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise bad("name", f"expected a name of letters, digits and '_', got {name!r}")
    objects = _objects(table["objects"], bad)
    by_name = {o.name: o for o in objects}
    drawers = _drawers(table.get("drawers", {}), bad)
    goal = _goal(table["goal"], by_name, bad)
    prior = _prior(table["prior"], by_name, bad)
    hide = _hide(table["hide"], by_name, bad) if "hide" in table else None
    reachable = table["hide"].get("reachable", False) if hide is not None else False
    if not isinstance(reachable, bool):
        raise bad("hide.reachable", f"expected true or false, got {reachable!r}")
    _check_room(objects, bad)
    return TaskSpec(
        name, objects, goal, prior, drawers, hide, hide_reachable=reachable, file=file, text=text
    )


def _str_list(value: Any, key: str, bad, what: str) -> list[str]:
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not items or not all(isinstance(v, str) for v in items):
        raise bad(key, f"expected {what} or a non-empty list of them, got {value!r}")
    return items


def _objects(value: Any, bad) -> tuple[ObjectSpec, ...]:
    if not isinstance(value, dict) or not value:
        raise bad(
            "objects", f"expected a table of objects (name = {{ kind = ... }}), got {value!r}"
        )
    out = []
    for name, entry in value.items():
        key = f"objects.{name}"
        if not _NAME.fullmatch(name):
            raise bad(key, "an object's name is letters, digits and '_', starting with a letter")
        if not isinstance(entry, dict):
            raise bad(key, f"expected a table {{ kind = ..., on = ... }}, got {entry!r}")
        for k in entry:
            if k not in OBJECT_KEYS:
                raise bad(f"{key}.{k}", _unknown(k, OBJECT_KEYS, "key"))
        kind = entry.get("kind")
        if kind not in OBJECTS:
            if not isinstance(kind, str):
                raise bad(f"{key}.kind", f"expected a kind ({', '.join(OBJECTS)}), got {kind!r}")
            raise bad(f"{key}.kind", _unknown(kind, tuple(OBJECTS), "kind"))
        if "on" not in entry:
            raise bad(key, "missing 'on': the surface(s) the seed places it on")
        on = _str_list(entry["on"], f"{key}.on", bad, "a surface")
        for s in on:
            if s not in SURFACES:
                raise bad(f"{key}.on", _unknown(s, SURFACES, "surface"))
        half, color = OBJECTS[kind]
        if "size" in entry:
            size = entry["size"]
            ok = isinstance(size, list) and len(size) == 3
            ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in size)
            if not ok or not all(0.01 <= v <= 0.5 for v in size):
                raise bad(
                    f"{key}.size",
                    f"expected [x, y, z]: the full size in metres, each from 0.01 to 0.5, got {size!r}",
                )
            half = tuple(float(v) / 2 for v in size)
        out.append(ObjectSpec(name, kind, tuple(dict.fromkeys(on)), tuple(half), tuple(color)))
    return tuple(out)


def _drawers(value: Any, bad) -> dict[str, float]:
    if not isinstance(value, dict):
        raise bad("drawers", f'expected a table (top_drawer = "open"), got {value!r}')
    out = {}
    for d, q in value.items():
        if d not in DRAWERS:
            raise bad(f"drawers.{d}", _unknown(d, DRAWERS, "drawer"))
        if q in ("open", "closed"):
            out[d] = DRAWER_TRAVEL if q == "open" else 0.0
        elif isinstance(q, int | float) and not isinstance(q, bool) and 0 <= q <= DRAWER_TRAVEL:
            out[d] = float(q)
        else:
            raise bad(
                f"drawers.{d}",
                f'expected "open", "closed" or an opening from 0 to {DRAWER_TRAVEL} m, got {q!r}',
            )
    return out


def _goal(value: Any, objects: dict[str, ObjectSpec], bad) -> tuple[tuple[str, ...], ...]:
    facts = _str_list(value, "goal", bad, 'a fact ("On block bottom_drawer")')
    out: list[tuple[str, ...]] = []
    where: dict[str, str] = {}
    for text in facts:
        head, *args = text.split()
        if head not in GOALS:
            raise bad("goal", _unknown(head, tuple(GOALS), "goal predicate"))
        if len(args) != GOALS[head]:
            raise bad("goal", f"'{text}': {head} takes {GOALS[head]} argument(s), got {len(args)}")
        if head in ("On", "Cooked"):
            o = objects.get(args[0])
            if o is None:
                raise bad("goal", f"'{text}': no object '{args[0]}' in [objects]")
            # a goal no object can satisfy: plans put tall objects on the counter only
            target = args[1] if head == "On" else "stove"
            if head == "On" and target not in SURFACES:
                raise bad("goal", f"'{text}': " + _unknown(target, SURFACES, "surface"))
            if o.tall and target != "counter":
                raise bad(
                    "goal",
                    f"'{text}': no plan can satisfy it: {o.name} is taller than {TALL_HEIGHT} m, "
                    "so it is placed on the counter only",
                )
            if head == "On":
                if where.setdefault(o.name, target) != target:
                    raise bad("goal", f"'{text}': {o.name} cannot be on {where[o.name]} too")
        elif head == "Closed" and args[0] not in DRAWERS:
            raise bad("goal", f"'{text}': " + _unknown(args[0], DRAWERS, "drawer"))
        out.append((head, *args))
    return tuple(out)


def _prior(value: Any, objects: dict[str, ObjectSpec], bad) -> dict[str, list[tuple[str, float]]]:
    if not isinstance(value, dict):
        raise bad("prior", f"expected a table (object = [surfaces]), got {value!r}")
    out: dict[str, list[tuple[str, float]]] = {}
    for name, entry in value.items():
        key = f"prior.{name}"
        if name not in objects:
            raise bad(key, _unknown(name, tuple(objects), "object"))
        if isinstance(entry, dict):
            weights = list(entry.items())
            for s, w in weights:
                if not isinstance(w, int | float) or isinstance(w, bool) or not w > 0:
                    raise bad(f"{key}.{s}", f"expected a weight > 0, got {w!r}")
            if not weights:
                raise bad(key, "expected some surfaces, got none")
        else:
            weights = [(s, 1) for s in _str_list(entry, key, bad, "a surface")]
        for s, _ in weights:
            if s not in SURFACES:
                raise bad(key, _unknown(s, SURFACES, "surface"))
        total = float(sum(w for _, w in weights))
        out[name] = [(s, float(w) / total) for s, w in weights]
    missing = [o for o in objects if o not in out]
    if missing:
        raise bad("prior", f"no prior for {', '.join(missing)} (every object needs one)")
    return out


def _hide(value: Any, objects: dict[str, ObjectSpec], bad) -> tuple[str, tuple[str, ...]]:
    if not isinstance(value, dict):
        raise bad("hide", f"expected a table (target = ..., by = [...]), got {value!r}")
    for k in value:
        if k not in HIDE_KEYS:
            raise bad(f"hide.{k}", _unknown(k, HIDE_KEYS, "key"))
    if "target" not in value or "by" not in value:
        raise bad("hide", "expected target = OBJECT and by = [OBJECTS]")
    target = value["target"]
    by = _str_list(value["by"], "hide.by", bad, "an object")
    for key, name in [("hide.target", target), *(("hide.by", b) for b in by)]:
        if not isinstance(name, str) or name not in objects:
            raise bad(key, _unknown(str(name), tuple(objects), "object"))
        if objects[name].on != ("counter",):
            raise bad(
                key, f'{name} must stand on the counter only (on = "counter") to hide or be hidden'
            )
    if target in by:
        raise bad("hide.by", f"{target} cannot hide itself")
    return target, tuple(dict.fromkeys(by))


def _check_room(objects: tuple[ObjectSpec, ...], bad) -> None:
    """Each object fits its surfaces, and the objects that must stand on one surface cover at
    most :data:`MAX_COVER` of it."""
    rects = surface_rects()
    cover = dict.fromkeys(rects, 0.0)
    for o in objects:
        for s in o.on:
            (x0, y0), (x1, y1), _ = rects[s]
            small, large = sorted(o.half[:2])
            if 2 * large > max(x1 - x0, y1 - y0) or 2 * small > min(x1 - x0, y1 - y0):
                raise bad(f"objects.{o.name}.on", f"{o.name} does not fit on {s}")
        if len(o.on) == 1:
            cover[o.on[0]] += 4 * o.half[0] * o.half[1]
    for s, area in cover.items():
        (x0, y0), (x1, y1), _ = rects[s]
        if area > MAX_COVER * (x1 - x0) * (y1 - y0):
            names = [o.name for o in objects if o.on == (s,)]
            raise bad(
                f"objects.{names[-1]}.on",
                f"the objects on {s} ({', '.join(names)}) cannot be placed without collision: "
                f"they cover {area / ((x1 - x0) * (y1 - y0)):.0%} of it (at most {MAX_COVER:.0%})",
            )
