"""Task object-count ranges, the MuJoCo execution world and --objects parsing in occrl eval."""

import pytest

from occrl.cli import main
from occrl.envs.episodes import task_object_count, task_scenes
from occrl.eval.runner import EVAL_SEED_BASE, run_tasks
from occrl.eval.sweep import noise_sweep_objects

SEEDS = list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + 40))


def test_object_count_ranges_are_drawn_per_task_seed():
    scenes = task_scenes(2, SEEDS, (1, 10))
    counts = [len(s) for s in scenes]
    assert counts == [task_object_count(s, 1, 10) for s in SEEDS]
    assert counts == [noise_sweep_objects(s) for s in SEEDS]  # the noise sweep's tasks
    assert min(counts) >= 1 and max(counts) <= 10 and len(set(counts)) > 3
    with pytest.raises(ValueError, match="low <= high"):
        task_scenes(2, SEEDS[:1], (5, 2))


@pytest.mark.parametrize("bad", ["0", "0-3", "7-2", "many"])
def test_bad_object_counts_are_refused(bad, capsys):
    assert main(["eval", "--method", "scripted", "--objects", bad, "--tasks", "1", "--no-progress"]) == 2
    assert "--objects must be" in capsys.readouterr().err


def test_scripted_retrieves_a_lone_target_in_the_mujoco_world():
    pytest.importorskip("dm_control")
    [result] = run_tasks("scripted", 2, SEEDS[:1], num_objects=1, progress=False, world="mujoco")
    assert result.objects == 1 and result.success and not result.dropped


def test_mujoco_frames_show_the_gripper_camera():
    pytest.importorskip("dm_control")
    from occrl.envs import make_env
    from occrl.envs.mujoco3d.camera import gl_available
    from occrl.eval.film import frame

    if not gl_available()[0]:
        pytest.skip("no OpenGL backend for MuJoCo camera images")
    plain = make_env(batch_size=1, stage=1, seed=0, heatmap_target=False).reset()[0]
    td = make_env(batch_size=1, stage=1, seed=0, heatmap_target=False, world="mujoco", record_camera=True).reset()[0]
    assert td["camera_rgb"].shape[0] == 3 and int(td["camera_rgb"].max()) > 0
    assert frame(td).shape[1] > frame(plain).shape[1] + 200  # a third panel: the camera image


@pytest.mark.integration
def test_replicate_0_is_what_the_recorded_results_ran():
    import json
    from pathlib import Path

    recorded = json.loads(
        (Path(__file__).resolve().parents[2] / "results/retrieval-takeover/stochastic-gen_s2_iteration75.json").read_text()
    )
    assert recorded["network"].endswith("weights_iteration75.pt")  # occnet-takeover's file, shipped under that name
    seeds = SEEDS[:8]
    from occrl.pretrained import pretrained_path

    weights = pretrained_path("occnet-takeover")
    again = run_tasks("stochastic-gen", 2, seeds, batch=8, weights=weights, progress=False, replicate=0)
    assert [(r.seed, r.success, r.actions) for r in again] == [(e["seed"], e["success"], e["actions"]) for e in recorded["episodes"][:8]]


@pytest.mark.integration
def test_a_replicate_draws_the_decision_makers_randomness_anew_on_the_same_tasks():
    seeds = SEEDS[:6]
    default = run_tasks("stochastic", 2, seeds, batch=6, progress=False)
    first = run_tasks("stochastic", 2, seeds, batch=6, progress=False, replicate=1)
    again = run_tasks("stochastic", 2, seeds, batch=6, progress=False, replicate=1)
    assert [(r.seed, r.objects) for r in first] == [(r.seed, r.objects) for r in default]  # the same shelves
    assert [(r.success, r.actions) for r in first] == [(r.success, r.actions) for r in again]  # a replicate is reproducible
    assert [(r.success, r.actions) for r in first] != [(r.success, r.actions) for r in default]  # with other policy samples
    # a deterministic decision maker does the same on every replicate: the execution noise is the task's
    greedy = [run_tasks("greedy", 2, seeds[:3], noise=0.1, batch=3, progress=False, replicate=r) for r in (0, 3)]
    assert [(r.success, r.actions) for r in greedy[0]] == [(r.success, r.actions) for r in greedy[1]]
    with pytest.raises(ValueError, match="replicate must be an integer >= 0"):
        run_tasks("stochastic", 2, seeds, progress=False, replicate=-2)


def test_eval_records_the_replicate_and_refuses_it_for_a_sweep(tmp_path, capsys):
    import json

    out = tmp_path / "r.json"
    assert (
        main(["eval", "--method", "scripted", "--stage", "1", "--tasks", "2", "--replicate", "2", "--out", str(out), "--no-progress"]) == 0
    )
    assert json.loads(out.read_text())["replicate"] == 2 and "replicate 2" in capsys.readouterr().out
    assert main(["eval", "--method", "scripted", "--tasks", "1", "--out", str(out), "--no-progress"]) == 0
    assert "replicate" not in json.loads(out.read_text())  # replicate 0: the files as before
    assert main(["eval", "--sweep", "--replicate", "1", "--tasks", "1", "--no-progress"]) == 2
    assert "--replicate applies to a single method" in capsys.readouterr().err
