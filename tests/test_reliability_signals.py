"""Issue 14 row 4: SIGTERM and SIGHUP clean up as SIGINT does.

A command that runs a planner binary (``proc.run_command``), a forked planner
(``proc.run_forked``) or a persistent forked worker (``proc.ForkedWorker``) gets a signal while
the planner hangs: it exits with 128 + the signal's number and a one-line message, no planner
process is left running, and no temporary folder is left behind.  Also: a forked planner's own
temporary files (unified-planning's ``/tmp/tmpXXXX``) go to a private folder that is removed
even when the planner is killed at its time limit.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from ssr_compile.planners import proc

pytestmark = pytest.mark.skipif(not proc.can_fork(), reason="needs os.fork")

SCRIPT = textwrap.dedent(
    """
    import os, shutil, sys, tempfile, time
    from ssr_compile import cli
    from ssr_compile.planners import proc

    out = sys.argv[1]

    def planner(out):
        # a forked planner: makes its own temporary folder, says where, then hangs
        mine = tempfile.mkdtemp()
        with open(os.path.join(out, "child.info.tmp"), "w") as f:
            f.write(f"{os.getpid()} {mine}")
        os.rename(os.path.join(out, "child.info.tmp"), os.path.join(out, "child.info"))
        while True:
            time.sleep(0.05)

    def run(args):
        tmp = tempfile.mkdtemp(prefix="ssr-test-", dir=out)
        try:
            if args.mode == "command":
                script = f"echo $$ - > {out}/child.tmp; mv {out}/child.tmp {out}/child.info; exec sleep 300"
                proc.run_command(["sh", "-c", script], 300, cwd=tmp)
            elif args.mode == "forked":
                proc.run_forked(planner, (out,), timeout=300)
            else:
                proc.ForkedWorker(planner).call((out,), timeout=300)
        finally:
            shutil.rmtree(tmp)
        return 0

    cli.register("hang", "a command whose planner hangs", lambda p: p.add_argument("mode"), run)
    sys.exit(cli.main(["hang", sys.argv[2]]))
    """
)


def _default_signals() -> None:
    # The command keeps a signal ignored that it was started ignoring (nohup): the test is
    # about a command started from a terminal, whatever started the test suite.
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    except OSError:  # no /proc: ask the kernel
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True
    return state not in ("Z", "X")


def _wait_for(path: Path, seconds: float = 30.0) -> str:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if path.exists():
            return path.read_text()
        time.sleep(0.05)
    raise AssertionError(f"{path} never appeared")


@pytest.mark.parametrize("mode", ["command", "forked", "worker"])
@pytest.mark.parametrize(
    "sig, code, word",
    [
        (signal.SIGTERM, 143, "terminated (SIGTERM)"),
        (signal.SIGHUP, 129, "terminated (SIGHUP)"),
        (signal.SIGINT, 130, "interrupted"),
    ],
)
def test_a_signal_stops_the_command_and_its_planner(tmp_path, mode, sig, code, word):
    script = tmp_path / "hang.py"
    script.write_text(SCRIPT)
    out = tmp_path / "out"
    out.mkdir()
    shared_tmp = tmp_path / "tmp"
    shared_tmp.mkdir()
    env = dict(os.environ, TMPDIR=str(shared_tmp))
    p = subprocess.Popen(
        [sys.executable, str(script), str(out), mode],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # a shell that started the test suite in the background ignores SIGINT (nohup:
        # SIGHUP), and its children inherit that: give the command the default dispositions
        # a terminal gives
        preexec_fn=_default_signals,
    )
    try:
        pid_text, child_tmp = _wait_for(out / "child.info").split()
        child = int(pid_text)
        assert _alive(child)
        p.send_signal(sig)
        stdout, stderr = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == code, stderr
    assert stderr.strip() == f"ssr-compile: {word}"
    # killed: on a loaded machine (the whole suite on 2 cores) the kernel may take a while to
    # reap it
    deadline = time.monotonic() + 20
    while _alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(child)
    assert sorted(p.name for p in out.iterdir()) == ["child.info"]  # ssr-test-* removed
    if child_tmp != "-":  # the forked planner's own temporary folder went with it
        assert not Path(child_tmp).exists()
        assert list(shared_tmp.iterdir()) == []


def _make_tmp_and_hang(report: str) -> None:
    mine = tempfile.mkdtemp()
    Path(report).write_text(mine)
    time.sleep(60)


def _make_tmp_and_return() -> str:
    return tempfile.mkdtemp()


def test_a_forked_planners_temporary_folder_is_removed_at_its_time_limit(tmp_path):
    report = tmp_path / "where"
    status, _ = proc.run_forked(_make_tmp_and_hang, (str(report),), timeout=1.0)
    assert status == proc.TIMED_OUT
    left = Path(report.read_text())
    assert left.name.startswith("tmp") and not left.exists()
    assert not left.parent.exists()  # the private folder around it is gone too


@pytest.mark.parametrize("worker", [False, True])
def test_a_forked_planners_temporary_folder_is_removed_after_it_returns(worker):
    if worker:
        w = proc.ForkedWorker(_make_tmp_and_return)
        try:
            status, made = w.call((), timeout=30)
            status2, made2 = w.call((), timeout=30)
        finally:
            w.close()
        assert status2 == proc.OK and not Path(made2).exists()
    else:
        status, made = proc.run_forked(_make_tmp_and_return, (), timeout=30)
    assert status == proc.OK
    assert not Path(made).exists() and not Path(made).parent.exists()
