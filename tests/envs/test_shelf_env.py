import numpy as np
import pytest
import torch
from tensordict import TensorDict
from torchrl.envs.utils import check_env_specs

from occrl.baselines import ScriptedRetriever
from occrl.envs import Scene, ShelfEnv, make_env
from occrl.envs import world_constants as C
from occrl.envs.episodes import run_episodes, task_scenes
from tests.helpers import scene


def test_check_env_specs_on_bare_env_and_pipeline():
    check_env_specs(ShelfEnv(batch_size=3, stage=2, seed=0))
    check_env_specs(make_env(batch_size=2, stage=1, seed=0))


def _random_policy(seed):
    g = torch.Generator().manual_seed(seed)

    def policy(td):
        td["action"] = torch.rand(td.shape + (4,), generator=g) * 2 - 1
        return td

    return policy


def test_same_seed_same_episode():
    a = make_env(batch_size=2, stage=2, seed=7).rollout(8, _random_policy(1), break_when_any_done=False)
    b = make_env(batch_size=2, stage=2, seed=7).rollout(8, _random_policy(1), break_when_any_done=False)
    c = make_env(batch_size=2, stage=2, seed=8).rollout(8, _random_policy(1), break_when_any_done=False)
    assert (a == b).all()
    assert not torch.equal(a["privileged", "object_pose"], c["privileged", "object_pose"])


def test_push_off_the_front_edge_ends_the_episode_with_minus_51():
    # gripper turned to point right; its side sweeps towards -y and pushes the box off the edge
    s = scene([(0.17, 0.022, 0.0, False), (-0.15, 0.3, 0.0, True)], gripper=(0.2, 0.08, -np.pi / 2), half=0.012)
    env = ShelfEnv(batch_size=1, scenes=[s])
    env.reset()
    td = env.rollout(5, policy=lambda tensordict: tensordict.set("action", torch.tensor([[0.0, 1.0, 0.0, -1.0]])))
    assert td["next", "dropped"][0, -1].item() and td["next", "terminated"][0, -1].item()
    assert td["next", "reward"][0, -1].item() == -51.0
    assert (td["next", "reward"][0, :-1] == -1.0).all()
    assert not td["next", "success"].any()


def test_retrieval_ends_with_success():
    s = scene([(0.0, 0.15, 0.0, True)])
    td = ShelfEnv(batch_size=1, scenes=[s]).rollout(C.MAX_EPISODE_STEPS, policy=ScriptedRetriever())
    assert td["next", "success"][0, -1].item() and td["next", "terminated"][0, -1].item()
    assert not td["next", "truncated"].any()
    assert (td["next", "reward"] == -1.0).all()


def test_truncation_after_max_steps():
    env = ShelfEnv(batch_size=2, stage=1, seed=0, max_steps=4)
    td = env.rollout(4, policy=lambda tensordict: tensordict.set("action", torch.zeros(2, 4)))
    assert td["next", "truncated"][:, -1].all() and not td["next", "terminated"].any()
    assert not td["next", "truncated"][:, :-1].any()


def test_nan_action_raises_and_no_world_moves():
    env = ShelfEnv(batch_size=3, stage=2, seed=0)
    td = env.reset()
    before = [w.snapshot() for w in env.worlds]
    td["action"] = torch.zeros(3, 4)
    td["action"][1, 2] = float("nan")
    with pytest.raises(ValueError, match=r"world\(s\) \[1\].*NaN or inf"):
        env.step(td)
    for w, s in zip(env.worlds, before):
        assert np.array_equal(w.object_poses(), s["object_poses"]) and np.array_equal(w.gripper_pose(), s["gripper_pose"])


def test_partial_reset_only_resets_the_masked_worlds():
    env = ShelfEnv(batch_size=2, stage=2, seed=3)
    env.rollout(3, policy=lambda tensordict: tensordict.set("action", torch.tensor([[1.0, 0, 0, -1]] * 2)))
    kept = env.worlds[1].gripper_pose().copy()
    old_scene = env.worlds[1].scene
    old_first = env.worlds[0].scene
    env.reset(TensorDict({"_reset": torch.tensor([[True], [False]])}, batch_size=[2]))
    assert env.worlds[1].scene is old_scene and np.array_equal(env.worlds[1].gripper_pose(), kept)
    assert env.worlds[0].scene is not old_first


def test_partial_step_only_steps_the_masked_worlds():
    env = ShelfEnv(batch_size=2, stage=2, seed=3)
    td = env.reset()
    kept = env.worlds[1].gripper_pose().copy()
    td["action"] = torch.tensor([[1.0, 0, 0, -1]] * 2)
    td["_step"] = torch.tensor([[True], [False]])
    env.step(td)
    assert np.array_equal(env.worlds[1].gripper_pose(), kept)
    assert env.worlds[0].gripper_pose()[1] > -0.1  # the stepped world moved in
    assert list(env._steps) == [1, 0]


