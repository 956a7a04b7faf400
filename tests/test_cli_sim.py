"""`ssr-compile render` and `belief-plot`: pictures of the kitchen tasks."""

import pytest

from ssr_compile.cli import main

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("view", ["camera", "top"])
def test_render_writes_a_png(tmp_path, view, capsys):
    out = tmp_path / "scene.png"
    assert main(["render", "cook", "--seed", "3", "--view", view, "-o", str(out)]) == 0
    data = out.read_bytes()
    assert data.startswith(PNG) and len(data) > 5000
    assert "cook, seed 3" in capsys.readouterr().out
    assert [p.name for p in tmp_path.iterdir()] == ["scene.png"]  # no temporary file left


def test_belief_plot_draws_every_object_of_the_prior(tmp_path, capsys):
    out = tmp_path / "belief.png"
    assert main(["belief-plot", "cook", "--seed", "1", "--particles", "50", "-o", str(out)]) == 0
    assert out.read_bytes().startswith(PNG)
    said = capsys.readouterr().out
    assert "block" in said and "cracker_box" in said and "sugar_box" in said


def test_render_refuses_other_formats_and_unknown_tasks(tmp_path, capsys):
    assert main(["render", "cook", "-o", str(tmp_path / "scene.jpg")]) == 2
    assert ".png" in capsys.readouterr().err
    assert not (tmp_path / "scene.jpg").exists()
    with pytest.raises(SystemExit) as e:
        main(["render", "dance", "-o", str(tmp_path / "x.png")])
    assert e.value.code == 2


def test_gui_without_a_display_is_a_clear_error(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["render", "inspect", "--gui", "-o", str(tmp_path / "s.png")]) == 2
    assert "needs a display" in capsys.readouterr().err
