"""The geometry helpers that replaced np.roll give the same arrays and values, bit for bit."""

import numpy as np

from occrl.envs.geometry import convex_hull, next_vertices, polygon_area, polygon_centroid


def _roll_area(v):
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _roll_centroid(v):
    x, y = v[:, 0], v[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    c = x * yn - xn * y
    return np.array([((x + xn) * c).sum(), ((y + yn) * c).sum()]) / (6.0 * 0.5 * c.sum())


def test_next_vertices_is_roll_by_one_along_the_vertex_axis():
    polys = np.random.default_rng(0).normal(size=(3, 5, 7, 2))
    assert np.array_equal(next_vertices(polys), np.roll(polys, -1, axis=-2))


def test_area_and_centroid_equal_the_roll_formulas_bit_for_bit():
    rng = np.random.default_rng(1)
    for _ in range(500):
        hull = convex_hull(rng.normal(size=(int(rng.integers(3, 9)), 2)) * rng.uniform(0.01, 0.2))
        if len(hull) < 3:
            continue
        assert polygon_area(hull) == _roll_area(hull)
        assert np.array_equal(polygon_centroid(hull), _roll_centroid(hull))


def test_gripper_outlines_of_many_openings_equal_each_openings_own_bit_for_bit():
    from occrl.envs import world_constants as C
    from occrl.envs.shelf_geometry import gripper_polygons, gripper_polygons_batch

    openings = np.concatenate([np.random.default_rng(0).uniform(0.0, C.GRIPPER_STROKE, 500), [0.0, C.GRIPPER_STROKE]])
    batch = gripper_polygons_batch(openings)
    each = np.stack([np.stack(gripper_polygons(float(o))) for o in openings])
    assert batch.shape == (len(openings), 4, 4, 2)
    assert np.array_equal(batch, each) and np.array_equal(np.signbit(batch), np.signbit(each))
