"""Issue 17 row 7: a misspelled stream name in STREAM_INFO is reported with the names that
exist (a misspelled field already was)."""

from __future__ import annotations

from pathlib import Path

import pytest

TAMP2D = Path(__file__).resolve().parent.parent / "domains" / "pddl" / "tamp2d"


def test_misspelled_stream_info_name_is_reported(tmp_path):
    from ssr_compile.errors import SSRError
    from ssr_compile.stream import load_streams_module

    mod = tmp_path / "typo.py"
    mod.write_text(
        "STREAMS = {'plan-motion': lambda a, b: None, 'sample-pose': lambda b: iter(())}\n"
        "STREAM_INFO = {'plan-moiton': {'deferrable': True}}\n"
    )
    with pytest.raises(SSRError) as e:
        load_streams_module(str(mod))
    assert "'plan-moiton'" in str(e.value) and "plan-motion, sample-pose" in str(e.value)


def test_stream_info_for_an_undeclared_stream_is_reported(tmp_path):
    from ssr_compile.errors import SSRError
    from ssr_compile.parse import parse_file
    from ssr_compile.stream import StreamInfo, StreamsModule, load_streams_module

    real = load_streams_module("ssr_compile.streams.tamp2d")
    module = StreamsModule("m", dict(real.streams), {"sample-posee": StreamInfo()}, {}, None)
    streams = parse_file(TAMP2D / "stream.pddl")
    with pytest.raises(SSRError, match="'sample-posee'.*the names that exist: .*sample-placement"):
        module.check_against(streams, str(TAMP2D / "stream.pddl"))
    real.check_against(streams)  # the shipped module names only its own streams


def test_a_module_calling_sys_exit_while_imported_is_an_error_naming_it(tmp_path):
    from ssr_compile.errors import StreamError
    from ssr_compile.stream import load_streams_module

    mod = tmp_path / "exits.py"
    mod.write_text("import sys\nsys.exit(0)\nSTREAMS = {}\n")
    with pytest.raises(StreamError, match=r"called sys.exit\(0\) while being imported"):
        load_streams_module(str(mod))
