"""The JSON that ``--json`` prints: one documented schema for every command.

Every document is one JSON object with ``schema_version`` (this module's
:data:`SCHEMA_VERSION`) and ``command`` (the subcommand that printed it).  Values follow one
rule (:func:`to_json`): numbers are JSON numbers, ``None`` is ``null``, tuples, lists and numpy
arrays are arrays, mappings are objects, dataclasses (trajectories, drawer motions) are objects
with their fields and ``"type"``: the class name; anything else is its ``repr`` string; a
non-finite float is the string ``"inf"``, ``"-inf"`` or ``"nan"`` (JSON has no such numbers).
Unless ``--full`` is asked, a long sequence of sequences (a path of configurations) is
summarised as ``{"summary": "sequence", "length": N, "first": ..., "last": ...}``.

:data:`SCHEMA` is the JSON Schema (draft 2020-12) of every document; ``tests/
test_cli_promises_json.py`` validates the output of every ``--json`` option against it.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

from .catalog import VARIANTS

SCHEMA_VERSION = 1

#: sequences of sequences longer than this are summarised unless ``full``
SUMMARY_LENGTH = 4


def to_json(value: Any, full: bool = False) -> Any:
    """``value`` as JSON data (see the module's docstring)."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    kind = type(value)
    if kind.__module__ == "numpy" and hasattr(value, "tolist"):  # arrays and numpy scalars
        return to_json(value.tolist(), full)
    if isinstance(value, (list, tuple)):
        items = list(value)
        if not full and len(items) > SUMMARY_LENGTH and all(_is_sequence(x) for x in items):
            return {
                "summary": "sequence",
                "length": len(items),
                "first": to_json(items[0], full),
                "last": to_json(items[-1], full),
            }
        return [to_json(v, full) for v in items]
    if isinstance(value, dict):
        return {str(k): to_json(v, full) for k, v in value.items()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = {"type": kind.__name__}
        for f in dataclasses.fields(value):
            out[f.name] = to_json(getattr(value, f.name), full)
        return out
    return repr(value)


def _is_sequence(x: Any) -> bool:
    return isinstance(x, (list, tuple)) or (
        type(x).__module__ == "numpy" and getattr(x, "ndim", 0) >= 1
    )


def document(command: str, **fields: Any) -> dict:
    """A JSON document of ``command``: ``schema_version``, ``command``, then ``fields``."""
    return {"schema_version": SCHEMA_VERSION, "command": command, **fields}


def dumps(doc: dict) -> str:
    """The document as text; non-finite floats anywhere become strings (valid JSON)."""
    return json.dumps(_finite(doc), indent=1, allow_nan=False)


def _finite(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return repr(x)
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


# ---------------------------------------------------------------- the schema

_NUMBER_OR_NONFINITE = {"anyOf": [{"type": "number"}, {"enum": ["inf", "-inf", "nan"]}]}
_NUMBER_OR_NULL = {
    "anyOf": [{"type": "number"}, {"type": "null"}, {"enum": ["inf", "-inf", "nan"]}]
}
_STRINGS = {"type": "array", "items": {"type": "string"}}

_VALUE = {
    "$comment": "a stream value: number, null, string, bool, array, object, or a summary",
    "anyOf": [
        {"type": ["number", "string", "boolean", "null", "array"]},
        {
            "type": "object",
            "required": ["summary", "length", "first", "last"],
            "properties": {"summary": {"const": "sequence"}, "length": {"type": "integer"}},
        },
        {"type": "object", "not": {"required": ["summary"]}},
    ],
}

_SETTINGS = {
    "type": "object",
    "additionalProperties": {
        "type": "object",
        "required": ["value", "source"],
        "properties": {
            "source": {"type": "string"},
            "value": {"type": ["number", "string", "boolean", "null"]},
        },
    },
}

_SOLVE_RESULT = {
    "type": "object",
    "required": ["problem", "status", "message", "cost", "plan", "certificate", "stats"],
    "additionalProperties": False,
    "properties": {
        "problem": {"type": "string"},
        "status": {"enum": ["solved", "unsolvable", "timeout"]},
        "message": {"type": ["string", "null"]},
        "cost": _NUMBER_OR_NULL,
        "plan": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["action", "args", "values", "deferred"],
                "additionalProperties": False,
                "properties": {
                    "action": {"type": "string"},
                    "args": _STRINGS,
                    "values": {"type": "array", "items": _VALUE},
                    "deferred": _STRINGS,
                },
            },
        },
        "certificate": _STRINGS,
        "stats": {
            "type": "object",
            "required": ["total_time"],
            "properties": {
                "iterations": {"type": "integer"},
                "levels": {"type": "array", "items": {"type": "integer"}},
                "planner_calls": {"type": "integer"},
                "planner_time": {"type": "number"},
                "stream_time": {"type": "number"},
                "total_time": {"type": "number"},
                "compile_time": {"type": "number"},
                "streams": {"type": "object"},
            },
        },
    },
}

_PLAN_RESULT = {
    "type": "object",
    "required": [
        "problem",
        "status",
        "planner",
        "time",
        "level",
        "message",
        "cost",
        "scale",
        "plan",
        "stream_plan",
    ],
    "additionalProperties": False,
    "properties": {
        "problem": {"type": "string"},
        "status": {
            "$comment": "level_limit: no plan up to the last level, where instances were cut off",
            "enum": ["solved", "unsolvable", "timeout", "level_limit"],
        },
        "planner": {"type": "string"},
        "time": {"type": "number"},
        "level": {"type": "integer"},
        "message": {"type": ["string", "null"]},
        "cost": _NUMBER_OR_NULL,
        "scale": {"type": ["integer", "null"]},
        "plan": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["action", "args"],
                "additionalProperties": False,
                "properties": {"action": {"type": "string"}, "args": _STRINGS},
            },
        },
        "stream_plan": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["stream", "inputs", "outputs"],
                "additionalProperties": False,
                "properties": {
                    "stream": {"type": "string"},
                    "inputs": _STRINGS,
                    "outputs": _STRINGS,
                },
            },
        },
    },
}

