"""``occrl demo``: cluttered shelves whose target starts hidden, a short table, a titled GIF."""

import json

import pytest
from PIL import Image

from occrl.cli import main, make_parser
from occrl.cli.demo import DEMO_FIRST_SEED, demo_seeds
from occrl.envs import Scene, make_env
from occrl.planners import recreate
from occrl.pretrained import load_pretrained

# whole episodes and env resets: 3-10 s each on a 2-core machine (demo_seeds' doctest is the fast check)
pytestmark = pytest.mark.integration


def first_observation_shows_the_target(stage: int, seed: int) -> bool:
    """Whether the demo's env (the shipped network's image size) detects the target at the start."""
    size = load_pretrained("occnet").config.image_size
    env = make_env(batch_size=1, scenes=[Scene.sample(stage, seed=seed)], heatmap_target=False, size=size)
    return recreate(env.reset()[0]).target_detected


def test_the_default_demo_shelves_are_cluttered_and_hide_the_target():
    args = make_parser().parse_args(["demo"])
    assert args.seed is None  # no --seed: the first hidden-target shelves from DEMO_FIRST_SEED on
    seeds = demo_seeds(args.stage, args.tasks, DEMO_FIRST_SEED)
    assert len(seeds) == args.tasks == 3 and seeds[0] >= DEMO_FIRST_SEED
    for seed in seeds:
        assert len(Scene.sample(args.stage, seed=seed)) >= 5
        assert not first_observation_shows_the_target(args.stage, seed)
    skipped = sorted(set(range(DEMO_FIRST_SEED, seeds[-1])) - set(seeds))
    assert skipped and all(first_observation_shows_the_target(args.stage, seed) for seed in skipped)  # the check can fail


def test_the_default_demo_plays_a_shelf_and_prints_a_short_table(tmp_path, capsys):
    assert main(["demo", "--tasks", "1", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "occrl demo: the hybrid planner 4x4 with the shipped network occnet (occnet-selfimit), in the 2D pymunk world"
    assert lines[1] == "1 stage-2 shelf whose target starts hidden (task seed 2024)"
    assert lines[3].split() == ["task", "seed", "objects", "result", "actions", "seconds"]
    task, seed, objects, result, actions, _ = lines[4].split()
    summary = json.loads((tmp_path / "demo_summary.json").read_text())
    [row] = summary["tasks"]
    assert (int(task), int(seed), int(objects), result, int(actions)) == (1, 2024, row["objects"], row["result"], row["actions"])
    assert row["objects"] >= 5 and summary["target_hidden_at_start"]
    assert any(line.startswith(f"GIF:     {tmp_path / 'demo.gif'} ({row['actions'] + 1} frames") for line in lines)
    gif = Image.open(tmp_path / "demo.gif")
    assert gif.n_frames == row["actions"] + 1 and gif.size == (518, 320)  # a caption and panel titles above the panels


def test_a_given_seed_plays_that_shelf(tmp_path, capsys):
    assert first_observation_shows_the_target(2, 8)  # not a default shelf, played all the same when asked for
    assert main(["demo", "--method", "scripted", "--tasks", "1", "--seed", "8", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.splitlines()[1] == "1 stage-2 shelf as given (task seed 8)"
    summary = json.loads((tmp_path / "demo_summary.json").read_text())
    assert [row["seed"] for row in summary["tasks"]] == [8] and not summary["target_hidden_at_start"]
