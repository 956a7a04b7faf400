"""Issue 38, items 11-16: outputs and sweeps.  Every output path is checked before the work;
every output follows the umask; journal lines of the wrong types are named, never fatal nor
silent; a stopped sweep leaves no temporary folders; seeds have one rule and a linear parser;
PyBullet's banner stays out of a sweep's output; an object has one colour in every picture."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from ssr_compile.cli import main

ROOT = Path(__file__).resolve().parent.parent
FIXTURE = ROOT / "tests" / "fixtures" / "experiment" / "misbehave"
PP = ROOT / "tests" / "fixtures" / "compile" / "pp1d"
D, S, P = (str(PP / n) for n in ("domain.pddl", "stream.pddl", "problem.pddl"))
PROGRESS_SETTINGS = {
    "budget": 30.0,
    "max_cycles": 100,
    "constrained_time": 30.0,
    "unconstrained_time": 300.0,
    "planner": "fd",
}


def run_cli(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as e:  # argparse's own bad input
        return int(e.code)


def _can_write(folder: Path) -> bool:
    try:
        fd, probe = tempfile.mkstemp(dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(probe)
    return True


@pytest.fixture
def unwritable(tmp_path):
    """A folder in which no file can be created (root ignores modes: a sysfs folder then)."""
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        if not _can_write(folder):
            yield folder
            return
        sysfs = Path("/sys")
        if sysfs.is_dir() and not _can_write(sysfs):
            yield sysfs
            return
        pytest.skip("no folder here that cannot be written")
    finally:
        folder.chmod(0o755)


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def umask():
    old = os.umask(0o022)
    yield lambda m: os.umask(m)
    os.umask(old)


@pytest.fixture
def drawing_progress(monkeypatch):
    """The progress example with a renderer (tiny frames), counting the episodes it makes."""
    from ssr_compile.streams.environments import progress

    made = []
    real = progress.make_episode

    def make_episode(problem=None, seed=0):
        episode = real(problem, seed)
        episode.render = lambda caption: np.full((8, 8, 3), 200, dtype=np.uint8)
        made.append(seed)
        return episode

    monkeypatch.setattr(progress, "make_episode", make_episode)
    return made


# ---------------------------------------------------------------- 11: outputs checked first


def test_run_gif_into_a_folder_that_cannot_be_written_fails_before_the_episode(
    unwritable, drawing_progress, capsys
):
    out = unwritable / "episode.gif"
    assert run_cli(["run", "progress", "--gif", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{out}: error: --gif: cannot write into the folder {unwritable}")
    assert ".tmp" not in err and "Traceback" not in err
    assert drawing_progress == []  # no episode was run only to lose its outcome


def test_a_bad_gif_leaves_an_existing_log_untouched(unwritable, drawing_progress, tmp_path):
    log = tmp_path / "episode.jsonl"
    log.write_text('{"index": 1}\n')
    out = unwritable / "episode.gif"
    assert run_cli(["run", "progress", "--log", str(log), "--gif", str(out)]) == 2
    assert log.read_text() == '{"index": 1}\n'  # checked before the log was opened


def test_render_and_belief_plot_check_the_output_before_drawing(unwritable, monkeypatch, capsys):
    import ssr_compile.sim.render as render
    import ssr_compile.sim.tasks as tasks

    def no_task(*args, **kwargs):
        raise AssertionError("the task was built before the output was checked")

    monkeypatch.setattr(render, "make_task", no_task)
    monkeypatch.setattr(tasks, "make_task", no_task)
    for command in ("render", "belief-plot"):
        out = unwritable / "picture.png"
        assert run_cli([command, "inspect", "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"{out}: error: -o: cannot write into the folder"), err
        assert ".tmp" not in err and "Traceback" not in err


def test_compile_checks_its_output_folder_before_compiling(unwritable, monkeypatch, capsys):
    import ssr_compile.cli.compile as compile_cli

    def no_inputs(*args, **kwargs):
        raise AssertionError("compiled before the output was checked")

    monkeypatch.setattr(compile_cli, "load_inputs", no_inputs)
    out = unwritable / "out"
    assert run_cli(["compile", D, S, P, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{out / 'domain.pddl'}: error: -o: cannot write into the folder" in err


def test_experiment_and_report_check_their_folder_first(unwritable, monkeypatch, capsys):
    import ssr_compile.experiment as X

    def no_tasks(*args, **kwargs):
        raise AssertionError("the tasks were loaded before the output was checked")

    monkeypatch.setattr(X, "parse_tasks", no_tasks)
    out = unwritable / "sweep"
    assert run_cli(["experiment", "--tasks", "progress", "--seeds", "0", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "-o: cannot write into the folder" in err and str(out) in err


def test_a_write_error_names_the_output_not_its_temporary_file(unwritable, capsys):
    from ssr_compile.errors import SSRError
    from ssr_compile.files import write_atomically

    with pytest.raises(SSRError) as info:
        write_atomically(unwritable / "x.txt", "text\n")
    assert info.value.file == str(unwritable / "x.txt")


# ---------------------------------------------------------------- 12: modes follow the umask


@pytest.mark.parametrize("mask, mode", [(0o002, 0o664)])
def test_every_output_follows_the_umask(tmp_path, umask, mask, mode, drawing_progress, capsys):
    umask(mask)
    gif, log = tmp_path / "run.gif", tmp_path / "run.jsonl"
    assert run_cli(["run", "progress", "--gif", str(gif), "--log", str(log)]) == 0
    assert run_cli(["compile", D, S, P, "-o", str(tmp_path / "compiled")]) == 0
    assert run_cli(["fmt", D, "-o", str(tmp_path / "fmt.pddl")]) == 0
    assert run_cli(["render", "inspect", "-o", str(tmp_path / "render.png")]) == 0
    png = tmp_path / "belief.png"
    assert run_cli(["belief-plot", "inspect", "--particles", "20", "-o", str(png)]) == 0
    sweep = tmp_path / "sweep"
    argv = ["--tasks", "progress", "--variants", "both", "--seeds", "0", "--budget", "30"]
    assert run_cli(["experiment", *argv, "--no-progress", "-o", str(sweep)]) == 0
    merged = tmp_path / "merged"
    assert run_cli(["report", str(sweep), str(sweep), "-o", str(merged)]) == 0
    capsys.readouterr()
    outputs = [gif, log, png, tmp_path / "render.png", tmp_path / "fmt.pddl"]
    outputs += sorted((tmp_path / "compiled").iterdir())
    outputs += [sweep / "episodes.jsonl", sweep / "table.md", sweep / "table1.png"]
    outputs += sorted((sweep / "logs").iterdir())
    outputs += [merged / "episodes.jsonl", merged / "table.md", merged / "table1.png"]
    assert len(outputs) >= 14
    modes = {p.relative_to(tmp_path).as_posix(): oct(_mode(p)) for p in outputs}
    assert modes == {name: oct(mode) for name in modes}


# ---------------------------------------------------------------- 13: journal lines of wrong types


def _record(seed, **changes) -> dict:
    rec = {
        "task": "progress",
        "variant": "both",
        "seed": seed,
        "status": "finished",
        "success": True,
        "failure": None,
        "planning_time": 1.5,
        "cycles": 3,
        "constrained_held": 1,
        "fallbacks": 0,
        "settings": PROGRESS_SETTINGS,
        "commit": "0123456789ab",
        "version": "0.1.0",
    }
    rec.update(changes)
    return rec


BAD_LINES = [
    json.dumps({**_record(1), "seed": "x"}),
    json.dumps(_record(2, planning_time="fast")),
    json.dumps(_record(3, task=None)),
    json.dumps(_record(4, cycles=2.5)),
    '{"task": "progress", "vari',  # cut short by a killed sweep
]


def _journal(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "episodes.jsonl"
    path.write_text("\n".join([json.dumps(_record(0)), *BAD_LINES]) + "\n")
    return path


def _names_each_bad_line(err: str, path: Path) -> None:
    assert "5 unreadable line(s) skipped" in err
    assert f"{path}:2: 'seed' is \"x\"" in err
    assert f"{path}:3: 'planning_time' is \"fast\"" in err
    assert f"{path}:4: no 'task'" in err
    assert f"{path}:5: 'cycles' is 2.5" in err
    assert f"{path}:6: not a complete JSON line" in err
    assert "Traceback" not in err and "internal error" not in err


def test_report_names_every_line_it_skips(tmp_path, capsys):
    path = _journal(tmp_path / "sweep")
    assert run_cli(["report", str(tmp_path / "sweep")]) == 0
    captured = capsys.readouterr()
    _names_each_bad_line(captured.err, path)
    assert "(n=1)" in captured.out  # the one good record is the table
    note = f"Not in the table: 5 unreadable line(s) of {path} (lines 2, 3, 4, 5, 6"
    assert note in captured.out and note in (tmp_path / "sweep" / "table.md").read_text()


def test_a_journal_of_bad_lines_only_is_bad_input_naming_them(tmp_path, capsys):
    folder = tmp_path / "sweep"
    folder.mkdir()
    (folder / "episodes.jsonl").write_text(BAD_LINES[0] + "\n")
    assert run_cli(["report", str(folder)]) == 2
    err = capsys.readouterr().err
    assert f"{folder / 'episodes.jsonl'}:1: 'seed' is \"x\"" in err


def test_a_resumed_sweep_says_which_lines_it_skipped(tmp_path, capsys):
    path = _journal(tmp_path / "sweep")
    argv = ["--tasks", "progress", "--variants", "both", "--seeds", "0", "--budget", "30"]
    assert run_cli(["experiment", *argv, "--no-progress", "-o", str(tmp_path / "sweep")]) == 0
    err = capsys.readouterr().err
    _names_each_bad_line(err, path)
    assert "their episodes run again" in err
    assert "ran 0 episode(s)" in err and "1 already on file" in err


# ---------------------------------------------------------------- 14: no temporary folders left


def _sweep_process(tmpdir: Path, out: Path, tasks: str, *extra: str) -> subprocess.Popen:
    env = {**os.environ, "TMPDIR": str(tmpdir)}
    return subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from ssr_compile.cli import main; sys.exit(main(sys.argv[1:]))",
            "experiment",
            "--tasks",
            tasks,
            "--variants",
            "both",
            "--no-progress",
            "-o",
            str(out),
            *extra,
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        # a shell that started the suite in the background ignores SIGINT and its children
        # inherit that: give the sweep the default disposition a terminal gives
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _pid_file(seed: int) -> Path:
    sys.path.insert(0, str(FIXTURE))
    try:
        from experiment_fixture_env import pid_file
    finally:
        sys.path.remove(str(FIXTURE))
    return pid_file(seed)


def _wait_for_episode(pids: Path) -> None:
    """Until the fixture's episode has written its two pids (at most 30 s)."""
    for _ in range(300):
        if pids.exists() and len(pids.read_text().split()) == 2:
            return
        time.sleep(0.1)


