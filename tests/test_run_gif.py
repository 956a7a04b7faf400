"""``ssr-compile run --gif``: frames of the kitchen from the fixed camera with the beliefs'
particles drawn over them, written as an animated GIF."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image
from ssr_compile.streams.environments import kitchen_gif

from ssr_compile.cli import main
from ssr_compile.cli.run import _write_gif


def test_a_kitchen_frame_shows_the_camera_view_the_particles_and_the_caption():
    episode = kitchen_gif.make_episode("inspect", 0)
    try:
        episode.agent.update(None, episode.environment.observe())
        plain = episode.render("")
        drawn = episode.render("cycle 1: (move-base bq0 t q1)")
    finally:
        episode.close()
    assert plain.shape == (480, 640, 3) and plain.dtype == np.uint8
    # the block's particles are lime: many pure-green-ish pixels that a kitchen has not
    lime = (plain[:, :, 1] > 200) & (plain[:, :, 0] < 90) & (plain[:, :, 2] < 90)
    assert lime.sum() > 50
    # the caption box (black) is drawn in the top-left corner only when there is a caption
    corner = (slice(5, 20), slice(5, 200))
    assert drawn[corner].mean() < plain[corner].mean() - 40


def test_frames_become_an_animated_gif(tmp_path):
    frames = [np.full((48, 64, 3), v, dtype=np.uint8) for v in (0, 120, 240)]
    out = tmp_path / "episode.gif"
    _write_gif(out, frames)
    im = Image.open(out)
    assert im.n_frames == 3 and im.size == (64, 48)
    assert [p for p in tmp_path.iterdir()] == [out]  # no temporary file left


def test_gif_where_the_environment_draws_nothing_is_bad_input(tmp_path, capsys):
    out = tmp_path / "x.gif"
    assert main(["run", "progress", "--gif", str(out)]) == 2
    assert "draws no pictures" in capsys.readouterr().err
    assert not out.exists()
    assert main(["run", "progress", "--gif", str(tmp_path / "no" / "x.gif")]) == 2
    assert main(["run", "progress", "--gif", str(Path(tmp_path))]) == 2
