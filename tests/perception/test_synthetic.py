"""Synthetic tag images: reproducible from a seed, the tag where its pose puts it."""

import numpy as np
import pytest

from occrl.perception import CameraModel
from occrl.perception.synthetic import render_tags

pytest.importorskip("cv2")


def face_on(distance: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = np.diag([1.0, -1.0, -1.0])
    pose[:3, 3] = [0.0, 0.0, distance]
    return pose


def test_a_seed_fixes_the_image():
    camera = CameraModel.from_fov(160, 120, 70.0)
    make = lambda seed: render_tags(camera, [(3, face_on(0.2), 0.03)], noise_std=2.0, rng=np.random.default_rng(seed))  # noqa: E731
    np.testing.assert_array_equal(make(1), make(1))
    assert not np.array_equal(make(1), make(2))


def test_the_tag_covers_its_projection():
    camera = CameraModel.from_fov(160, 120, 70.0)
    image = render_tags(camera, [(3, face_on(0.2), 0.03)], rgb=False)
    side = 0.03 * camera.fx / 0.2  # 17.1 pixels
    # along the middle row: the middle of the black border's cell (one of 8), of the white margin's
    row, cell = int(round(camera.cy)), side / 8
    assert image[row, int(round(camera.cx - side / 2 + cell / 2))] == 0
    assert image[row, int(round(camera.cx - side / 2 - cell / 2))] == 255
    assert image[0, 0] == 128  # the background


def test_noise_needs_a_seeded_generator():
    camera = CameraModel.from_fov(160, 120, 70.0)
    with pytest.raises(ValueError, match="noise_std > 0 needs rng, a seeded numpy.random.Generator"):
        render_tags(camera, [(3, face_on(0.2), 0.03)], noise_std=2.0)