_PLANNER = {
    "type": "object",
    "required": ["name"],
    "properties": {
        "name": {"type": "string"},
        "capabilities": {"type": "object", "additionalProperties": {"type": "boolean"}},
        "description": {"type": "string"},
        "error": {"type": "string"},
    },
}

_RUN = {
    "required": [
        "example",
        "problem",
        "seed",
        "variant",
        "success",
        "reason",
        "cycles",
        "planning_time",
        "trace",
    ],
    "properties": {
        "example": {"type": "string"},
        "problem": {"type": ["string", "null"]},
        "seed": {"type": "integer"},
        "variant": {"enum": sorted(VARIANTS)},
        "success": {"type": "boolean"},
        "reason": {"type": "string"},
        "cycles": {"type": "integer"},
        "planning_time": _NUMBER_OR_NONFINITE,
        "trace": {"type": "array", "items": {"type": "object"}},
    },
}


# ``map-plan``: valid and validator are null with --no-validate
_MAP_PLAN = {
    "required": ["plan", "valid", "validator", "reason", "domain", "problem", "stream_instances"],
    "properties": {
        "plan": _PLAN_RESULT["properties"]["plan"],
        "valid": {"type": ["boolean", "null"]},
        "validator": {"enum": ["unified-planning", "ssr-compile", None]},
        "reason": {"type": ["string", "null"]},
        "domain": {"type": ["string", "null"]},
        "problem": {"type": ["string", "null"]},
        "stream_instances": {"type": "object", "additionalProperties": {"type": "string"}},
    },
}


def _command(name: str, body: dict) -> dict:
    required = ["schema_version", "command", *body.get("required", [])]
    props = {
        "schema_version": {"const": SCHEMA_VERSION},
        "command": {"const": name},
        **body.get("properties", {}),
    }
    return {
        "if": {"properties": {"command": {"const": name}}},
        "then": {"type": "object", "required": required, "properties": props},
    }


SCHEMA: dict = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "ssr-compile --json output",
    "type": "object",
    "required": ["schema_version", "command"],
    "properties": {
        "schema_version": {"const": SCHEMA_VERSION},
        "command": {"enum": ["solve", "plan", "planners", "run", "map-plan"]},
    },
    "allOf": [
        _command(
            "solve",
            {
                "required": ["settings", "results"],
                "properties": {
                    "settings": _SETTINGS,
                    "results": {"type": "array", "minItems": 1, "items": _SOLVE_RESULT},
                },
            },
        ),
        _command(
            "plan",
            {
                "required": ["results"],
                "properties": {"results": {"type": "array", "minItems": 1, "items": _PLAN_RESULT}},
            },
        ),
        _command(
            "planners",
            {
                "required": ["planners"],
                "properties": {"planners": {"type": "array", "items": _PLANNER}},
            },
        ),
        _command("run", _RUN),
        _command("map-plan", _MAP_PLAN),
    ],
}