@pytest.mark.parametrize("how", ["SIGINT", "SIGTERM"])
def test_a_stopped_sweep_leaves_no_temporary_folders(tmp_path, how):
    tmpdir = Path(tempfile.mkdtemp(prefix="ssr-t-"))  # short: its own temporary directory
    seed = 920_000 + os.getpid() % 10_000 + (how == "SIGTERM")
    pids = _pid_file(seed)
    pids.unlink(missing_ok=True)
    sweep = _sweep_process(
        tmpdir, tmp_path / "out", f"{FIXTURE}:tmp-hang", "--seeds", str(seed), "--wall-limit", "300"
    )
    try:
        _wait_for_episode(pids)
        assert pids.exists(), sweep.stderr.read() if sweep.poll() is not None else "no episode"
        episode_tmp = [p for p in tmpdir.rglob("ssr-fd-*")]
        assert episode_tmp, "the fixture's planner folder is there while the episode runs"
        sweep.send_signal(getattr(signal, how))
        code = sweep.wait(60)
    finally:
        if sweep.poll() is None:
            sweep.kill()
        pids.unlink(missing_ok=True)
    assert code == 128 + getattr(signal, how)
    try:
        assert sorted(p.name for p in tmpdir.rglob("*")) == []
    finally:
        import shutil

        shutil.rmtree(tmpdir, ignore_errors=True)


