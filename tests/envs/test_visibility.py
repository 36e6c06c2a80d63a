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
