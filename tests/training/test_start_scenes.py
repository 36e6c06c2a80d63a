import pytest
import torch

from occrl.baselines import NetPolicy
from occrl.envs import Scene, ShelfWorld, make_env
from occrl.envs.episodes import task_scenes
from occrl.envs.scene_files import load_scenes, save_scenes
from occrl.modules import make_occnet
from occrl.planners import recreate
from occrl.training import Trainer, get_train_config
from occrl.training.collection import training_env
from occrl.training.start_scenes import collect_handover_scenes, hidden_target_scenes, scene_of_world


def _target_seen_at_start(scene: Scene) -> bool:
    return recreate(make_env(batch_size=1, scenes=[scene], heatmap_target=False).reset()[0]).target_detected


def test_hidden_target_scenes_are_the_tasks_whose_first_observation_lacks_the_target():
    seeds = list(range(30))
    hidden = hidden_target_scenes(2, seeds, batch=7)
    all_tasks = task_scenes(2, seeds)
    expected = [s.seed for s in all_tasks if not _target_seen_at_start(s)]
    assert [s.seed for s in hidden] == expected and 0 < len(expected) < len(seeds)


def test_a_handover_scene_starts_where_the_search_saw_the_target():
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    policy = NetPolicy(net, stochastic=True)
    seeds = list(range(100, 124))
    scenes, counts = collect_handover_scenes(policy, 2, seeds, primers=[net.make_primer()], batch=8)
    assert counts["tasks"] == 24 and counts["kept"] == len(scenes)
    assert counts["handed_over"] == counts["kept"] + sum(counts["dropped"].values())
    assert scenes and {s.meta["task_seed"] for s in scenes} <= set(seeds)
    sight = counts["first_sight"]
    assert set(sight) == set(seeds) and sum(v is not None for v in sight.values()) == counts["handed_over"]
    assert all(sight[s.meta["task_seed"]] == s.meta["step"] for s in scenes)
    for s in scenes:
        # a world built from the scene shows the target in its first observation, as the search did
        assert _target_seen_at_start(s)
        task = task_scenes(2, [s.meta["task_seed"]])[0]
        assert [o.type_id for o in s.objects] == [o.type_id for o in task.objects]
        if s.meta["step"] == 0:  # seen from the start: the task's own scene
            assert s.gripper_pose == task.gripper_pose and [o.pose for o in s.objects] == [o.pose for o in task.objects]


def test_scene_of_world_refuses_states_a_scene_cannot_start_from():
    world = ShelfWorld(Scene.sample(stage=1, seed=0))
    world.step([0.0, 0.0, 0.0, 1.0])  # close the fingers
    with pytest.raises(ValueError, match="closed"):
        scene_of_world(world)


def test_training_env_starts_from_the_pool_at_its_stage_only(tmp_path):
    pool = [Scene.sample(2, seed=s) for s in range(4)]
    path = tmp_path / "pool.json"
    save_scenes(path, pool, meta={"stage": 2})
    net = make_occnet("paper")
    env = training_env(2, 0.0, 4, 0, net, str(path), 1.0)
    env.reset()
    starts = [w.scene for w in env.base_env.worlds]
    saved, _ = load_scenes(path)
    assert all(any([o.pose for o in s.objects] == [o.pose for o in p.objects] for p in saved) for s in starts)
    replay = training_env(1, 0.0, 4, 0, net, str(path), 1.0)  # another stage: its own tasks
    replay.reset()
    assert all(1 <= len(w.scene) <= 4 for w in replay.base_env.worlds)
    assert replay.base_env.scene_pool is None
    nameless = tmp_path / "nameless.json"
    save_scenes(nameless, pool)
    with pytest.raises(ValueError, match="names no 'stage'"):
        training_env(2, 0.0, 4, 0, net, str(nameless), 1.0)


def test_start_scene_settings_are_checked(tmp_path):
    with pytest.raises(ValueError, match="start_scenes names no file"):
        get_train_config("tiny", start_scenes=str(tmp_path / "missing.json")).validate()
    with pytest.raises(ValueError, match="start_scenes_share must be a probability"):
        get_train_config("tiny", start_scenes_share=0.0).validate()


def test_a_run_with_start_scenes_trains_and_resumes_exactly(tmp_path):
    path = tmp_path / "pool.json"
    save_scenes(path, hidden_target_scenes(1, range(200))[:6], meta={"stage": 1})
    cfg = get_train_config("tiny", start_scenes=str(path), start_scenes_share=0.5)
    straight = Trainer(cfg, tmp_path / "a", seed=3, progress=False, tensorboard=False)
    straight.train(iterations=2)
    env = straight.collection.collector.env.base_env
    assert env.scene_pool is not None and len(env.scene_pool) == 6 and env.scene_pool_share == 0.5
    straight.close()
    first = Trainer(cfg, tmp_path / "b", seed=3, progress=False, tensorboard=False)
    first.train(iterations=1)
    first.close()
    resumed = Trainer(cfg, tmp_path / "b", seed=3, progress=False, tensorboard=False)
    resumed.train(iterations=2)
    resumed.close()
    a, b = straight.net.state_dict(), resumed.net.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
