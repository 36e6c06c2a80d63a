import numpy as np
import pytest
import torch

from occrl.envs import make_env
from occrl.envs.render import PALETTE
from tests.helpers import scene, world_to_crop_pixel

GRIPPER = (0.0, -0.1, 0.0)


@pytest.fixture(scope="module")
def pixels():
    # clutter straight ahead, the target to the right and visible, a box hidden behind the clutter
    s = scene([(0.0, 0.1, 0.0, False), (0.12, 0.15, 0.0, True), (0.0, 0.28, 0.0, False)], gripper=GRIPPER)
    env = make_env(batch_size=1, scenes=[s], heatmap_target=True)
    td = env.reset()
    return td


def colour_at(td, point):
    r, c = world_to_crop_pixel(point, GRIPPER)
    return (td["pixels"][0, :, r, c] * 255).round().to(torch.uint8).tolist()


@pytest.mark.parametrize(
    "point, name, index",
    [
        ((0.0, 0.1), "clutter red", 4),
        ((0.12, 0.15), "target green", 5),
        ((0.0, 0.33), "occluded white (shadow of the clutter)", 1),
        ((0.0, 0.28), "hidden box is not drawn (white)", 1),
        ((-0.05, 0.06), "observable grey", 0),
        ((-0.23, 0.1), "outside the field of view white", 1),
        ((-0.2, 0.0), "front edge black", 3),
        ((-0.26, 0.2), "wall brown", 2),
        ((0.0, -0.13), "gripper blue", 6),
    ],
)
def test_pixel_colours_at_known_places(pixels, point, name, index):
    assert colour_at(pixels, point) == PALETTE[index].tolist(), name


def test_heatmap_target_marks_the_true_target_even_when_hidden(pixels):
    heat = pixels["privileged", "heatmap_target"][0, 0]
    r, c = world_to_crop_pixel((0.12, 0.15), GRIPPER)
    assert heat[r, c] == 1.0
    area_px = heat.sum().item()
    assert area_px == pytest.approx(0.04 * 0.04 / (0.8 / 64) ** 2, rel=0.35)
    r, c = world_to_crop_pixel((0.0, 0.1), GRIPPER)
    assert heat[r, c] == 0.0


def test_the_window_turns_with_the_gripper():
    s = scene([(0.1, 0.25, 0.0, True)], gripper=(0.0, -0.1, 0.5))
    td = make_env(batch_size=1, scenes=[s], heatmap_target=False).reset()
    # a point on the palm, 3 cm behind the camera along the gripper's own axis, shows in the
    # same pixel whatever the gripper's heading, and it is gripper blue
    local = np.array([0.006, -0.03])
    rot = np.array([[np.cos(0.5), -np.sin(0.5)], [np.sin(0.5), np.cos(0.5)]])
    turned = np.array([0.0, -0.1]) + rot @ local
    straight = np.array([0.0, -0.1]) + local
    r, c = world_to_crop_pixel(turned, (0.0, -0.1, 0.5))
    assert (r, c) == world_to_crop_pixel(straight, GRIPPER)
    assert (td["pixels"][0, :, r, c] * 255).round().to(torch.uint8).tolist() == PALETTE[6].tolist()
