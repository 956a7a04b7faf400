"""Task files (issue 40): the paper's four tasks are shipped TOML files that generate the same
worlds, priors and goals as the hand-written generator did (a reference recorded from it,
tests/fixtures/kitchen_tasks_reference.json, seeds 0-5); a task file of the user's runs; bad
task files are bad input naming the file and the key.  One world of the reference changed on
purpose since: Stow seed 5's block, which stood where no grasp reached it (the generator now
places an object the goal moves within reach: tests/test_sim_tasks.py).  Poses are compared to
1e-9: their last bits are those of the sine and cosine used, and numpy's AVX-512 ones differ
from libm's by an ulp or two (the world now uses libm's, ``math``, on every CPU); Inspect seed
3, recorded on a machine whose numpy used AVX-512, drew other reach probes there from an
ulp's difference and is recorded again as generated with libm's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from ssr_compile.sim.task_file import load_task_file, shipped_task_file
from ssr_compile.sim.tasks import make_task

from ssr_compile.catalog import TASKS
from ssr_compile.cli import main
from ssr_compile.errors import SSRError

REFERENCE = json.loads(
    (Path(__file__).parent / "fixtures" / "kitchen_tasks_reference.json").read_text()
)


def _plain(value):
    return json.loads(json.dumps(value))


def _same(a, b, tol: float = 1e-9) -> bool:
    """``a`` and ``b`` (JSON values) equal, their floats to ``tol``."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k], tol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y, tol) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        return isinstance(a, (int, float)) and isinstance(b, (int, float)) and abs(a - b) <= tol
    return a == b


def test_poses_compare_to_a_billionth():
    assert _same({"p": [1.0, 2.0]}, {"p": [1.0 + 1e-12, 2.0]})
    assert not _same({"p": [1.0, 2.0]}, {"p": [1.0 + 1e-6, 2.0]})
    assert not _same({"p": [1.0]}, {"p": [1.0, 2.0]})
    assert not _same({"p": [1.0]}, {"q": [1.0]})


@pytest.mark.slow
@pytest.mark.parametrize("name", TASKS)
def test_shipped_task_files_give_the_reference_worlds(name):
    seeds = sorted(int(k.split(":")[1]) for k in REFERENCE if k.startswith(name + ":"))
    assert len(seeds) == 6
    for seed in seeds:
        ref = REFERENCE[f"{name}:{seed}"]
        task = make_task(shipped_task_file(name), seed)
        try:
            assert _same(_plain(task.world.true_state()), ref["latent"]), (name, seed)
            assert _same(_plain(task.latent), ref["latent"])
            assert _plain(task.prior) == ref["prior"]
            assert list(task.prior) == sorted(task.prior)  # the order the old code gave
            assert _plain(task.goal) == ref["goal"]
            assert task.name == name
            # the bodies in the order the old world built them (the streams iterate in it)
            kinds = ("block", "sugar_box", "cracker_box")
            assert list(task.world.objects) == [k for k in kinds if k in ref["latent"]["objects"]]
        finally:
            task.close()


OWN_TASK = """\
# a task of the user's own: a weighted prior, a resized block, a box on the counter
name = "inspect_box"
goal = ["On block bottom_drawer", "Closed bottom_drawer"]

[objects]
cracker_box = { kind = "cracker_box", on = "counter" }
block = { kind = "block", on = "bottom_drawer", size = [0.05, 0.04, 0.04] }

[prior]
block = { top_drawer = 1, bottom_drawer = 3 }
cracker_box = ["counter"]
"""


def test_a_task_file_states_objects_sizes_and_a_weighted_prior(tmp_path):
    path = tmp_path / "own.toml"
    path.write_text(OWN_TASK)
    spec = load_task_file(path)
    assert spec.prior["block"] == [("top_drawer", 0.25), ("bottom_drawer", 0.75)]
    task = make_task(path, 4)
    try:
        assert task.name == "inspect_box"
        assert task.world.half_extents["block"] == (0.025, 0.02, 0.02)
        state = task.world.true_state()
        assert state["objects"]["block"]["surface"] == "bottom_drawer"
        assert state["objects"]["cracker_box"]["surface"] == "counter"
        assert sorted(task.world.objects) == ["block", "cracker_box"]  # no other body built
        assert task.world.is_tall("cracker_box") and not task.world.is_tall("block")
    finally:
        task.close()


