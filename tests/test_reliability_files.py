"""Issue 14 row 2: ``-o`` replaces only regular files, keeps modes, and ``compile`` writes its
three outputs as a unit."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from ssr_compile import files as cli
from ssr_compile.cli import main
from ssr_compile.errors import SSRError
from ssr_compile.files import write_atomically, write_files_atomically

LANG = Path(__file__).parent / "fixtures" / "lang"
PP = Path(__file__).parent / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))
SOURCE = str(LANG / "kitchen" / "stream.pddl")


@pytest.fixture
def umask():
    old = os.umask(0o022)
    yield lambda m: os.umask(m)
    os.umask(old)


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_fmt_refuses_to_replace_a_symlink(tmp_path, capsys):
    target = tmp_path / "precious.txt"
    target.write_text("keep me\n")
    link = tmp_path / "out.pddl"
    link.symlink_to(target)
    assert main(["fmt", SOURCE, "-o", str(link)]) == 2
    err = capsys.readouterr().err
    assert f"{link}: error: the output path is a symbolic link" in err
    assert "Traceback" not in err
    assert link.is_symlink() and target.read_text() == "keep me\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.pddl", "precious.txt"]


def test_fmt_refuses_to_replace_a_fifo(tmp_path, capsys):
    fifo = tmp_path / "out.pddl"
    os.mkfifo(fifo)
    assert main(["fmt", SOURCE, "-o", str(fifo)]) == 2
    assert "is a FIFO" in capsys.readouterr().err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == ["out.pddl"]


def test_fmt_refuses_to_replace_a_device(tmp_path, capsys):
    dev = tmp_path / "null"
    try:
        os.mknod(dev, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, OSError):
        pytest.skip("cannot make a device node here (needs root)")
    assert main(["fmt", SOURCE, "-o", str(dev)]) == 2
    assert "is a character device" in capsys.readouterr().err
    assert stat.S_ISCHR(os.lstat(dev).st_mode)


def test_fmt_refuses_to_replace_a_folder(tmp_path, capsys):
    folder = tmp_path / "out.pddl"
    folder.mkdir()
    assert main(["fmt", SOURCE, "-o", str(folder)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert folder.is_dir() and not any(folder.iterdir())


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_new_output_honours_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    out = tmp_path / "new.pddl"
    assert main(["fmt", SOURCE, "-o", str(out)]) == 0
    assert _mode(out) == mode


def test_an_existing_output_keeps_its_mode(tmp_path, umask):
    umask(0o077)
    out = tmp_path / "old.pddl"
    out.write_text("old\n")
    os.chmod(out, 0o640)
    assert main(["fmt", SOURCE, "-o", str(out)]) == 0
    assert _mode(out) == 0o640 and "(define" in out.read_text()


def test_compile_writes_nothing_when_one_output_cannot_be_written(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "objects.json").mkdir()  # the third output's path is a folder
    assert main(["compile", D, S, P, "-o", str(out)]) == 2
    assert "objects.json: error: the output path is a folder" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["objects.json"]


def test_compile_output_folder_that_is_a_file_is_bad_input(tmp_path, capsys):
    out = tmp_path / "out"
    out.write_text("a file\n")
    assert main(["compile", D, S, P, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{out}: error: is not a folder" in err and "Traceback" not in err


def test_a_failed_replace_puts_back_the_files_already_replaced(tmp_path, monkeypatch):
    a, b, c = (tmp_path / n for n in ("a.txt", "b.txt", "c.txt"))
    a.write_text("old a\n")
    b.write_text("old b\n")
    real_replace = os.replace
    calls = []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 3:  # the third output fails (disk full, ...)
            raise OSError(28, "No space left on device", str(dst))
        return real_replace(src, dst)

    monkeypatch.setattr(cli.os, "replace", flaky)
    with pytest.raises(SSRError) as info:
        write_files_atomically({a: "new a\n", b: "new b\n", c: "new c\n"})
    assert info.value.exit_code == 1 and "No space left" in info.value.message
    monkeypatch.setattr(cli.os, "replace", real_replace)
    assert a.read_text() == "old a\n" and b.read_text() == "old b\n" and not c.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]


def test_write_atomically_replaces_a_regular_file(tmp_path):
    out = tmp_path / "x.txt"
    out.write_text("old\n")
    write_atomically(out, "new\n")
    assert out.read_text() == "new\n"
    assert [p.name for p in tmp_path.iterdir()] == ["x.txt"]


def test_a_full_disk_is_one_line_and_exit_1(tmp_path):
    """`fmt > /dev/full`: the output cannot be written -- the environment's fault, not a bug."""
    import os
    import subprocess
    import sys

    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    (tmp_path / "d.pddl").write_text("(define (domain d) (:predicates (p)))")
    with open("/dev/full", "w") as full:
        proc = subprocess.run(
            [sys.executable, "-m", "ssr_compile.cli", "fmt", str(tmp_path / "d.pddl")],
            stdout=full, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [
        "ssr-compile: cannot write the output: No space left on device"
    ]
