"""A typo in a stream file's predicates (Blok for Block) is found: the warning names
file:line:col, and a solve that finds no plan says which stream can never fire."""

from __future__ import annotations

from ssr_compile.cli import main
from ssr_compile.resources import domains_dir

TAMP = domains_dir() / "tamp2d"


def _typo(tmp_path):
    text = (TAMP / "stream.pddl").read_text()
    assert "(Block ?b)" in text
    path = tmp_path / "stream.pddl"
    path.write_text(text.replace("(Block ?b)", "(Blok ?b)", 1))
    line = next(i for i, s in enumerate(path.read_text().splitlines(), 1) if "Blok" in s)
    return path, line


def test_check_names_where_the_unknown_predicate_is(tmp_path, capsys):
    path, line = _typo(tmp_path)
    assert main(["check", str(TAMP / "domain.pddl"), str(path)]) == 0  # a warning, not an error
    err = capsys.readouterr().err + capsys.readouterr().out
    assert f"{path}:{line}:" in err
    assert "stream 'sample-placement' can never fire: its domain needs 'blok'" in err


def test_solve_without_a_plan_says_which_stream_never_fires(tmp_path, capsys):
    path, line = _typo(tmp_path)
    code = main(
        [
            "solve",
            str(TAMP / "domain.pddl"),
            str(path),
            str(TAMP / "problem.pddl"),
            "--streams",
            "ssr_compile.streams.tamp2d",
            "--max-level",
            "3",
        ]  # fmt: skip
    )
    captured = capsys.readouterr()
    assert code == 1
    assert f"{path}:{line}:" in captured.err
    assert "'sample-placement' can never fire" in captured.err


def test_the_shipped_stream_files_have_no_such_warning(capsys):
    for name in ("tamp2d", "tamp2d-routes", "belief-detect", "progress", "kitchen"):
        folder = domains_dir() / name
        assert main(["check", str(folder / "domain.pddl"), str(folder / "stream.pddl")]) == 0
    captured = capsys.readouterr()
    assert "can never fire" not in captured.err + captured.out