@pytest.mark.slow
def test_a_task_file_of_ones_own_runs_to_success_in_closed_loop(tmp_path, capsys):
    path = tmp_path / "own.toml"
    path.write_text(OWN_TASK)
    assert main(["run", str(path), "--seed", "0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["success"] and out["problem"] == str(path)
    assert any("pull bottom_drawer" in c["action"] for c in out["trace"] if c["action"])


def test_more_objects_of_a_kind_are_built_and_reach_the_problem(tmp_path):
    from ssr_compile.sim.problem import task_problem

    path = tmp_path / "three.toml"
    path.write_text(
        'goal = ["On block_2 top_drawer"]\n[objects]\n'
        'block = { kind = "block", on = "counter" }\n'
        'block_2 = { kind = "block", on = ["counter", "bottom_drawer"] }\n'
        'big = { kind = "sugar_box", on = "counter", size = [0.1, 0.06, 0.2] }\n'
        '[prior]\nblock = ["counter"]\nblock_2 = ["counter", "bottom_drawer"]\nbig = ["counter"]\n'
    )
    task = make_task(path, 1)
    try:
        assert set(task.world.true_state()["objects"]) == {"block", "block_2", "big"}
        problem, values = task_problem(task)
        init = {str(f) for f in problem.init}
        assert {"(graspable block_2)", "(tall big)", "(placeable block_2 top_drawer)"} <= init
        assert "(placeable big top_drawer)" not in init
        assert {"pb-block", "pb-block_2", "pb-big"} <= set(values)
    finally:
        task.close()


GOOD = {
    "goal": '["On block bottom_drawer"]',
    "objects": '{ block = { kind = "block", on = "counter" } }',
    "prior": '{ block = ["counter"] }',
}


def _file(tmp_path, **keys) -> Path:
    table = {**GOOD, **keys}
    path = tmp_path / "bad.toml"
    path.write_text("".join(f"{k} = {v}\n" for k, v in table.items() if v is not None))
    return path


@pytest.mark.parametrize(
    ("keys", "key", "said"),
    [
        ({"gaol": '["StoveOff"]'}, "gaol", "did you mean 'goal'"),
        ({"goal": "3"}, "goal", "expected a fact"),
        ({"goal": '["Boil block"]'}, "goal", "unknown goal predicate 'Boil'"),
        ({"goal": '["On block shelf"]'}, "goal", "unknown surface 'shelf'"),
        ({"goal": '["On box counter"]'}, "goal", "no object 'box'"),
        ({"goal": '["Closed counter"]'}, "goal", "unknown drawer 'counter'"),
        (
            {
                "objects": '{ block = { kind = "block", on = "counter" }, '
                'box = { kind = "cracker_box", on = "counter" } }',
                "prior": '{ block = ["counter"], box = ["counter"] }',
                "goal": '["On box top_drawer"]',
            },
            "goal",
            "no plan can satisfy it",
        ),
        ({"goal": '["On block counter", "On block stove"]'}, "goal", "cannot be on counter too"),
        (
            {"objects": '{ block = { kind = "brick", on = "counter" } }'},
            "objects.block.kind",
            "unknown kind 'brick'; did you mean 'block'",
        ),
        (
            {"objects": '{ block = { kind = "block", on = "counterr" } }'},
            "objects.block.on",
            "did you mean 'counter'",
        ),
        (
            {"objects": '{ block = { kind = "block", onn = "counter" } }'},
            "objects.block.onn",
            "did you mean 'on'",
        ),
        (
            {"objects": '{ block = { kind = "block", on = "counter", size = [1, 2] } }'},
            "objects.block.size",
            "expected [x, y, z]",
        ),
        (
            {"objects": '{ block = { kind = "block", on = "stove", size = [0.5, 0.5, 0.1] } }'},
            "objects.block.on",
            "does not fit on stove",
        ),
        ({"prior": "{ block = { counter = -1 } }"}, "prior.block.counter", "expected a weight > 0"),
        ({"prior": '{ blok = ["counter"] }'}, "prior.blok", "did you mean 'block'"),
        ({"prior": "{}"}, "prior", "no prior for block"),
        ({"drawers": '{ top_drawer = "ajar" }'}, "drawers.top_drawer", 'expected "open"'),
        ({"hide": '{ target = "block", by = ["block"] }'}, "hide.by", "cannot hide itself"),
        (
            {
                "objects": '{ block = { kind = "block", on = "counter" }, '
                'box = { kind = "cracker_box", on = "counter" } }',
                "prior": '{ block = ["counter"], box = ["counter"] }',
                "hide": '{ target = "block", by = ["box"], reachable = "yes" }',
            },
            "hide.reachable",
            "expected true or false",
        ),
    ],
)
def test_bad_task_files_are_bad_input_naming_file_and_key(tmp_path, capsys, keys, key, said):
    path = _file(tmp_path, **keys)
    with pytest.raises(SSRError) as e:
        load_task_file(path)
    assert e.value.file == str(path) and e.value.message.startswith(f"{key}: ")
    assert said in e.value.message
    assert main(["run", str(path), "--seed", "0"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and said in err and "Traceback" not in err


def test_objects_that_cannot_be_placed_are_bad_input(tmp_path, capsys):
    boxes = ", ".join(f'b{i} = {{ kind = "cracker_box", on = "stove" }}' for i in range(6))
    path = _file(
        tmp_path,
        objects=f'{{ block = {{ kind = "block", on = "counter" }}, {boxes} }}',
        prior='{ block = ["counter"], ' + ", ".join(f'b{i} = ["stove"]' for i in range(6)) + " }",
    )
    assert main(["run", str(path), "--seed", "0"]) == 2
    err = capsys.readouterr().err
    assert f"{path}:" in err and "objects.b5.on" in err and "without collision" in err
    # a placement the seed cannot find: bad input too, named, nothing drawn half-way
    path = _file(
        tmp_path,
        objects='{ block = { kind = "block", on = "stove", size = [0.29, 0.15, 0.04] } }',
        prior='{ block = ["stove"] }',
        goal='["On block stove"]',
    )
    out = tmp_path / "scene.png"
    assert main(["render", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "objects.block" in err and "cannot be placed on stove without collision" in err
    assert not out.exists()


def test_experiment_and_pictures_take_task_files(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(GOOD_TEXT.replace("kind", "knd"))
    assert main(["experiment", "--tasks", f"inspect,{path}", "-o", str(tmp_path / "sw")]) == 2
    assert "objects.block.knd" in capsys.readouterr().err
    assert not (tmp_path / "sw" / "episodes.jsonl").exists()
    good = tmp_path / "good.toml"
    good.write_text(GOOD_TEXT)
    out = tmp_path / "b.png"
    assert main(["belief-plot", str(good), "--particles", "20", "-o", str(out)]) == 0
    assert out.read_bytes().startswith(b"\x89PNG")


GOOD_TEXT = "".join(f"{k} = {v}\n" for k, v in GOOD.items())


def test_the_family_generator_writes_valid_task_files(tmp_path, capsys):
    from ssr_compile.sim.task_family import generate

    path = tmp_path / "family.toml"
    for kind in ("cook", "inspect"):
        for n in range(2, 13):
            for k in range(1, min(6, n - 1) + 1):
                path.write_text(generate(kind, n, k))
                spec = load_task_file(path)
                assert len(spec.objects) == n and len(spec.hide[1]) == k
                assert spec.hide[0] == "block" and spec.name == f"{kind}_n{n}_k{k}"
                assert len({o.name for o in spec.objects}) == n
    out = tmp_path / "c.toml"
    assert main(["tasks", "generate", "--objects", "3", "--hiders", "2", "-o", str(out)]) == 0
    assert load_task_file(out).hide == ("block", ("cracker_box", "sugar_box"))
    assert load_task_file(out).hide_reachable  # the family's boxes in front can be moved
    assert not load_task_file(shipped_task_file("cook")).hide_reachable  # the paper's worlds
    assert main(["tasks", "generate", "--objects", "13", "--hiders", "2"]) == 2
    assert "objects must be from 2 to 12" in capsys.readouterr().err
    assert main(["tasks", "generate", "--objects", "3", "--hiders", "3"]) == 2
    assert main(["tasks", "generate", "--objects", "3", "--hiders", "7"]) == 2


@pytest.mark.slow
def test_a_generated_kitchen_hides_the_block_behind_one_of_its_boxes(tmp_path):
    from ssr_compile.sim.perception import visible_fraction
    from ssr_compile.sim.task_family import generate

    path = tmp_path / "c.toml"
    path.write_text(generate("cook", 6, 4))
    hiders = {"cracker_box", "sugar_box", "cracker_box_2", "sugar_box_2"}
    for seed in (0, 1):
        task = make_task(path, seed)
        try:
            state = task.world.true_state()
            assert set(state["objects"]) == hiders | {"block", "block_2"}
            assert all(state["objects"][h]["surface"] == "counter" for h in hiders)
            assert visible_fraction(task.world, "block") <= 0.1
            assert task.goal == (("Cooked", "block"), ("StoveOff",))
        finally:
            task.close()
    a, b = make_task(path, 3), make_task(path, 3)  # seeded
    try:
        assert a.world.true_state() == b.world.true_state()
    finally:
        a.close()
        b.close()


@pytest.mark.slow
def test_the_box_in_front_is_one_the_robot_can_grasp_when_the_file_says_reachable(tmp_path):
    # The family's N = 4, K = 2, seed 9: the sugar box in front of the block, the cracker box
    # placed after it in its way, no grasp of the sugar box reached from any base (the
    # episode proved every optimistic problem unsolvable up to level 12).  With ``reachable``
    # the seed draws another world, whose box in front some grasp reaches.
    from ssr_compile.sim.perception import visible_fraction
    from ssr_compile.sim.task_family import generate
    from ssr_compile.sim.tasks import _clear_to_reach, _reachable

    text = generate("cook", 4, 2)
    assert "reachable = true" in text
    free, stuck = tmp_path / "free.toml", tmp_path / "stuck.toml"
    free.write_text(text)
    stuck.write_text(text.replace("reachable = true", "reachable = false"))
    a, b = make_task(free, 9), make_task(stuck, 9)
    try:
        assert a.world.true_state() != b.world.true_state()

        def front(task):  # the box without which the camera sees the block
            for box in ("cracker_box", "sugar_box"):
                rest = task.world.support[box]
                task.world.remove_object(box)
                seen = visible_fraction(task.world, "block")
                task.world.place_object(box, *rest)
                if seen > 0.1:
                    return box
            raise AssertionError("no box hides the block")

        assert not _reachable(b.world, front(b))
        assert _clear_to_reach(a.world, front(a), "block", moved=True)
        assert visible_fraction(a.world, "block") <= 0.1
    finally:
        a.close()
        b.close()
    # Seed 0: the cracker box in front can be grasped, but the block stands against the sugar
    # box behind it, and neither the block (the cracker box gone) nor the sugar box is reached.
    c = make_task(stuck, 0)
    try:
        assert front(c) == "cracker_box" and _reachable(c.world, "cracker_box")
        assert not _clear_to_reach(c.world, "cracker_box", "block", moved=True)
        assert _clear_to_reach(c.world, "cracker_box", "block", moved=False)
    finally:
        c.close()
