"""Issue 14 row 1: the parse tables are never unpickled from a shared folder.

Lark's ``cache=True`` reads ``/tmp/.lark_cache_<user>_<hash>_<py>.tmp`` with ``pickle``, so a
file planted there by another local user ran code in every ssr-compile.  The tables now live in
a private per-user folder (``$XDG_CACHE_HOME/ssr-compile``, 0700, ours, not writable by others),
and without such a folder the parser is built without a cache.
"""

from __future__ import annotations

import os
import pickle
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from ssr_compile.resources import grammar_file

pytestmark = pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX file ownership")


class _Payload:
    """Unpickling this creates the marker file: proof that the planted file was read."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _plant(path: Path, marker: Path) -> None:
    path.write_bytes(b"0" * 64 + b"\n" + pickle.dumps(_Payload(str(marker))))


def _parse_in_child(env_extra: dict) -> subprocess.CompletedProcess:
    env = dict(os.environ, **env_extra)
    env.pop("SSR_COMPILE_NO_CACHE", None)
    code = (
        "from ssr_compile.parse import parse_text\n"
        "print(parse_text('(define (domain d) (:predicates (p)))').name)\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60
    )


def _old_lark_cache_path(tmp: Path) -> Path:
    """The file Lark's cache=True would read for our grammar, with the temp folder ``tmp``."""
    code = (
        "import tempfile, sys\n"
        "from lark import Lark\n"
        f"tempfile.tempdir = {str(tmp)!r}\n"
        f"text = open({str(grammar_file())!r}).read()\n"
        "Lark(text, parser='lalr', lexer='contextual', maybe_placeholders=False, cache=True)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)
    (found,) = tmp.glob(".lark_cache_*")
    return found


def test_a_file_planted_at_larks_tmp_path_is_never_read(tmp_path):
    shared = tmp_path / "shared-tmp"
    shared.mkdir()
    planted = _old_lark_cache_path(shared)
    marker = tmp_path / "PWNED"
    _plant(planted, marker)
    r = _parse_in_child({"TMPDIR": str(shared), "XDG_CACHE_HOME": str(tmp_path / "cache")})
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "d"
    assert not marker.exists()
    # and nothing new was put in the shared folder
    assert [p.name for p in shared.iterdir()] == [planted.name]


def test_the_cache_folder_is_private_and_reused(tmp_path):
    cache = tmp_path / "cache"
    r = _parse_in_child({"XDG_CACHE_HOME": str(cache)})
    assert r.returncode == 0, r.stderr
    folder = cache / "ssr-compile"
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    (tables,) = folder.glob("lark-*.pickle")
    assert tables.stat().st_uid == os.getuid()
    # A second process uses it (and still parses).
    r = _parse_in_child({"XDG_CACHE_HOME": str(cache)})
    assert r.returncode == 0 and r.stdout.strip() == "d", r.stderr


def _planted_in_cache(tmp_path: Path) -> tuple[Path, Path, Path]:
    """A cache folder with our tables file replaced by a payload; (cache root, file, marker)."""
    cache = tmp_path / "cache"
    assert _parse_in_child({"XDG_CACHE_HOME": str(cache)}).returncode == 0
    (tables,) = (cache / "ssr-compile").glob("lark-*.pickle")
    marker = tmp_path / "PWNED"
    _plant(tables, marker)
    return cache, tables, marker


def test_a_world_writable_cache_folder_is_not_used(tmp_path):
    cache, tables, marker = _planted_in_cache(tmp_path)
    os.chmod(tables.parent, 0o777)
    r = _parse_in_child({"XDG_CACHE_HOME": str(cache)})
    assert r.returncode == 0 and r.stdout.strip() == "d", r.stderr
    assert not marker.exists()


def test_a_group_writable_cache_file_is_not_used(tmp_path):
    cache, tables, marker = _planted_in_cache(tmp_path)
    os.chmod(tables, 0o664)
    r = _parse_in_child({"XDG_CACHE_HOME": str(cache)})
    assert r.returncode == 0 and r.stdout.strip() == "d", r.stderr
    assert not marker.exists()


def test_a_symlinked_cache_folder_is_not_used(tmp_path):
    cache, tables, marker = _planted_in_cache(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    (cache / "ssr-compile").rename(elsewhere)
    (cache / "ssr-compile").symlink_to(elsewhere)
    r = _parse_in_child({"XDG_CACHE_HOME": str(cache)})
    assert r.returncode == 0 and r.stdout.strip() == "d", r.stderr
    assert not marker.exists()


def test_a_cache_folder_owned_by_someone_else_is_not_used(tmp_path):
    if os.getuid() != 0:
        pytest.skip("making a folder owned by another user needs root")
    cache, tables, marker = _planted_in_cache(tmp_path)
    os.chown(tables.parent, 12345, 12345)
    os.chown(tables, 12345, 12345)
    r = _parse_in_child({"XDG_CACHE_HOME": str(cache)})
    assert r.returncode == 0 and r.stdout.strip() == "d", r.stderr
    assert not marker.exists()


def test_the_planted_payload_would_run_if_read(tmp_path):
    """The test's payload is real: unpickling the planted file creates the marker."""
    marker = tmp_path / "PWNED"
    planted = tmp_path / "f"
    _plant(planted, marker)
    with open(planted, "rb") as f:
        f.readline()
        pickle.load(f)
    assert marker.exists()
