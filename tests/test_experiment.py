"""``ssr-compile experiment`` / ``report`` (issue 12): the Table I harness on the small
environments (progress) and on a test-only example that crashes, hangs or runs out of memory."""

from __future__ import annotations

import json
import math
import os
import re
import time
from pathlib import Path

import pytest

from ssr_compile import experiment as X
from ssr_compile.cli import main

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "experiment" / "misbehave"


def run_cli(argv: list[str]) -> int:
    import ssr_compile.cli.experiment  # noqa: F401 - registers the commands

    try:
        return main(argv)
    except SystemExit as e:  # argparse's own bad input
        return int(e.code)


def lines(out: Path) -> list[dict]:
    return [json.loads(x) for x in (out / "episodes.jsonl").read_text().splitlines() if x.strip()]


SWEEP = [
    "--tasks",
    "progress",
    "--variants",
    "neither,both",
    "--seeds",
    "0-1",
    "--budget",
    "30",
    "--no-progress",
]
FIELDS = {
    "task",
    "variant",
    "seed",
    "success",
    "planning_time",
    "cycles",
    "constrained_held",
    "fallbacks",
    "stream_calls",
    "planner_calls",
    "failure",
    "wall_time",
    "version",
    "commit",
    "status",
}


def test_sweep_runs_resumes_and_reports(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert run_cli(["experiment", *SWEEP, "-o", str(out)]) == 0
    recs = lines(out)
    assert sorted((r["variant"], r["seed"]) for r in recs) == [
        ("both", 0),
        ("both", 1),
        ("neither", 0),
        ("neither", 1),
    ]
    for r in recs:
        assert FIELDS <= r.keys()
        assert r["task"] == "progress" and r["status"] == "finished"
        assert r["success"] is True and r["failure"] is None  # progress succeeds in 30 s
        assert r["cycles"] >= 2 and r["planner_calls"] >= 1 and r["planning_time"] > 0
        assert r["wall_time"] >= r["episode_time"] and r["cpu_time"] > 0
        assert r["version"] == X.provenance()["version"]
        # the episode's log: one line per cycle, then the outcome
        log = Path(r["log"]).read_text().splitlines()
        cycles = [x for x in log if x.startswith("cycle ")]
        assert len(cycles) == r["cycles"] and cycles[0].startswith("cycle   1  (move-base")
        assert log[-1] == "outcome: goal belief reached; success True"
    assert (out / "table.md").is_file() and (out / "table1.png").stat().st_size > 1000
    before = (out / "episodes.jsonl").read_text()
    capsys.readouterr()

    # the same command again: nothing re-run
    assert run_cli(["experiment", *SWEEP, "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "4 of 4 episodes already" in err and "ran 0 episode(s)" in err
    assert (out / "episodes.jsonl").read_text() == before

    # one more seed: only its two episodes run
    more = [*SWEEP]
    more[more.index("0-1")] = "0-2"
    assert run_cli(["experiment", *more, "-o", str(out)]) == 0
    recs = lines(out)
    assert len(recs) == 6 and (out / "episodes.jsonl").read_text().startswith(before)
    assert {r["seed"] for r in recs[4:]} == {2}

    # other settings on file: refused, nothing run
    other = [*SWEEP]
    other[other.index("30")] = "20"
    assert run_cli(["experiment", *other, "-o", str(out)]) == 2
    assert "other settings: budget 30.0 (this run: 20.0)" in capsys.readouterr().err
    assert len(lines(out)) == 6

    # report rebuilds the same table from the JSON lines alone
    table = (out / "table.md").read_text()
    (out / "table.md").unlink()
    (out / "table1.png").unlink()
    assert run_cli(["report", str(out)]) == 0
    assert (out / "table1.png").is_file()
    rebuilt = (out / "table.md").read_text()
    assert rebuilt.split("Command:")[0].rstrip() == table.split("Command:")[0].rstrip()
    ok = [r["planning_time"] for r in recs if r["variant"] == "both" and r["success"]]
    row = next(x for x in rebuilt.splitlines() if x.startswith("| **progress** | ours"))
    assert f"100 [{100 * X.wilson(3, 3)[0]:.0f}, 100] (n=3)" in row
    assert X.fmt_time(sum(ok) / len(ok)) in row.split("|")[-2]


def _record(task, variant, seed, success, t=None, status="finished"):
    return {
        "task": task,
        "variant": variant,
        "seed": seed,
        "success": success,
        "planning_time": t,
        "status": status,
        "failure": None if success else "x",
        "settings": {
            "budget": 600.0,
            "max_cycles": 100,
            "constrained_time": 30.0,
            "unconstrained_time": 300.0,
            "planner": "fd",
        },
        "version": "0.1.0",
        "commit": "abc",
        "dirty": False,
    }


def _wilson(k, n, z=1.959963984540054):
    # the textbook formula, written independently of the module's
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0, c - h), min(1, c + h)


def test_report_numbers_are_recomputed_from_the_json_lines(tmp_path, capsys):
    out = tmp_path / "made"
    out.mkdir()
    times = [30.0, 50.0, 40.0]
    recs = [_record("inspect", "both", s, True, t) for s, t in enumerate(times)]
    recs += [_record("inspect", "both", 3, False, 100.0)]  # a failure: its time not counted
    recs += [_record("inspect", "neither", s, s == 0, 10.0) for s in range(4)]
    recs += [_record("cook", "neither", 0, False, None, status="crashed")]
    recs += [_record("progress", "both", 0, True, 0.5)]
    with open(out / "episodes.jsonl", "w") as f:
        for r in recs:
            f.write(json.dumps(r) + "\n")
        f.write('{"task": "inspect", "vari')  # a line cut short by a killed sweep
    assert run_cli(["report", str(out)]) == 0
    text = (out / "table.md").read_text()
    assert text == capsys.readouterr().out.rstrip("\n") + "\n"
    rows, last = {}, ""
    for line in text.splitlines():
        m = re.match(r"\| (\*\*\w+\*\*|) \| (ours|paper) \|(.*)\|$", line)
        if m:
            task = m.group(1).strip("*") or last
            last = task
            rows[(task, m.group(2))] = [c.strip() for c in m.group(3).split("|")]
    header = next(x for x in text.splitlines() if x.startswith("| Task"))
    assert "Neither %" in header and header.index("Neither") < header.index("Both")
    # inspect, both: 3 of 4, Wilson interval; mean of the successes' times and its bootstrap
    lo, hi = _wilson(3, 4)
    neither_pct, neither_t, both_pct, both_t = rows[("Inspect", "ours")]
    assert both_pct == f"75 [{100 * lo:.0f}, {100 * hi:.0f}] (n=4)"
    b_lo, b_hi = X.bootstrap_mean(times, X.cell_seed("inspect", "both"))
    assert both_t == f"40.0 [{X.fmt_time(b_lo)}, {X.fmt_time(b_hi)}]"
    assert 30 <= b_lo <= 40 <= b_hi <= 50
    lo, hi = _wilson(1, 4)
    assert neither_pct == f"25 [{100 * lo:.0f}, {100 * hi:.0f}] (n=4)"
    assert neither_t == "10.0 [10.0, 10.0]"
    assert rows[("Inspect", "paper")] == ["96", "41", "100", "26"]
    # a crash counts as a failure, and is named
    assert rows[("Cook", "ours")][0] == f"0 [0, {100 * _wilson(0, 1)[1]:.0f}] (n=1)"
    assert rows[("Cook", "paper")] == ["20", "375", "100", "203"]
    assert "1 crashed" in text
    # a task without the paper's numbers: ours only, after the kitchen's tasks
    assert ("progress", "ours") in rows and ("progress", "paper") not in rows
    order = [k[0] for k in rows if k[1] == "ours"]
    assert order == ["Inspect", "Cook", "progress"]
    assert (out / "table1.png").stat().st_size > 1000
    # the bootstrap is seeded: the same lines, the same table
    assert run_cli(["report", str(out)]) == 0
    assert (out / "table.md").read_text() == text


def test_crashes_and_out_of_memory_are_recorded_and_the_sweep_goes_on(tmp_path, capsys):
    out = tmp_path / "crash"
    tasks = ",".join(f"{FIXTURE}:{p}" for p in ("raise", "exit", "segv", "oom", "flaky"))
    code = run_cli(
        [
            "experiment",
            "--tasks",
            tasks,
            "--variants",
            "both",
            "--seeds",
            "0-1",
            "--budget",
            "30",
            "--no-progress",
            "-o",
            str(out),
        ]
    )
    assert code == 0
    recs = {(r["problem"], r["seed"]): r for r in lines(out)}
    assert len(recs) == 10
    for seed in (0, 1):
        assert recs[("raise", seed)]["status"] == "crashed"
        assert recs[("raise", seed)]["failure"] == (
            "crashed: RuntimeError: fixture: the world cannot be built"
        )
        assert recs[("exit", seed)]["failure"] == (
            "crashed: the episode's process exited with code 3 without a result"
        )
        assert recs[("segv", seed)]["failure"] == "crashed: killed by SIGSEGV"
        assert recs[("oom", seed)]["status"] == "oom"
        assert "out of memory" in recs[("oom", seed)]["failure"]
    assert recs[("flaky", 1)]["status"] == "crashed"
    assert recs[("flaky", 0)]["status"] == "finished" and recs[("flaky", 0)]["success"]
    assert sum(r["success"] for r in recs.values()) == 1
    # the traceback of a crash is in the episode's log
    assert "RuntimeError" in Path(recs[("raise", 0)]["log"]).read_text()
    table = (out / "table.md").read_text()
    assert "8 crashed" not in table and "2 oom" in table and "7 crashed" in table
    # crashed episodes are finished episodes: a second run re-runs nothing
    capsys.readouterr()
    assert (
        run_cli(
            [
                "experiment",
                "--tasks",
                tasks,
                "--variants",
                "both",
                "--seeds",
                "0-1",
                "--budget",
                "30",
                "--no-progress",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    assert "ran 0 episode(s)" in capsys.readouterr().err


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def test_a_hanging_episode_is_killed_at_its_wall_limit(tmp_path):
    import sys

    sys.path.insert(0, str(FIXTURE))
    try:
        from experiment_fixture_env import pid_file
    finally:
        sys.path.remove(str(FIXTURE))
    seed = 900_000 + os.getpid() % 10_000
    pid_file(seed).unlink(missing_ok=True)
    out = tmp_path / "hang"
    t0 = time.monotonic()
    code = run_cli(
        [
            "experiment",
            "--tasks",
            f"{FIXTURE}:hang,progress",
            "--variants",
            "both",
            "--seeds",
            str(seed),
            "--budget",
            "30",
            "--wall-limit",
            "3",
            "--workers",
            "2",
            "--no-progress",
            "-o",
            str(out),
        ]
    )
    assert code == 0
    assert time.monotonic() - t0 < 30
    recs = {r["task"].rsplit(":", 1)[-1]: r for r in lines(out)}
    hang = recs["hang"]
    assert hang["status"] == "timeout" and hang["success"] is False
    assert hang["failure"] == "timeout: wall limit of 3 s reached (killed)"
    assert 3 <= hang["wall_time"] < 15
    assert recs["progress"]["status"] == "finished"  # the other worker went on
    helper = int(pid_file(seed).read_text().split()[1])
    pid_file(seed).unlink()
    for _ in range(50):  # the helper it started in a session of its own is killed too
        if not _alive(helper):
            break
        time.sleep(0.1)
    assert not _alive(helper)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--tasks", "nosuchtask"], "unknown task 'nosuchtask'"),
        (["--tasks", "progress", "--variants", "both,sometimes"], "unknown variant 'sometimes'"),
        (["--tasks", "progress", "--seeds", "5-2"], "'5-2' is an empty range"),
        (["--tasks", "progress", "--seeds", "0,x"], "'x' is not a seed"),
        (["--tasks", "progress", "--seeds", "-3"], "'-3' is not a seed"),
        (["--tasks", "progress", "--seeds", ""], "--seeds: empty"),
        (["--tasks", "progress", "--budget", "0"], "greater than 0, got '0'"),
        (["--tasks", "progress", "--budget", "-5"], "greater than 0, got '-5'"),
        (["--tasks", "progress", "--budget", "nan"], "greater than 0, got 'nan'"),
        (["--tasks", "progress", "--workers", "0"], ">= 1, got '0'"),
        (["--tasks", "progress,progress"], "'progress' is named twice"),
        (["--tasks", "tamp2d"], "names no environment"),
    ],
)
def test_bad_input_exits_2_with_a_message(tmp_path, capsys, argv, message):
    out = tmp_path / "bad"
    assert run_cli(["experiment", *argv, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (out / "episodes.jsonl").exists()


def test_default_tasks_need_the_kitchen_environment(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(X, "kitchen_has_environment", lambda: False)
    assert run_cli(["experiment", "--seeds", "0", "-o", str(tmp_path / "k")]) == 2
    assert "the kitchen has no closed-loop environment yet" in capsys.readouterr().err


def test_report_of_a_folder_without_a_sweep(tmp_path, capsys):
    assert run_cli(["report", str(tmp_path)]) == 2
    assert "no episodes.jsonl" in capsys.readouterr().err


def test_seed_lists():
    from ssr_compile.cli.options import seed_list

    assert seed_list("0-24") == list(range(25))
    assert seed_list("0,3,5") == [0, 3, 5]
    assert seed_list("4-6, 1, 5") == [4, 5, 6, 1]


def test_wilson_interval_known_values():
    lo, hi = X.wilson(24, 25)  # the paper's 96%
    assert (round(lo, 3), round(hi, 3)) == (0.805, 0.993)
    assert X.wilson(0, 10)[0] == 0 and X.wilson(10, 10)[1] == 1


def test_ray_executor_runs_the_same_sweep(tmp_path, capsys):
    pytest.importorskip("ray", reason="Ray is not installed (pip install 'ssr-compile[ray]')")
    out = tmp_path / "ray"
    argv = [
        "experiment",
        "--tasks",
        f"progress,{FIXTURE}:exit",
        "--variants",
        "neither,both",
        "--seeds",
        "0",
        "--budget",
        "30",
        "--executor",
        "ray",
        "--workers",
        "2",
        "--no-progress",
        "-o",
        str(out),
    ]
    assert run_cli(argv) == 0
    recs = {(r["task"].rsplit(":", 1)[-1], r["variant"]): r for r in lines(out)}
    assert len(recs) == 4
    for v in ("neither", "both"):
        assert recs[("progress", v)]["success"] is True
        assert recs[("progress", v)]["status"] == "finished"
        assert recs[("exit", v)]["failure"] == (
            "crashed: the episode's process exited with code 3 without a result"
        )
    assert (out / "table.md").is_file() and (out / "table1.png").is_file()
    capsys.readouterr()
    assert run_cli(argv) == 0  # resumes alike: nothing re-run (and no Ray started for nothing)
    assert "ran 0 episode(s)" in capsys.readouterr().err
    assert len(lines(out)) == 4


def _fixture_pid_file(seed: int) -> Path:
    import sys

    sys.path.insert(0, str(FIXTURE))
    try:
        from experiment_fixture_env import pid_file
    finally:
        sys.path.remove(str(FIXTURE))
    return pid_file(seed)


@pytest.mark.parametrize("how", ["SIGINT", "SIGKILL"])
def test_no_episode_outlives_its_sweep(tmp_path, how):
    """Ctrl-C: the sweep kills its episodes' process trees and exits 130; SIGKILL: the
    episode's process dies with the fork server, which exits with the sweep."""
    import signal
    import subprocess
    import sys

    seed = 910_000 + os.getpid() % 10_000 + (how == "SIGKILL")
    pids = _fixture_pid_file(seed)
    pids.unlink(missing_ok=True)
    out = tmp_path / "killed"
    sweep = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from ssr_compile.cli import main; sys.exit(main(sys.argv[1:]))",
            "experiment",
            "--tasks",
            f"{FIXTURE}:hang",
            "--variants",
            "both",
            "--seeds",
            str(seed),
            "--wall-limit",
            "300",
            "--no-progress",
            "-o",
            str(out),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        # a shell that started the suite in the background ignores SIGINT and its children
        # inherit that: give the sweep the default disposition a terminal gives
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        for _ in range(300):
            if pids.exists() and len(pids.read_text().split()) == 2:
                break
            time.sleep(0.1)
        episode, helper = map(int, pids.read_text().split())
        sweep.send_signal(getattr(signal, how))
        code = sweep.wait(30)
    finally:
        if sweep.poll() is None:
            sweep.kill()
        pids.unlink(missing_ok=True)
    if how == "SIGINT":
        assert code == 130 and "interrupted" in sweep.stderr.read()
        dead = (episode, helper)
    else:
        dead = (episode,)  # a helper in a session of its own is out of reach after SIGKILL
        try:
            os.kill(helper, signal.SIGKILL)
        except ProcessLookupError:
            pass
    for _ in range(100):
        if not any(_alive(p) for p in dead):
            break
        time.sleep(0.1)
    assert not any(_alive(p) for p in dead)
    assert not (out / "episodes.jsonl").read_text().strip()  # nothing recorded for it


def _write(folder: Path, recs: list[dict]) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "episodes.jsonl", "w") as f:
        for r in recs:
            f.write(json.dumps(r) + "\n")


def test_sweeps_are_merged_into_one_table_with_the_details(tmp_path, capsys):
    # Table I is run in pieces (a variant, a range of seeds at a time); one table of them all,
    # with what Table I does not show: seeds, failures, cycles, constrained attempts.
    a, b, out = tmp_path / "a", tmp_path / "b", tmp_path / "all"

    def rec(seed, ok, t, cycles, held, fell, commit, variant="both"):
        r = _record("swap", variant, seed, ok, t)
        r.update(cycles=cycles, constrained_held=held, fallbacks=fell, commit=commit)
        return r

    _write(
        a, [rec(0, True, 100.0, 30, 20, 4, "aaaaaaa1"), rec(1, False, 600.0, 50, 3, 9, "aaaaaaa1")]
    )
    _write(
        b,
        [
            rec(1, True, 200.0, 40, 25, 2, "bbbbbbb2"),  # seed 1 again: this one counts
            rec(2, True, 150.0, 20, 10, 0, "bbbbbbb2"),
            rec(3, True, 120.0, 10, 0, 0, "bbbbbbb2", variant="neither"),
        ],
    )
    assert run_cli(["report", str(a), str(b)]) == 2  # several folders need -o
    assert "need -o OUT" in capsys.readouterr().err
    assert run_cli(["report", str(a), str(b), "-o", str(a)]) == 2  # a sweep's journal is kept
    assert "would be overwritten" in capsys.readouterr().err
    assert len(lines(a)) == 2
    assert run_cli(["report", str(a), str(b), "-o", str(out)]) == 0
    text = (out / "table.md").read_text()
    merged = lines(out)
    assert sorted((r["variant"], r["seed"]) for r in merged) == [
        ("both", 0), ("both", 1), ("both", 2), ("neither", 3)
    ]  # fmt: skip
    assert next(r for r in merged if r["seed"] == 1)["commit"] == "bbbbbbb2"
    rows = {
        tuple(c.strip() for c in line.strip("|").split("|"))[1]: [
            c.strip() for c in line.strip("|").split("|")
        ]
        for line in text.splitlines()
        if line.startswith("| Swap |")
    }
    # both: seeds 0-2, none failed, median of 100/200/150, cycles (30+40+20)/3, 55 held / 6 fell
    assert rows["both"] == ["Swap", "both", "0-2", "–", "150", "30.0", "55 / 6", "aaaaaaa, bbbbbbb"]
    assert rows["neither"] == ["Swap", "neither", "3", "–", "120", "10.0", "0 / 0", "bbbbbbb"]
    assert "100 [" in text and "(n=3)" in text  # Table I's cell: 3 of 3
    # the merged folder is a report of its own: rebuilt alone, the same table
    assert run_cli(["report", str(out)]) == 0
    assert (out / "table.md").read_text() == text


def test_seed_lists_are_folded():
    assert X.seed_list([5, 0, 1, 2, 7, 8, 3]) == "0-3,5,7-8"
    assert X.seed_list([]) == "–"
    assert X.median([3.0, 1.0, 2.0, 10.0]) == 2.5


def test_report_publishes_the_table_between_the_marks_of_pages(tmp_path, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    recs = [_record("inspect", "both", s, True, 2.0 + s) for s in range(3)]
    (out / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    docs = tmp_path / "docs"
    docs.mkdir()
    page = docs / "experiments.md"
    page.write_text(
        "# Experiments\n\nintro\n\n<!-- table-of-record -->\nan old table\n"
        "<!-- /table-of-record -->\n\nWhy ours differs.\n"
    )
    readme = tmp_path / "README.md"
    readme.write_text("# Tool\n<!-- table-of-record -->\n<!-- /table-of-record -->\nend\n")
    argv = ["report", str(out), "--into", str(page), "--into", str(readme)]
    assert run_cli(argv) == 0
    table = (out / "table.md").read_text()
    text = page.read_text()
    # the page's own text is kept, the old table replaced by the sweep's (without its title)
    assert text.startswith("# Experiments\n\nintro\n\n<!-- table-of-record -->\n")
    assert text.endswith("<!-- /table-of-record -->\n\nWhy ours differs.\n")
    assert "an old table" not in text and "# Table I:" not in text
    row = next(x for x in table.splitlines() if x.startswith("| **Inspect** | ours"))
    assert row in text and row in readme.read_text()
    # the plot beside the first page, linked from each page by its own relative path
    assert (docs / "table1.png").stat().st_size > 1000
    assert "](table1.png)" in text and "](docs/table1.png)" in readme.read_text()
    # published again: the same page (the marks are kept)
    assert run_cli(argv) == 0
    assert page.read_text() == text


@pytest.mark.parametrize(
    "body, found",
    [
        ("no marks\n", "found 0 line(s) <!-- table-of-record -->"),
        ("<!-- /table-of-record -->\n<!-- table-of-record -->\n", "before"),
        ("<!-- table-of-record -->\n<!-- table-of-record -->\n<!-- /table-of-record -->\n", ":2"),
    ],
)
def test_report_refuses_a_page_without_its_marks_and_writes_nothing(tmp_path, capsys, body, found):
    out = tmp_path / "sweep"
    out.mkdir()
    (out / "episodes.jsonl").write_text(json.dumps(_record("inspect", "both", 0, True, 2.0)) + "\n")
    page = tmp_path / "page.md"
    page.write_text(body)
    assert run_cli(["report", str(out), "--into", str(page)]) == 2
    err = capsys.readouterr().err
    assert str(page) in err and found in err and "Traceback" not in err
    assert page.read_text() == body
    assert not (out / "table.md").exists() and not (tmp_path / "table1.png").exists()