def test_the_folder_of_a_killed_sweep_is_removed_by_the_next(tmp_path, monkeypatch):
    from ssr_compile.experiment import sweep as sweep_module

    tmpdir = Path(tempfile.mkdtemp(prefix="ssr-t-"))
    seed = 930_000 + os.getpid() % 10_000
    pids = _pid_file(seed)
    pids.unlink(missing_ok=True)
    sweep = _sweep_process(
        tmpdir, tmp_path / "out", f"{FIXTURE}:tmp-hang", "--seeds", str(seed), "--wall-limit", "300"
    )
    try:
        _wait_for_episode(pids)
        helper = int(pids.read_text().split()[1])
        sweep.kill()  # SIGKILL: nothing of the sweep's own runs
        sweep.wait(30)
        try:
            os.kill(helper, signal.SIGKILL)  # in a session of its own: out of the sweep's reach
        except ProcessLookupError:
            pass
        left = [p.name for p in tmpdir.glob("ssr-sweep-*")]
        assert len(left) == 1
        monkeypatch.setattr(tempfile, "tempdir", str(tmpdir))
        sweep_module._remove_stale_tmp_roots(min_age=0)  # as the next sweep starts
        assert list(tmpdir.glob("ssr-sweep-*")) == []
    finally:
        if sweep.poll() is None:
            sweep.kill()
        pids.unlink(missing_ok=True)
        import shutil

        shutil.rmtree(tmpdir, ignore_errors=True)


