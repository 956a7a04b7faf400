"""The artifact of ``ssr-compile compile``: its map from the compiled actions back to the user's
lifted actions, and plans of the compiled task read, mapped back and validated (``map-plan``).

``DIR/actions.json`` (README, ``compile``)::

    {"format": 1, "task": "lifted" | "ground", "level": 3,
     "source": {"domain": PATH, "stream": PATH, "problem": PATH},
     "objects": {COMPILED OBJECT: OBJECT},              # names the writer changed
     "actions": {COMPILED ACTION: {"parameters": ["?a", ...],   # omitted when none
                                   "action": LIFTED ACTION | null,
                                   "args": ["?a", "obj", ...]}}}

A step ``(NAME v1 ... vk)`` of a plan of the compiled task is the step ``(action a1 ... an)``
of the user's domain where each ``ai`` is ``vj`` when ``args[i]`` is the compiled action's
``j``-th parameter, else the object ``args[i]`` itself; a value the writer renamed maps back
through ``objects``.  ``"action": null`` marks a step that is no action of the user's domain
(the goal actions of a disjunctive goal): it is left out.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

from . import syntax as S
from .errors import SSRError

ACTIONS_FILE = "actions.json"
FORMAT = 1


# ---------------------------------------------------------------- writing the map


def action_map(compiled) -> dict[str, dict]:
    """Each action of ``compiled.domain`` -> its lifted action and argument template, found by
    mapping a one-step plan of placeholders back through every pass (:meth:`map_plan`)."""
    out: dict[str, dict] = {}
    for a in compiled.domain.actions:
        marks = tuple(f"?{i}" for i in range(len(a.parameters)))
        mapped = compiled.map_plan([(a.name, marks)])
        names = [p.name if p.name.startswith("?") else f"?{p.name}" for p in a.parameters]
        entry: dict = {"parameters": names} if names else {}
        if not mapped:
            entry.update(action=None, args=[])
        else:
            lifted, args = mapped[0]
            index = {m: names[i] for i, m in enumerate(marks)}
            entry.update(action=lifted, args=[index.get(x, x) for x in args])
        out[a.name] = entry
    return out


def actions_document(compiled, *, task: str, level: int, source: dict[str, str | None]) -> str:
    renaming = compiled.lowered.renaming
    objects = {new: old for old, new in renaming.objects.items()} if renaming else {}
    head = {
        "format": FORMAT,
        "task": task,
        "level": level,
        "source": source,
        "objects": dict(sorted(objects.items())),
    }
    # one line per action: a ground task has tens of thousands
    lines = [f"{json.dumps(k)}: {json.dumps(v)}" for k, v in action_map(compiled).items()]
    text = json.dumps(head, indent=1)[:-2]
    return text + ',\n "actions": {\n  ' + ",\n  ".join(lines) + "\n }\n}\n"


# ---------------------------------------------------------------- reading a plan file


@dataclass(frozen=True)
class Step:
    """One step of a plan file: the action's name, its arguments, and where it stands."""

    name: str
    args: tuple[str, ...]
    line: int
    col: int


_NAME = r"[^\s();,\[\]]+"
# "(name a b)" as Fast Downward's sas_plan and pyperplan's .soln write it
_PAREN = re.compile(rf"\(\s*(?P<name>{_NAME})(?P<args>(?:\s+{_NAME})*)\s*\)")
# "name(a, b)" or "name" as unified-planning's plans print
_CALL = re.compile(rf"(?P<name>{_NAME})(?:\(\s*(?P<args>{_NAME}(?:\s*,\s*{_NAME})*)?\s*\))?")
_STEP_NUMBER = re.compile(r"\d+(?:\.\d+)?\s*:\s*")  # "0: " / "0.000: " (IPC plan files)
_STEP_COST = re.compile(r"\s*\[[0-9.]+\]\s*$")  # " [1]" / " [1.000]" after a step
_HEADERS = {"sequentialplan:"}  # unified-planning's str(plan)


def read_plan(path: str) -> list[Step]:
    """The steps of a plan file: ``(name a b)`` lines (Fast Downward, pyperplan), ``name(a,
    b)`` lines (unified-planning's printed plan, after its ``SequentialPlan:`` header),
    optionally numbered (``0: ``) and followed by ``[cost]``; ``;`` starts a comment.
    A line of any other form is an :class:`SSRError` at its file, line and column."""
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise SSRError(f"cannot read the plan: {e.strerror or e}", file=path) from None
    steps: list[Step] = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        body = raw.split(";", 1)[0].rstrip()
        start = len(body) - len(body.lstrip())
        body = body.strip()
        if not body or body.lower() in _HEADERS:
            continue
        number = _STEP_NUMBER.match(body)
        if number:
            start += number.end()
            body = body[number.end() :]
        body = _STEP_COST.sub("", body)
        m = _PAREN.fullmatch(body)
        if m:
            args = tuple(m.group("args").split())
        else:
            m = _CALL.fullmatch(body)
            if m is None:
                raise SSRError(
                    f"malformed plan step {body!r}: expected (action arg ...) or action(arg, ...)",
                    file=path,
                    line=lineno,
                    col=start + 1,
                    source=text,
                )
            args = tuple(a.strip() for a in (m.group("args") or "").split(",") if a.strip())
        steps.append(Step(m.group("name"), args, lineno, start + m.start("name") + 1))
    return steps


