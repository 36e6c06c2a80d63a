"""Physics validity: the world measures its own penetration, and the default physics keeps solids
apart under hard pushing (docs/lab/environment.md, "Physics validity")."""

import logging
import math

import numpy as np
import pytest
import torch

from occrl.envs import DEFAULT_PHYSICS, LEGACY_PHYSICS, PhysicsSettings, Scene, ShelfEnv, ShelfWorld
from occrl.envs import world_constants as C
from occrl.envs.geometry import transform_points
from occrl.envs.pymunk2d.physics_validity import adversarial_pushing, pymunk_world_factory
from occrl.envs.shelf_geometry import gripper_polygons, wall_polygons
from tests.helpers import square

BOUND = 0.002  # m, the design's penetration bound


def _boxes(poses, half=0.02, gripper=(0.0, -0.1, 0.0)) -> Scene:
    return Scene.from_objects(
        [{"vertices": square(half), "pose": p, "is_target": k == 0} for k, p in enumerate(poses)], gripper_pose=gripper
    )


def _mtd(a: np.ndarray, b: np.ndarray) -> float:
    """Penetration depth of two convex polygons: the minimum translation distance (0 if apart)."""
    depth = math.inf
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        normals = np.c_[edges[:, 1], -edges[:, 0]]
        normals = normals[np.linalg.norm(normals, axis=1) > 1e-12]
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        pa, pb = a @ normals.T, b @ normals.T
        overlap = np.minimum(pa.max(0), pb.max(0)) - np.maximum(pa.min(0), pb.min(0))
        depth = min(depth, float(overlap.min()))
    return max(depth, 0.0)


def _geometric_penetration(world: ShelfWorld) -> float:
    """Deepest overlap between objects, gripper and walls from the simulated polygons alone."""
    objects = world.simulated_polygons()
    gripper = [transform_points(p, world.gripper_pose()) for p in gripper_polygons(world.opening)]
    deepest = 0.0
    for i, a in enumerate(objects):
        others = objects[i + 1 :] + wall_polygons() + ([] if world.held == i else gripper)
        deepest = max([deepest] + [_mtd(a, b) for b in others])
    for g in gripper:
        deepest = max([deepest] + [_mtd(g, w) for w in wall_polygons()])
    return deepest


def _push(world: ShelfWorld, action, times: int) -> list[float]:
    depths = []
    for _ in range(times):
        world.step(action)
        depths.append(world.penetration)
        assert not world.crossed_wall
    return depths


@pytest.mark.parametrize("noise", [0.0, 0.25])
def test_a_box_pushed_into_the_back_wall_stays_out_of_it(noise):
    world = ShelfWorld(_boxes([(0.0, 0.25, 0.0)], gripper=(0.0, 0.15, 0.0)), noise=noise, rng=np.random.default_rng(1))
    depths = _push(world, [1.0, 0.0, 0.0, -1.0], 8)
    assert max(depths) <= BOUND
    box = world.simulated_polygons()[0]
    assert box[:, 1].max() <= C.SHELF_DEPTH + BOUND


def test_two_boxes_squeezed_between_the_gripper_and_a_side_wall():
    world = ShelfWorld(_boxes([(0.09, 0.04, 0.0), (0.14, 0.04, 0.3)], gripper=(0.0, 0.05, 0.0)))
    # palm and finger push sideways into the pair, then keep pressing (open, then closed, turning)
    depths = _push(world, [0.0, 1.0, 0.0, -1.0], 8) + _push(world, [0.3, 1.0, -0.5, 1.0], 6)
    assert max(depths) <= BOUND
    assert world.object_poses()[:, 0].max() <= C.SHELF_HALF_WIDTH


def test_a_row_of_objects_pushed_sideways_into_a_side_wall():
    row = [(x, 0.06, 0.0) for x in (-0.05, 0.0, 0.05, 0.10, 0.15)]
    world = ShelfWorld(_boxes(row, half=0.018, gripper=(-0.14, 0.04, 0.0)))
    depths = _push(world, [0.0, 1.0, 0.0, -1.0], 14)
    assert max(depths) <= BOUND
    assert world.object_poses()[:, 0].max() < C.SHELF_HALF_WIDTH


def test_the_measure_reads_the_overlaps_of_the_old_physics():
    """The measure is not blind: occrl 0.1.0's settings overlap in the same squeeze, and the
    depth pymunk reports agrees with the polygons' own minimum translation distance."""
    row = [(x, 0.06, 0.0) for x in (-0.05, 0.0, 0.05, 0.10, 0.15)]
    legacy = ShelfWorld(
        _boxes(row, half=0.018, gripper=(-0.14, 0.04, 0.0)), physics=PhysicsSettings(substeps=10, finger_contact=False, collision_slop=0.1)
    )
    depths = []
    for _ in range(14):
        legacy.step([0.0, 1.0, 0.0, -1.0])
        depths.append(legacy.penetration)
        geometric = _geometric_penetration(legacy)
        if geometric < 0.01:  # deeper, Chipmunk's depth along its contact normal exceeds the minimum
            assert legacy.penetration == pytest.approx(geometric, abs=3e-4)
        else:
            assert legacy.penetration >= geometric - 3e-4
    assert max(depths) > 0.005


