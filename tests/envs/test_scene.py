import math

import numpy as np
import pytest

from occrl.envs import Scene
from occrl.envs import world_constants as C
from occrl.envs.geometry import min_width, polygons_overlap
from occrl.envs.scene import STAGES
from tests.helpers import scene, square


@pytest.mark.parametrize("stage", [1, 2, 3])
def test_sampled_scenes_follow_the_curriculum(stage):
    lo, hi = STAGES[stage]["num_objects"]
    for seed in range(15):
        s = Scene.sample(stage, seed=seed)
        assert lo <= len(s) <= hi
        assert sum(o.is_target for o in s.objects) == 1
        for o in s.objects:
            assert C.MIN_VERTICES <= len(o.vertices) <= C.MAX_VERTICES
            assert min_width(o.vertices) <= C.GRIPPER_STROKE
        if stage == 3:
            assert s.target.pose[1] >= C.SHELF_DEPTH / 2
        polys = [o.world_vertices() for o in s.objects]
        for i in range(len(polys)):
            for j in range(i + 1, len(polys)):
                assert not polygons_overlap(polys[i], polys[j])


def test_same_seed_same_scene_and_different_seed_differs():
    a, b, c = Scene.sample(2, seed=11), Scene.sample(2, seed=11), Scene.sample(2, seed=12)
    assert [o.pose for o in a.objects] == [o.pose for o in b.objects]
    assert all(np.array_equal(x.vertices, y.vertices) for x, y in zip(a.objects, b.objects))
    assert [o.pose for o in a.objects] != [o.pose for o in c.objects]


def test_from_objects_recentres_on_the_centroid():
    # a square whose object frame has its origin at a corner
    s = Scene.from_objects([{"vertices": [[0, 0], [0.04, 0], [0.04, 0.04], [0, 0.04]], "pose": (0.0, 0.1, 0.0), "is_target": True}])
    assert s.target.pose[:2] == pytest.approx((0.02, 0.12))
    assert s.target.vertices.mean(axis=0) == pytest.approx((0.0, 0.0))


def test_clockwise_input_is_accepted():
    cw = square(0.02)[::-1]
    s = Scene.from_objects([{"vertices": cw, "pose": (0.0, 0.2, 0.3), "is_target": True}])
    assert len(s) == 1


@pytest.mark.parametrize(
    "objects, message",
    [
        (
            [
                {"vertices": square(0.02), "pose": (0, 0.2, 0), "is_target": True},
                {"vertices": square(0.02), "pose": (0.03, 0.2, 0), "is_target": False},
            ],
            "overlap",
        ),
        ([{"vertices": square(0.02), "pose": (0.24, 0.2, 0), "is_target": True}], "outside the shelf"),
        ([{"vertices": square(0.02), "pose": (0.0, 0.01, 0), "is_target": True}], "outside the shelf"),
        ([{"vertices": [[0, 0], [0.04, 0], [0.01, 0.01], [0, 0.04]], "pose": (0, 0.2, 0), "is_target": True}], "not strictly convex"),
        ([{"vertices": [[0, 0], [0.04, 0], [0.08, 0]], "pose": (0, 0.2, 0), "is_target": True}], "degenerate"),
        ([{"vertices": [[0, 0], [0.04, 0]], "pose": (0, 0.2, 0), "is_target": True}], "3 to 8 vertices"),
        ([{"vertices": square(0.02), "pose": (0, 0.2, 0), "is_target": False}], "exactly one target"),
        (
            [
                {"vertices": square(0.02), "pose": (-0.1, 0.2, 0), "is_target": True},
                {"vertices": square(0.02), "pose": (0.1, 0.2, 0), "is_target": True},
            ],
            "exactly one target",
        ),
        ([{"vertices": square(0.05), "pose": (0, 0.2, 0), "is_target": True}], "stroke"),
        ([{"vertices": square(0.02), "pose": (0, float("nan"), 0), "is_target": True}], "NaN"),
        ([{"vertices": square(0.02), "is_target": True}], "missing key"),
        ([], "at least one object"),
    ],
)
def test_malformed_scenes_are_rejected_with_the_reason(objects, message):
    with pytest.raises(ValueError, match=message):
        Scene.from_objects(objects)


def test_gripper_overlapping_an_object_or_wall_is_rejected():
    with pytest.raises(ValueError, match="overlaps object 0"):
        scene([(0.0, 0.03, 0.0, True)], gripper=(0.045, 0.0, 0.0))  # a finger in the object
    with pytest.raises(ValueError, match="overlaps a shelf wall"):
        scene([(0.0, 0.2, 0.0, True)], gripper=(0.25, 0.1, 0.0))


def test_bad_stage_is_rejected():
    with pytest.raises(ValueError, match="stage must be one of"):
        Scene.sample(4, seed=0)


def test_round_trip_through_to_objects():
    s = Scene.sample(2, seed=5)
    t = Scene.from_objects(s.to_objects(), gripper_pose=s.gripper_pose)
    for a, b in zip(s.objects, t.objects):
        assert np.allclose(a.vertices, b.vertices) and np.allclose(a.pose, b.pose) and a.is_target == b.is_target
    assert math.isclose(t.target.pose[0], s.target.pose[0])
