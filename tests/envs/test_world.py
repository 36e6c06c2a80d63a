import numpy as np
import pytest

from occrl.envs import Scene, ShelfWorld
from occrl.envs import world_constants as C
from tests.helpers import scene


def _random_actions(seed, n):
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, (n, 4))
    a[:, 0] = np.abs(a[:, 0])  # mostly into the shelf, where the contacts are
    return a


@pytest.mark.parametrize("noise", [0.0, 0.15])
def test_snapshot_restore_is_bit_exact(noise):
    for seed in range(3):
        s = Scene.sample(2, seed=seed)
        world = ShelfWorld(s, noise=noise, rng=np.random.default_rng(seed))
        for a in _random_actions(seed, 4):
            world.step(a)
        snap = world.snapshot()
        actions = _random_actions(seed + 100, 6)
        for a in actions:
            world.step(a)
        first = (world.object_poses(), world.gripper_pose(), world.opening, world.held)
        world.restore(snap)
        for a in actions:
            world.step(a)
        assert np.array_equal(world.object_poses(), first[0])
        assert np.array_equal(world.gripper_pose(), first[1])
        assert (world.opening, world.held) == first[2:]
        # a fresh world restored to the snapshot continues identically too
        other = ShelfWorld(s, noise=noise, rng=np.random.default_rng(999))
        other.restore(snap)
        for a in actions:
            other.step(a)
        assert np.array_equal(other.object_poses(), first[0])


def test_nan_action_raises_and_leaves_the_world_unchanged():
    world = ShelfWorld(Scene.sample(1, seed=0))
    before = world.snapshot()
    for bad in ([np.nan, 0, 0, 0], [0, np.inf, 0, 0], [0, 0, 0]):
        with pytest.raises(ValueError, match="NaN or inf|4 entries"):
            world.step(bad)
    after = world.snapshot()
    assert np.array_equal(before["object_poses"], after["object_poses"])
    assert np.array_equal(before["gripper_pose"], after["gripper_pose"])


def test_out_of_range_actions_are_clipped():
    a, b = ShelfWorld(Scene.sample(1, seed=1)), ShelfWorld(Scene.sample(1, seed=1))
    a.step([3.0, -7.0, 2.0, -5.0])
    b.step([1.0, -1.0, 1.0, -1.0])
    assert np.array_equal(a.gripper_pose(), b.gripper_pose())


def test_free_motion_matches_the_action_scale():
    world = ShelfWorld(scene([(0.2, 0.3, 0.0, True)], gripper=(-0.1, -0.2, 0.0)))
    world.step([1.0, 0.0, 0.0, -1.0])
    x, y, th = world.gripper_pose()
    assert y - (-0.2) == pytest.approx(C.MAX_FORWARD, abs=2e-3)
    world.step([0.0, 1.0, 1.0, -1.0])
    x2, _, th2 = world.gripper_pose()
    assert x2 - x == pytest.approx(C.MAX_LATERAL, abs=3e-3)
    assert th2 - th == pytest.approx(C.MAX_ROTATION, abs=0.02)


def test_walls_stop_the_gripper():
    world = ShelfWorld(scene([(-0.15, 0.3, 0.0, True)], gripper=(0.15, 0.1, 0.0)))
    for _ in range(6):
        world.step([0.0, 1.0, 0.0, -1.0])  # slide right into the side wall
    right_edge = world.gripper_pose()[0] + C.GRIPPER_STROKE / 2 + C.FINGER_WIDTH
    assert right_edge <= C.SHELF_HALF_WIDTH + 0.005


def test_grasp_holds_the_object_between_the_fingers_and_release_lets_go():
    world = ShelfWorld(scene([(0.0, 0.05, 0.0, True)], gripper=(0.005, 0.015, 0.0)))
    world.step([0.0, 0.0, 0.0, 1.0])
    assert world.held == 0 and world.opening == pytest.approx(0.04)
    assert world.object_poses()[0, 0] == pytest.approx(world.gripper_pose()[0], abs=1e-4)  # centred by the fingers
    for _ in range(3):
        out = world.step([-1.0, 0.0, 0.0, 1.0])
    assert out.retrieved
    world.step([0.0, 0.0, 0.0, -1.0])
    assert world.held is None and world.opening == C.GRIPPER_STROKE


def test_closing_on_two_objects_grasps_neither():
    s = Scene.from_objects(
        [
            {"vertices": [[-0.012, -0.02], [0.012, -0.02], [0.012, 0.02], [-0.012, 0.02]], "pose": (-0.015, 0.05, 0.0), "is_target": True},
            {"vertices": [[-0.012, -0.02], [0.012, -0.02], [0.012, 0.02], [-0.012, 0.02]], "pose": (0.015, 0.05, 0.0), "is_target": False},
        ],
        gripper_pose=(0.0, 0.015, 0.0),
    )
    world = ShelfWorld(s)
    world.step([0.0, 0.0, 0.0, 1.0])
    assert world.held is None and world.closed


def test_pulling_a_clutter_object_out_counts_as_a_drop():
    world = ShelfWorld(scene([(0.0, 0.05, 0.0, False), (0.15, 0.3, 0.0, True)], gripper=(0.0, 0.015, 0.0)))
    world.step([0.0, 0.0, 0.0, 1.0])
    assert world.held == 0
    dropped = ()
    for _ in range(3):
        out = world.step([-1.0, 0.0, 0.0, 1.0])
        dropped = dropped or out.dropped
    assert dropped == (0,) and not out.retrieved