def test_episodes_stop_when_every_world_has_ended():
    # a batch of one is not stepped, nor its policy asked, after its episode ends
    calls = []
    policy = ScriptedRetriever()
    policy.register_forward_hook(lambda *a: calls.append(1))
    [result] = run_episodes(policy, [scene([(0.0, 0.15, 0.0, True)])], seeds=[0])
    assert result.success and len(calls) == result.actions < 20
    # in a batch, a world that ended keeps its outcome while the others go on
    seeds = [0, 1, 2]
    results = run_episodes(ScriptedRetriever(), task_scenes(1, seeds), seeds, batch_size=3)
    alone = [run_episodes(ScriptedRetriever(), task_scenes(1, [s]), [s])[0] for s in seeds]
    assert [(r.success, r.actions) for r in results] == [(r.success, r.actions) for r in alone]


def test_scenes_are_used_in_turn():
    scenes = [Scene.sample(1, seed=s) for s in range(3)]
    env = ShelfEnv(batch_size=1, scenes=scenes)
    for k in range(4):
        env.reset()
        assert env.worlds[0].scene is scenes[k % 3]


def test_scene_pool_draws_by_each_worlds_seed():
    pool = [Scene.sample(2, seed=s) for s in range(5)]

    def starts(seed, share, resets=6):
        env = ShelfEnv(batch_size=3, stage=1, seed=seed, scene_pool=pool, scene_pool_share=share)
        out = []
        for _ in range(resets):
            env.reset()
            out.append([next((k for k, p in enumerate(pool) if w.scene is p), None) for w in env.worlds])
        return out

    every = starts(0, 1.0)
    assert all(k is not None for row in every for k in row)  # share 1: always from the pool
    assert len({k for row in every for k in row}) > 1  # drawn, not one scene
    assert starts(0, 1.0) == every  # a seed fixes the draws
    mixed = [k for row in starts(1, 0.5, resets=12) for k in row]
    from_pool = sum(k is not None for k in mixed)
    assert 0 < from_pool < len(mixed)  # share 0.5: some from the pool, some sampled stage-1 scenes
    # the scenes not from the pool are the stage's own sampled tasks
    env = ShelfEnv(batch_size=1, stage=1, seed=3, scene_pool=pool, scene_pool_share=0.01)
    env.reset()
    assert all(env.worlds[0].scene is not p for p in pool) and 1 <= len(env.worlds[0].scene) <= 4


def test_each_world_draws_its_scenes_from_its_own_stream_of_the_seed():
    """World k's scenes come from the k-th stream spawned from the seed (or from its own seed in a list)."""
    single = ShelfEnv(batch_size=2, stage=2, seed=4)
    single.reset()
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(4).spawn(2)]
    assert [repr(w.scene) for w in single.worlds] == [repr(Scene.sample(2, seed=rng)) for rng in streams]
    listed = ShelfEnv(batch_size=2, stage=2, seed=[7, 9])
    listed.reset()
    assert [repr(w.scene) for w in listed.worlds] == [repr(Scene.sample(2, seed=np.random.default_rng(s))) for s in (7, 9)]


def test_undetected_slots_reveal_nothing():
    s = scene([(0.0, 0.1, 0.0, False), (0.0, 0.28, 0.0, True)])  # the target is hidden behind the box
    td = ShelfEnv(batch_size=1, scenes=[s]).reset()
    det = td["objects", "detected"][0]
    assert det.tolist()[:2] == [True, False]
    for key in ("type_id", "pose", "vertices", "num_vertices"):
        assert (td["objects", key][0, ~det] == 0).all()
    assert td["privileged", "visible_fraction"][0, 1] == 0.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(stage=4), "stage must be one of"),
        (dict(noise=-0.1), "noise must be in"),
        (dict(batch_size=0), "batch_size"),
        (dict(scenes=["not a scene"]), "scenes must be"),
        (dict(scene_pool=[]), "scene_pool must be a non-empty"),
        (dict(scene_pool=[Scene.sample(1, seed=0)], scene_pool_share=0.0), "scene_pool_share must be a probability"),
        (dict(scene_pool=[Scene.sample(1, seed=0)], scene_pool_share=1.5), "scene_pool_share must be a probability"),
        (dict(scenes=[Scene.sample(1, seed=0)], scene_pool=[Scene.sample(1, seed=1)]), "not both"),
    ],
)
def test_bad_env_arguments(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ShelfEnv(**kwargs)
