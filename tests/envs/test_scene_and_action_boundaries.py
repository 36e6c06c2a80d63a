"""Property-based boundaries (hypothesis): scenes and actions. Valid random input never raises;
malformed input always raises ValueError/TypeError with a message, never a crash or a silent
acceptance."""

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from occrl.envs import Scene, ShelfEnv


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 3), st.integers(0, 2**31 - 1))
def test_every_sampled_scene_passes_through_from_objects(stage, seed):
    scene = Scene.sample(stage, seed=seed)
    again = Scene.from_objects(scene.to_objects(), gripper_pose=scene.gripper_pose)
    assert len(again) == len(scene) and again.target_index == scene.target_index


def _box(x, y, half=0.02):
    return {"vertices": [[-half, -half], [half, -half], [half, half], [-half, half]], "pose": (x, y, 0.0), "is_target": False}


SCENE_CORRUPTIONS = [
    (lambda objs: objs[0].update(pose=(0.0, math.nan, 0.0)), "pose"),
    (lambda objs: objs[0].update(pose=(0.0, 0.1)), "pose"),
    (lambda objs: objs[0].update(vertices=[[0, 0], [0.02, 0]]), "polygon needs"),
    (lambda objs: objs[0].update(vertices=[[0, 0], [0.04, 0], [0.02, 0.005], [0.04, 0.04], [0, 0.04]]), "convex"),
    (lambda objs: objs[0].update(vertices="square"), "vertices"),
    (lambda objs: objs[0].pop("pose"), "missing key"),
    (lambda objs: objs[0].update(type_id=1.5), "type_id"),
    (lambda objs: objs[0].update(is_target="yes"), "is_target"),
    (lambda objs: objs[0].update(is_target=False), "exactly one target"),
    (lambda objs: objs[1].update(is_target=True), "exactly one target"),
    (lambda objs: objs[1].update(pose=objs[0]["pose"]), "overlap"),
    (lambda objs: objs[0].update(pose=(0.4, 0.2, 0.0)), "outside the shelf"),
    (lambda objs: objs.extend(_box(-0.2 + 0.045 * k, 0.3) for k in range(9)), "at most"),
]


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.15, 0.15), st.floats(0.05, 0.12), st.sampled_from(SCENE_CORRUPTIONS))
def test_malformed_scenes_are_refused_with_a_message(x, y, corruption):
    objs = [dict(_box(x, y), is_target=True), _box(x, y + 0.15)]
    Scene.from_objects([dict(o) for o in objs])  # the uncorrupted scene is valid
    corrupt, words = corruption
    corrupt(objs)
    with pytest.raises((ValueError, TypeError)) as info:
        Scene.from_objects(objs)
    assert words in str(info.value)


@pytest.mark.integration
@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=8, max_size=8), st.sampled_from([torch.float32, torch.float64, torch.int64])
)
def test_any_finite_action_is_clipped_and_stepped(values, dtype):
    env = ShelfEnv(batch_size=2, stage=1, seed=0)
    td = env.reset()
    action = torch.tensor(values).reshape(2, 4).to(dtype)
    out = env.step(td.set("action", action))["next"]
    assert out["reward"].shape == (2, 1) and torch.isfinite(out["gripper_pose"]).all()
    clipped = ShelfEnv(batch_size=2, stage=1, seed=0)
    ref = clipped.step(clipped.reset().set("action", action.double().clamp(-1, 1).float()))["next"]
    assert torch.equal(out["gripper_pose"], ref["gripper_pose"])  # out-of-range entries act as +-1


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(["nan", "inf", "shape", "short"]), st.integers(0, 1))
def test_malformed_actions_are_refused_and_leave_the_worlds_unchanged(kind, world):
    env = ShelfEnv(batch_size=2, stage=1, seed=0)
    td = env.reset()
    before = [w.snapshot()["object_poses"].copy() for w in env.worlds]
    gripper = [w.gripper_pose().copy() for w in env.worlds]
    action = torch.zeros(2, 4)
    if kind == "nan":
        action[world, world] = math.nan
    elif kind == "inf":
        action[world, 3] = -math.inf
    elif kind == "shape":
        action = torch.zeros(2, 5)
    else:
        action = torch.zeros(2, 3)
    with pytest.raises((ValueError, RuntimeError)) as info:
        env.step(td.set("action", action))
    assert "action" in str(info.value)
    for w, poses, g in zip(env.worlds, before, gripper):
        assert np.array_equal(w.object_poses(), poses) and np.array_equal(w.gripper_pose(), g)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(num_objects=0), "num_objects"),
        (dict(num_objects=11), "num_objects"),
        (dict(max_steps=0), "max_steps"),
        (dict(seed=-1), "seed"),
        (dict(seed=1.5), "seed"),
        (dict(batch_size=2, seed=[1, None]), "seed"),
        (dict(stage=4), "stage"),
        (dict(noise=-0.1), "noise"),
        (dict(batch_size=0), "batch_size"),
    ],
)
def test_env_arguments_are_range_checked_at_construction(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ShelfEnv(**kwargs)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(window=0.0), "window"),
        (dict(size=4), "size"),
        (dict(forward_offset=math.inf), "forward_offset"),
        (dict(world="box2d"), "world"),
    ],
)
def test_make_env_arguments_are_range_checked(kwargs, match):
    from occrl.envs import make_env

    with pytest.raises(ValueError, match=match):
        make_env(**kwargs)