def test_the_measure_agrees_with_the_polygons_during_random_pushing():
    world = ShelfWorld(Scene.sample(3, seed=4), noise=0.25, rng=np.random.default_rng(4))
    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(25):
        out = world.step(rng.uniform(0.5, 1.0, 4) * rng.choice([-1.0, 1.0], 4))
        assert world.penetration == pytest.approx(_geometric_penetration(world), abs=3e-4)
        checked += 1
        if out.terminal:
            break
    assert checked >= 10


def test_fingers_open_until_they_touch_a_wall():
    world = ShelfWorld(_boxes([(-0.15, 0.3, 0.0)], gripper=(0.0, 0.1, 0.0)))
    world.step([0.0, 0.0, 0.0, 1.0])  # close on nothing
    assert world.opening == 0.0
    for _ in range(6):
        world.step([0.0, 1.0, 0.0, 1.0])  # closed fingers slide into the right wall
    world.step([0.0, 0.0, 0.0, -1.0])  # open next to the wall
    right_face = world.gripper_pose()[0] + world.opening / 2 + C.FINGER_WIDTH
    assert 0.0 < world.opening < C.GRIPPER_STROKE
    assert right_face <= C.SHELF_HALF_WIDTH + BOUND
    assert world.penetration <= BOUND
    for _ in range(3):
        world.step([0.0, -1.0, 0.0, -1.0])  # away from the wall the fingers open fully
    assert world.opening == C.GRIPPER_STROKE


def test_a_grasped_object_is_drawn_to_the_centre_between_the_fingers():
    world = ShelfWorld(_boxes([(0.0, 0.05, 0.0)], gripper=(0.012, 0.015, 0.0)))
    world.step([0.0, 0.0, 0.0, 1.0])
    assert world.held == 0
    assert world.object_poses()[0, 0] == pytest.approx(world.gripper_pose()[0], abs=1e-3)
    assert world.penetration <= BOUND


def test_legacy_physics_is_the_old_world():
    """LEGACY_PHYSICS reproduces occrl 0.1.0 (the figures made before the change): a recorded
    pose of its random pushing."""
    world = ShelfWorld(Scene.sample(2, seed=0), physics=LEGACY_PHYSICS)
    rng = np.random.default_rng(0)
    for _ in range(10):
        world.step(rng.uniform(-1, 1, 4))
    assert math.isnan(world.penetration) and world.physically_valid()
    assert world.gripper_pose().round(6).tolist() == LEGACY_GRIPPER_POSE


# ShelfWorld(Scene.sample(2, seed=0)) after 10 random actions, recorded on occrl 0.1.0 (c42be67)
LEGACY_GRIPPER_POSE = [-0.020628, -0.018226, 0.68115]


def test_bad_settings_are_refused():
    for kwargs, match in [
        (dict(substeps=0), "substeps"),
        (dict(contact_substeps=1.5), "contact_substeps"),
        (dict(collision_slop=-1.0), "collision_slop"),
        (dict(collision_bias=1.0), "collision_bias"),
        (dict(gripper_mass=0.0), "gripper_mass"),
        (dict(grasp_max_force=-1.0), "grasp_max_force"),
    ]:
        with pytest.raises(ValueError, match=match):
            PhysicsSettings(**kwargs)
    with pytest.raises(TypeError, match="PhysicsSettings"):
        ShelfWorld(Scene.sample(1, seed=0), physics={"substeps": 40})
    with pytest.raises(TypeError, match="PhysicsSettings"):
        ShelfEnv(stage=1, physics="legacy")


def test_env_reports_penetration_and_flags_an_invalid_episode(caplog):
    row = [(x, 0.06, 0.0) for x in (-0.05, 0.0, 0.05, 0.10, 0.15)]
    squeeze = _boxes(row, half=0.018, gripper=(-0.14, 0.04, 0.0))
    push = torch.tensor([[0.0, 1.0, 0.0, -1.0]])
    old = PhysicsSettings(substeps=10, finger_contact=False, collision_slop=0.1)
    for physics, invalid in ((DEFAULT_PHYSICS, False), (old, True)):
        env = ShelfEnv(scenes=[squeeze], physics=physics)
        td = env.reset()
        assert td["privileged", "penetration"].item() == 0.0
        flags, depths = [], []
        with caplog.at_level(logging.WARNING, logger="occrl.envs.shelf_env"):
            caplog.clear()
            for _ in range(14):
                td = env.step(td.set("action", push))["next"]
                flags.append(bool(td["privileged", "physics_invalid"].item()))
                depths.append(td["privileged", "penetration"].item())
        assert any(flags) == invalid
        if invalid:  # flagged from the first invalid state on, for the rest of the episode, warned once
            first = flags.index(True)
            assert all(flags[first:]) and depths[first] > 0.005
            assert len([r for r in caplog.records if "physically invalid" in r.message]) == 1
        td = env.reset()
        assert not td["privileged", "physics_invalid"].item()


@pytest.mark.slow
def test_adversarial_pushing_stays_within_the_bound():
    """The design's goal: penetration <= 2 mm in >= 99.9 % of >= 5,000 states of full-speed random
    pushing on stages 2 and 3 at noise 0 and 0.25, and no object through a wall."""
    reports = [adversarial_pushing(pymunk_world_factory(), stage, noise, 1250, seed=7) for stage in (2, 3) for noise in (0.0, 0.25)]
    depths = np.concatenate([r.penetration for r in reports])
    assert len(depths) == 5000
    assert np.mean(depths <= BOUND) >= 0.999, f"{np.sum(depths > BOUND)} states deeper than 2 mm, worst {depths.max():.4f} m"
    assert sum(r.crossings for r in reports) == 0