def test_a_running_sweeps_folder_is_not_removed(tmp_path, monkeypatch):
    from ssr_compile.experiment import sweep as sweep_module

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    root, fd = sweep_module._make_tmp_root()
    try:
        sweep_module._remove_stale_tmp_roots(min_age=0)
        assert Path(root).is_dir()
    finally:
        os.close(fd)
    sweep_module._remove_stale_tmp_roots(min_age=0)
    assert not Path(root).exists()


def test_a_ray_sweep_leaves_no_temporary_folders(tmp_path):
    pytest.importorskip("ray", reason="Ray is not installed (pip install 'ssr-compile[ray]')")
    tmpdir = Path(tempfile.mkdtemp(prefix="ssr-t-"))  # short: Ray's sockets are in it
    try:
        sweep = _sweep_process(
            tmpdir,
            tmp_path / "out",
            "progress",
            "--seeds",
            "0",
            "--budget",
            "30",
            "--executor",
            "ray",
            "--workers",
            "1",
        )
        _, err = sweep.communicate(timeout=300)
        assert sweep.returncode == 0, err
        assert sorted(p.name for p in tmpdir.iterdir()) == []
    finally:
        import shutil

        shutil.rmtree(tmpdir, ignore_errors=True)


# ---------------------------------------------------------------- 15: seeds


def test_seed_ranges_parse_in_linear_time_and_absurd_counts_are_refused(capsys):
    from ssr_compile.cli.options import MAX_SEEDS, seed_list

    t0 = time.monotonic()
    assert seed_list(f"0-{MAX_SEEDS - 1}") == list(range(MAX_SEEDS))
    assert seed_list("5-9,0-7") == [5, 6, 7, 8, 9, 0, 1, 2, 3, 4]
    assert time.monotonic() - t0 < 1.0  # quadratic: 10k seeds took 1.4 s
    for text in ("0-200000", "0-4294967295", f"0-{MAX_SEEDS // 2},{MAX_SEEDS}-{2 * MAX_SEEDS}"):
        t0 = time.monotonic()
        code = run_cli(["experiment", "--tasks", "progress", "--seeds", text, "-o", "unused"])
        assert code == 2 and time.monotonic() - t0 < 5.0
        err = capsys.readouterr().err
        assert f"seeds; at most {MAX_SEEDS} in one sweep" in err
    assert not Path("unused").exists()


