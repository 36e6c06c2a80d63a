"""The geometry helpers: the ones that replaced np.roll give the same arrays and values, bit for bit; the padding helpers."""

import numpy as np
import pytest

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


def test_ragged_positions_fill_row_by_row_and_refuse_negative_counts():
    from occrl.envs.geometry import ragged_positions

    rows, slots = ragged_positions([2, 0, 3])
    padded = np.full((3, 3), -1)
    padded[rows, slots] = np.arange(5)  # the items laid end to end, each list's in its row
    assert padded.tolist() == [[0, 1, -1], [-1, -1, -1], [2, 3, 4]]
    assert [r.tolist() for r in ragged_positions([])] == [[], []]
    with pytest.raises(ValueError, match=">= 0"):
        ragged_positions([1, -1])


def test_pad_polygons_takes_arrays_and_nested_lists_alike():
    from occrl.envs.geometry import pad_polygons

    tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    quad = np.array([[0, 0], [2, 0], [2, 2], [0, 2]])  # ints: padded as floats
    out = pad_polygons([tri, quad], 5)
    assert out.dtype == np.float64 and out.shape == (2, 5, 2)
    assert np.array_equal(out, pad_polygons([np.array(tri), quad.astype(float)], 5))
    assert out[0, 3:].tolist() == [[0.0, 0.0]] * 2 and out[1, 4].tolist() == [0.0, 0.0]
