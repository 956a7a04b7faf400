"""Python's cyclic garbage collector around allocation-heavy work: off during a compilation
(and back as it was, whatever happens), frozen for what a forked worker inherits and off
during its calls, whose cyclic garbage is collected after each answer."""

from __future__ import annotations

import gc
import weakref
from pathlib import Path

import pytest

from ssr_compile.compile import pipeline
from ssr_compile.parse import parse_domain, parse_problem, parse_stream_file
from ssr_compile.planners.proc import ForkedWorker, can_fork

PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"


def load():
    return (
        parse_domain((PP / "domain.pddl").read_text()),
        parse_stream_file((PP / "stream.pddl").read_text()),
        parse_problem((PP / "problem.pddl").read_text()),
    )


@pytest.fixture
def seen_during_instantiation(monkeypatch):
    """Whether the collector was on while the instantiation pass ran, call by call."""
    seen: list[bool] = []
    real = pipeline.instantiate

    def spy(*args, **kwargs):
        seen.append(gc.isenabled())
        return real(*args, **kwargs)

    monkeypatch.setattr(pipeline, "instantiate", spy)
    return seen


def test_the_collector_is_off_during_a_compilation_and_on_after(seen_during_instantiation):
    assert gc.isenabled()
    compiled = pipeline.compile_problem(*load(), level=3)
    assert compiled.domain.actions  # the compilation itself is unchanged
    assert seen_during_instantiation == [False]
    assert gc.isenabled()


def test_the_collector_comes_back_when_a_compilation_fails(monkeypatch):
    def broken(*args, **kwargs):
        assert not gc.isenabled()
        raise RuntimeError("a pass failed")

    monkeypatch.setattr(pipeline, "instantiate", broken)
    with pytest.raises(RuntimeError, match="a pass failed"):
        pipeline.compile_problem(*load(), level=3)
    assert gc.isenabled()


def test_a_collector_the_caller_turned_off_stays_off(seen_during_instantiation):
    gc.disable()
    try:
        pipeline.compile_problem(*load(), level=3)
        assert not gc.isenabled()
    finally:
        gc.enable()
    assert seen_during_instantiation == [False]


# ---------------------------------------------------------------- the forked worker

_made: weakref.ref | None = None


class _Node:
    pass


def _probe(what: str):
    """Run in the worker: its collector's state, or a reference cycle made and left behind,
    or whether the last one is still alive."""
    global _made
    if what == "state":
        return gc.isenabled(), gc.get_freeze_count()
    if what == "cycle":
        node = _Node()
        node.me = node  # unreachable once the call returns, freed only by a collection
        _made = weakref.ref(node)
        return True
    return _made is not None and _made() is not None


@pytest.mark.skipif(not can_fork(), reason="needs fork")
def test_a_worker_call_runs_without_the_collector_and_its_cycles_are_collected_after():
    worker = ForkedWorker(_probe)
    try:
        status, (enabled, frozen) = worker.call(("state",), timeout=10)
        assert status == "ok" and enabled is False
        assert frozen > 1000  # the objects inherited from this process
        assert worker.call(("cycle",), timeout=10) == ("ok", True)
        assert worker.call(("alive",), timeout=10) == ("ok", False)
    finally:
        worker.close()
    assert gc.isenabled() and gc.get_freeze_count() == 0  # this process is left as it was
