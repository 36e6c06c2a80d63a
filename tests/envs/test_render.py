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


def test_rendering_only_the_window_equals_cropping_the_whole_map_bit_for_bit():
    """render_labels_at draws only the canvas rows and columns its points reach (the planner's
    roll-outs): the labels equal Canvas.lookup on the whole map, for stage-2 detections seen from
    the env's poses and from poses moved and turned anywhere (windows partly off the canvas)."""
    from occrl.envs.observation import detected_world_polygons, detection_arrays, worlds_visible_fractions
    from occrl.envs.render import DEFAULT_CANVAS, render_labels_at, render_labels_batch
    from occrl.envs.robot_frame import robot_centric_points

    rng = np.random.default_rng(0)
    env = make_env(batch_size=4, stage=2, noise=0.1, seed=3, heatmap_target=False)
    td = env.reset()
    checked = 0
    for _ in range(8):
        worlds = env.base_env.worlds
        a = detection_arrays(worlds, worlds_visible_fractions(worlds))
        polygons = detected_world_polygons(a["detected"], a["type_id"], a["pose"], a["vertices"], a["num_vertices"], a["target_type"])
        poses = a["gripper_pose"].astype(np.float64)
        moved = poses + np.c_[rng.uniform(-0.6, 0.6, (4, 2)), rng.uniform(-3.0, 3.0, 4)]
        for p in (poses, moved):
            points = robot_centric_points(p)
            window = render_labels_at(p, a["gripper_opening"], polygons, points)
            whole = DEFAULT_CANVAS.lookup(render_labels_batch(p, a["gripper_opening"], polygons), points)
            assert np.array_equal(window, whole)
            checked += int((whole != whole[:, :1, :1]).any())
        td = env.step(env.rand_action(td))["next"]
    assert checked >= 8  # the windows showed more than one class


def test_pillow_draws_float_polygons_at_their_truncated_coordinates():
    """What the renderer relies on to draw a part of the canvas (occrl.envs.render truncates the
    coordinates itself and shifts them by whole rows): Pillow fills a polygon given in floats as
    the one given in the floats truncated towards zero."""
    from PIL import Image, ImageDraw

    rng = np.random.default_rng(0)
    for _ in range(200):
        polygon = rng.uniform(-40.0, 140.0, size=(int(rng.integers(3, 8)), 2))
        floats, ints = Image.new("L", (100, 90)), Image.new("L", (100, 90))
        ImageDraw.Draw(floats).polygon(polygon.ravel().tolist(), fill=1)
        ImageDraw.Draw(ints).polygon(np.trunc(polygon).astype(np.int64).ravel().tolist(), fill=1)
        assert np.array_equal(np.asarray(floats), np.asarray(ints))
    # rounding instead would differ: the test can tell
    polygon = np.array([[10.7, 10.7], [60.7, 10.7], [60.7, 60.7]])
    a, b = Image.new("L", (100, 90)), Image.new("L", (100, 90))
    ImageDraw.Draw(a).polygon(polygon.ravel().tolist(), fill=1)
    ImageDraw.Draw(b).polygon(np.round(polygon).astype(np.int64).ravel().tolist(), fill=1)
    assert not np.array_equal(np.asarray(a), np.asarray(b))


def test_label_maps_come_out_writable():
    """The env hands them to torch.from_numpy, which warns on (and cannot own) a read-only buffer."""
    import warnings

    from occrl.envs.render import render_labels_batch

    labels = render_labels_batch(np.array([[0.0, -0.1, 0.0], [0.1, -0.1, 0.2]]), np.array([0.085, 0.04]), [([], []), ([], [])])
    assert labels.flags.writeable
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        torch.from_numpy(labels)


def test_labels_to_pixels_colours_every_label_and_refuses_others():
    """Each label's pixel carries its palette colour in every channel (the one gather over the
    channels' palettes laid end to end), for uint8 and int64 labels; a label outside LABELS is
    refused with a message naming the allowed range."""
    from occrl.envs.render import LABELS, labels_to_pixels

    for dtype in (np.uint8, np.int64):
        labels = np.tile(np.arange(len(PALETTE), dtype=dtype), (2, 3, 1))  # (2, 3, 7)
        px = labels_to_pixels(labels)
        assert px.shape == (2, 3, 3, len(PALETTE)) and px.dtype == torch.float32
        expected = PALETTE[labels].astype(np.float32) / 255.0  # (2, 3, 7, 3)
        assert np.array_equal(px.numpy(), expected.transpose(0, 3, 1, 2))
    assert len(LABELS) == len(PALETTE)
    for bad in (np.full((1, 4, 4), len(PALETTE), np.uint8), np.full((1, 4, 4), -1, np.int64)):
        with pytest.raises(ValueError, match=r"labels must be in \[0, 7\)"):
            labels_to_pixels(bad)


def test_robot_centric_points_are_the_per_pixel_rotation_bit_for_bit():
    """The window's points, computed from a column's and a row's products broadcast
    (robot_centric_xy), equal the per-pixel rotation c x - s y + px, s x + c y + py of the window's
    grid bit for bit, as the pixel indices of the observation pipeline rely on."""
    from occrl.envs.robot_frame import robot_centric_points

    rng = np.random.default_rng(3)
    poses = np.stack([rng.uniform(-0.3, 0.3, 50), rng.uniform(-0.3, 0.5, 50), rng.uniform(-3.0, 3.0, 50)], 1)
    window, size, offset = 0.8, 64, 0.15
    k = np.arange(size) + 0.5
    gx = np.broadcast_to(((k - size / 2) * (window / size))[None, :], (size, size))
    gy = np.broadcast_to((offset + (size / 2 - k) * (window / size))[:, None], (size, size))
    c, s = np.cos(poses[:, 2])[:, None, None], np.sin(poses[:, 2])[:, None, None]
    expected = np.stack([c * gx - s * gy + poses[:, 0, None, None], s * gx + c * gy + poses[:, 1, None, None]], -1)
    assert np.array_equal(robot_centric_points(poses, window, size, offset), expected)


def test_to_pixels_in_place_gives_the_same_values_in_the_callers_array():
    from occrl.envs.render import DEFAULT_CANVAS

    points = np.random.default_rng(0).uniform(-0.3, 0.5, size=(3, 7, 2))
    expected = DEFAULT_CANVAS.to_pixels(points)
    scratch = points.copy()
    out = DEFAULT_CANVAS.to_pixels(scratch, overwrite=True)
    assert out is scratch and np.array_equal(out, expected)
    assert np.array_equal(expected[..., 0], (points[..., 0] - DEFAULT_CANVAS.x0) / DEFAULT_CANVAS.resolution - 0.5)
    assert np.array_equal(expected[..., 1], (DEFAULT_CANVAS.y1 - points[..., 1]) / DEFAULT_CANVAS.resolution - 0.5)