# ---------------------------------------------------------------- mapping it back


@dataclass
class Artifact:
    """A compiled folder's maps (``actions.json``, and ``objects.json`` for stream problems)."""

    folder: Path
    task: str
    level: int
    source: dict
    objects: dict[str, str]
    actions: dict[str, dict]
    optimistic: dict[str, dict]

    @classmethod
    def load(cls, folder: str) -> Artifact:
        path = Path(folder) / ACTIONS_FILE
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise SSRError(
                f"no {ACTIONS_FILE} in {folder}: compile the problem with `ssr-compile compile "
                "... -o DIR` (with a PROBLEM) first",
                file=str(folder),
            ) from None
        except (OSError, ValueError) as e:
            raise SSRError(f"cannot read {ACTIONS_FILE}: {e}", file=str(path)) from None
        if doc.get("format") != FORMAT:
            raise SSRError(f"unknown {ACTIONS_FILE} format {doc.get('format')!r}", file=str(path))
        optimistic: dict[str, dict] = {}
        objects_file = Path(folder) / "objects.json"
        if objects_file.is_file():
            optimistic = json.loads(objects_file.read_text(encoding="utf-8")).get("objects", {})
        return cls(
            Path(folder),
            doc["task"],
            doc.get("level", 0),
            doc.get("source", {}),
            doc.get("objects", {}),
            {k.lower(): v for k, v in doc["actions"].items()},
            optimistic,
        )

    def map_steps(self, steps: list[Step], path: str) -> list[tuple[str, tuple[str, ...]]]:
        """The user's lifted plan for ``steps`` of a plan file at ``path``."""
        plan = []
        for step in steps:
            entry = self.actions.get(step.name.lower())
            if entry is None:
                raise SSRError(
                    f"unknown action '{step.name}': not an action of the compiled task in "
                    f"{self.folder}",
                    file=path,
                    line=step.line,
                    col=step.col,
                    source=_text(path),
                )
            params = entry.get("parameters", [])
            if len(step.args) != len(params):
                raise SSRError(
                    f"'{step.name}' takes {len(params)} arguments, the plan gives {len(step.args)}",
                    file=path,
                    line=step.line,
                    col=step.col,
                    source=_text(path),
                )
            if entry["action"] is None:
                continue
            value = {p: self.objects.get(v.lower(), v.lower()) for p, v in zip(params, step.args)}
            plan.append((entry["action"], tuple(value.get(a, a) for a in entry["args"])))
        return plan

    def stream_instances(self, plan) -> dict[str, str]:
        """The optimistic objects the plan names -> the stream instance that makes each."""
        out: dict[str, str] = {}
        for _, args in plan:
            for a in args:
                r = self.optimistic.get(a)
                if r is not None and a not in out:
                    out[a] = f"{r['stream']}({', '.join(r['inputs'])})"
        return out


def _text(path: str) -> str | None:
    try:
        return Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None


# ---------------------------------------------------------------- validating it


def source_task(artifact: Artifact) -> tuple[S.Domain, S.Problem]:
    """The task the plan must solve: the user's domain and problem (with the optimistic objects
    and facts of the recorded level, for a stream problem), read from the recorded files."""
    from .compile.instantiate import instantiate
    from .compile.pipeline import objects_as_constants
    from .inputs import load_inputs

    src = artifact.source
    for key in ("domain", "stream", "problem"):
        if not src.get(key) or not Path(src[key]).is_file():
            raise SSRError(
                f"the {key} file the artifact was compiled from ({src.get(key)}) is not there; "
                "it is needed to validate (or give --no-validate)",
                file=str(artifact.folder / ACTIONS_FILE),
            )
    domain, streams, problem = load_inputs(src["domain"], src["stream"], src["problem"], [])
    first = objects_as_constants(domain, problem)
    if streams is None:
        return first.domain, first.problem
    inst = instantiate(first.domain, streams, first.problem, level=artifact.level)
    return inst.domain, inst.problem


def validate(domain: S.Domain, problem: S.Problem, plan) -> tuple[bool, str, str]:
    """``(valid, reason, validator)``: unified-planning's validator where its reader takes the
    task, else the project's own checker (:func:`~.solver.preimage.plan_preimage`)."""
    from .errors import UnsupportedError
    from .solver.preimage import PlanInvalid, plan_preimage

    if not domain.axioms:
        try:
            from .planners.validate import validate_plan

            ok, reason = validate_plan(domain, problem, list(plan))
            return ok, reason, "unified-planning"
        except (ImportError, UnsupportedError):
            pass
        except Exception:  # noqa: BLE001 - its reader refused the task: check it ourselves
            pass
    try:
        plan_preimage(domain, problem, list(plan))
    except PlanInvalid as e:
        return False, str(e), "ssr-compile"
    return True, "", "ssr-compile"
