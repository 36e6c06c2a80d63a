import math

import numpy as np
import pytest

from occrl.envs.visibility import detect, visible_fractions
from occrl.envs.shelf_geometry import wall_polygons

CAMERA = np.array([0.0, -0.1, 0.0])  # at the front, looking into the shelf (+y)


def box(x, y, hx, hy=None):
    hy = hx if hy is None else hy
    return np.array([[x - hx, y - hy], [x + hx, y - hy], [x + hx, y + hy], [x - hx, y + hy]])


def test_object_wholly_behind_another_is_not_detected():
    f = visible_fractions([box(0, 0.1, 0.03), box(0, 0.3, 0.02)], CAMERA)
    assert f.tolist() == [1.0, 0.0]
    assert detect(f).tolist() == [True, False]


def test_half_hidden_object_is_at_the_threshold():
    # the front box's right silhouette ray passes exactly through the back box's centre line
    front = box(-0.03, 0.1, 0.03)
    back = box(0.0, 0.3, 0.02)
    f = visible_fractions([front, back], CAMERA)
    assert f[1] == pytest.approx(0.5, abs=1e-9)
    assert not detect(f)[1]  # detection needs strictly more than half


@pytest.mark.parametrize("shift, detected", [(-0.004, True), (0.004, False)])
def test_a_little_more_or_less_than_half_hidden(shift, detected):
    front = box(-0.03 + shift, 0.1, 0.03)
    f = visible_fractions([front, box(0.0, 0.3, 0.02)], CAMERA)
    assert detect(f)[1] == detected


def test_outside_the_field_of_view_is_not_visible():
    half = math.radians(35)
    y = 0.2
    x_edge = (y - CAMERA[1]) * math.tan(half)
    inside, straddling, outside = box(x_edge - 0.05, y, 0.01), box(x_edge, y, 0.01), box(x_edge + 0.05, y, 0.01)
    f = visible_fractions([inside, straddling, outside], CAMERA)
    assert f[0] == pytest.approx(1.0)
    assert f[1] == pytest.approx(0.5, abs=0.02)
    assert f[2] == 0.0


def test_side_wall_hides_objects_from_a_camera_outside_the_shelf():
    camera = np.array([0.4, -0.05, math.radians(40)])  # right of the shelf, looking in to the left
    obj = box(0.2, 0.12, 0.015)
    assert visible_fractions([obj], camera)[0] > 0.5
    assert visible_fractions([obj], camera, wall_polygons())[0] == 0.0


def test_object_containing_the_camera_is_not_visible():
    assert visible_fractions([box(0.0, -0.1, 0.05)], CAMERA)[0] == 0.0


def test_batched_visibility_equals_the_per_camera_function_bit_for_bit():
    """Many cameras at once (the planner's roll-out worlds) give exactly the per-camera values,
    whatever the other cameras' object counts, with a hidden object and with empty worlds."""
    from occrl.envs import Scene, ShelfWorld
    from occrl.envs.observation import WALLS_PADDED
    from occrl.envs.visibility import visible_fractions_batch

    rng = np.random.default_rng(0)
    worlds = [ShelfWorld(Scene.sample(stage=1 + s % 3, seed=s)) for s in range(24)]
    objects = [w.object_world_padded() for w in worlds] + [np.zeros((0, 8, 2))]
    poses = np.array([[rng.uniform(-0.3, 0.3), rng.uniform(-0.15, 0.3), rng.uniform(-0.8, 0.8)] for _ in objects])
    hidden = [None] * len(objects)
    hidden[3] = 0
    batch = visible_fractions_batch(objects, poses, WALLS_PADDED, hidden=hidden)
    for k, (objs, pose, got) in enumerate(zip(objects, poses, batch)):
        if k == 3:  # the hidden object reads 0 and hides nothing: as if it were not there
            rest = visible_fractions(objs[1:], pose, WALLS_PADDED)
            assert got[0] == 0.0 and np.array_equal(got[1:], rest)
        else:
            assert np.array_equal(got, visible_fractions(objs, pose, WALLS_PADDED)) if len(objs) else got.shape == (0,)


def test_pad_polygons_pads_with_the_first_vertex_and_refuses_what_does_not_fit():
    """Every polygon padded to the size by repeating its first vertex (one gather for all), and
    a polygon with no vertex or more than the size refused with a message."""
    from occrl.envs.geometry import pad_polygons

    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    quad = np.array([[2.0, 2.0], [3.0, 2.0], [3.0, 3.0], [2.0, 3.0]])
    out = pad_polygons([tri, quad], 5)
    assert out.shape == (2, 5, 2) and out.dtype == np.float64
    assert np.array_equal(out[0], np.concatenate([tri, tri[:1], tri[:1]]))
    assert np.array_equal(out[1], np.concatenate([quad, quad[:1]]))
    assert pad_polygons([tri, quad]).shape == (2, 4, 2)  # the most vertices of any
    assert pad_polygons([], 8).shape == (0, 8, 2)
    for bad in ([quad], [np.zeros((0, 2))]):
        with pytest.raises(ValueError, match="vertices to pad to 3"):
            pad_polygons(bad, 3)


def test_detection_arrays_refuse_fractions_that_do_not_match_the_worlds():
    from occrl.envs import Scene, ShelfWorld
    from occrl.envs.observation import detection_arrays, worlds_visible_fractions

    worlds = [ShelfWorld(Scene.sample(stage=2, seed=s)) for s in range(2)]
    fractions = worlds_visible_fractions(worlds)
    with pytest.raises(ValueError, match="one value per object of each world"):
        detection_arrays(worlds, [fractions[0][:-1], fractions[1]])