def test_one_rule_for_a_seed_in_every_command(tmp_path, capsys):
    from ssr_compile.cli.app import build_parser

    commands = {
        "run": ["run", "progress"],
        "solve": ["solve", D, S, P],
        "render": ["render", "inspect", "-o", "x.png"],
        "belief-plot": ["belief-plot", "inspect", "-o", "x.png"],
    }
    parser = build_parser()
    for name, argv in commands.items():
        assert parser.parse_args([*argv, "--seed", str(2**32 - 1)]).seed == 2**32 - 1
        for bad in (str(2**70), str(2**32), "-1", "x"):
            with pytest.raises(SystemExit):
                parser.parse_args([*argv, "--seed", bad])
            err = capsys.readouterr().err
            assert f"expected a seed (seeds are whole numbers from 0 to {2**32 - 1}" in err, name
            assert "numpy" not in err
    code = run_cli(["experiment", "--tasks", "progress", "--seeds", str(2**70), "-o", "unused"])
    assert code == 2
    assert f"seeds are whole numbers from 0 to {2**32 - 1}" in capsys.readouterr().err


# ---------------------------------------------------------------- 16: banner and colours


def test_pybullet_banner_stays_out_of_a_kitchen_sweep(tmp_path):
    tmpdir = Path(tempfile.mkdtemp(prefix="ssr-t-"))
    try:
        env = {**os.environ, "TMPDIR": str(tmpdir)}
        proc = subprocess.run(
            [
                sys.executable,
                "-c",
                "import sys; from ssr_compile.cli import main; sys.exit(main(sys.argv[1:]))",
                "experiment",
                "--tasks",
                "inspect",
                "--variants",
                "both",
                "--seeds",
                "0",
                "--wall-limit",
                "3",
                "-o",
                str(tmp_path / "out"),
            ],
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
    finally:
        import shutil

        shutil.rmtree(tmpdir, ignore_errors=True)
    assert proc.returncode == 0, proc.stderr
    assert "episodes" in proc.stderr  # the progress bar was drawn
    assert "pybullet build time" not in proc.stdout + proc.stderr


def test_an_object_has_the_same_colour_in_the_top_view_and_the_belief_plot(tmp_path, monkeypatch):
    from matplotlib.axes import Axes
    from matplotlib.colors import to_rgb
    from ssr_compile.sim.render import render_task
    from ssr_compile.sim.tasks import make_task

    from ssr_compile.belief.particles import PoseBelief
    from ssr_compile.belief.plot import belief_figure

    drawn: dict[str, tuple] = {}
    real_scatter = Axes.scatter

    def scatter(self, *args, **kwargs):
        if "label" in kwargs and "c" in kwargs:
            drawn[kwargs["label"]] = to_rgb(kwargs["c"])
        return real_scatter(self, *args, **kwargs)

    monkeypatch.setattr(Axes, "scatter", scatter)
    render_task("cook", 0, str(tmp_path / "top.png"), view="top")
    monkeypatch.setattr(Axes, "scatter", real_scatter)
    task = make_task("cook", 0)
    try:
        rng = np.random.default_rng(0)
        beliefs = {
            obj: PoseBelief.uniform(obj, [s for s, _ in entries], 20, rng)
            for obj, entries in task.prior_surfaces().items()
        }
    finally:
        task.close()
    fig = belief_figure(beliefs, [])
    try:
        plotted = {}
        for ax in fig.axes:
            for c in ax.collections:
                gid = c.get_gid() or ""
                if gid.startswith("particles:"):
                    plotted[gid.split(":", 1)[1]] = tuple(np.round(c.get_facecolors()[0][:3], 3))
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    assert set(drawn) == set(plotted) == {"block", "sugar_box", "cracker_box"}
    for obj in drawn:
        assert tuple(np.round(drawn[obj], 3)) == plotted[obj], obj
    assert len(set(plotted.values())) == 3
