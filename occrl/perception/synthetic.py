"""Synthetic camera images of tags at known poses, to test a detector and measure its accuracy.

A tag is drawn by warping its image (the black square and a white margin around it) with the
homography of its pose into an ideal pinhole camera (the camera's intrinsics, no distortion),
rendered ``supersample`` times larger and averaged down (anti-aliased), over a flat grey background,
then Gaussian pixel noise is added. Tags are painted far to near; object bodies are not drawn (a tag
hides only what lies behind it).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from occrl.perception.camera import CameraModel
from occrl.perception.catalogue import TagCatalogue
from occrl.perception.checks import rigid_transform, strict_int
from occrl.perception.frames import gripper_pose_matrix, invert_transform
from occrl.perception.opencv import DEFAULT_DICTIONARY, aruco_dictionary, check_dictionary, require_opencv

__all__ = ["tag_texture", "render_tags", "render_objects", "MARGIN_CELLS"]

MARGIN_CELLS = 1  # white cells around the black square (the tag's quiet zone)


def tag_texture(tag_id: int, pixels_per_cell: int, dictionary: str = DEFAULT_DICTIONARY, margin_cells: int = MARGIN_CELLS) -> np.ndarray:
    """The tag's image, uint8 grey: its black square of ``bits + 2`` cells and ``margin_cells``
    white cells around it, ``pixels_per_cell`` pixels a cell.

    Examples:
        >>> from occrl.perception.synthetic import tag_texture
        >>> texture = tag_texture(0, 4)  # 36h11: 6 data cells + the black border, + 1 white cell a side
        >>> texture.shape, int(texture[0, 0]), int(texture[4, 4])
        ((40, 40), 255, 0)
    """
    cells = check_dictionary(dictionary).bits + 2
    ppc = strict_int("pixels_per_cell", pixels_per_cell, 1, 1000)
    strict_int("tag_id", tag_id, 0, check_dictionary(dictionary).size)
    cv2 = require_opencv()
    marker = cv2.aruco.generateImageMarker(aruco_dictionary(dictionary), tag_id, cells * ppc, borderBits=1)
    m = margin_cells * ppc
    return np.pad(marker, m, constant_values=255)


def render_tags(
    camera: CameraModel,
    tags: Sequence[tuple[int, np.ndarray, float]],
    noise_std: float = 0.0,
    rng: np.random.Generator | None = None,
    background: int = 128,
    supersample: int = 4,
    dictionary: str = DEFAULT_DICTIONARY,
    rgb: bool = True,
) -> np.ndarray:
    """An image of ``tags``, each ``(tag_id, camera_tag, size)``: its 4x4 pose in the camera frame
    (OpenCV's tag frame: centre, x right, y up, z out of the tag) and the side of its black square (m).

    Returns (H, W, 3) uint8 RGB (grey values) when ``rgb``, else (H, W) uint8. ``noise_std`` (grey
    levels) needs ``rng``, a seeded ``numpy.random.Generator``, so that an image can be made again.
    """
    if noise_std < 0 or not np.isfinite(noise_std):
        raise ValueError(f"noise_std must be a finite number >= 0 (grey levels), got {noise_std!r}")
    if noise_std > 0 and not isinstance(rng, np.random.Generator):
        raise ValueError(f"noise_std > 0 needs rng, a seeded numpy.random.Generator (np.random.default_rng(seed)), got {rng!r}")
    cv2 = require_opencv()
    f = strict_int("supersample", supersample, 1, 17)
    w, h = camera.width * f, camera.height * f
    k = camera.intrinsic_matrix.copy()
    k[0, 0] *= f
    k[1, 1] *= f
    k[0, 2] = (k[0, 2] + 0.5) * f - 0.5
    k[1, 2] = (k[1, 2] + 0.5) * f - 0.5
    canvas = np.full((h, w), float(background), np.float32)
    cells = check_dictionary(dictionary).bits + 2
    poses = [(int(tag_id), rigid_transform("camera_tag", pose), float(size)) for tag_id, pose, size in tags]
    for tag_id, pose, size in sorted(poses, key=lambda t: -t[1][2, 3]):
        if pose[2, 3] <= 0 or pose[2, 2] >= 0:  # behind the camera, or facing away from it
            continue
        texture = tag_texture(tag_id, 16, dictionary).astype(np.float32)
        n = texture.shape[0]
        side = size * n / (16 * cells)  # the texture's side in metres
        # texture pixel (u, v) -> tag plane (X, Y, 1): pixel centres at integers, y up
        plane = np.array([[side / n, 0.0, side / n * 0.5 - side / 2], [0.0, -side / n, side / 2 - side / n * 0.5], [0.0, 0.0, 1.0]])
        homography = k @ np.stack([pose[:3, 0], pose[:3, 1], pose[:3, 3]], axis=1) @ plane
        warped = cv2.warpPerspective(texture, homography, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=-1.0)
        mask = cv2.warpPerspective(
            np.ones_like(texture), homography, (w, h), flags=cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0.0
        )
        inside = mask > 0.5
        canvas[inside] = warped[inside]
    image = cv2.resize(canvas, (camera.width, camera.height), interpolation=cv2.INTER_AREA) if f > 1 else canvas
    if noise_std > 0:
        image = image + rng.normal(0.0, noise_std, image.shape)
    image = np.clip(np.round(image), 0, 255).astype(np.uint8)
    return np.repeat(image[..., None], 3, axis=2) if rgb else image


def render_objects(
    camera: CameraModel,
    catalogue: TagCatalogue,
    objects: Sequence[tuple[int, Sequence[float]]],
    gripper_pose: np.ndarray,
    **render_options,
) -> np.ndarray:
    """An image of the tags of ``objects``, each ``(type_id, (x, y, theta))`` standing on the shelf
    floor, seen from the camera of a gripper at ``gripper_pose`` (4x4, shelf frame; see
    :func:`occrl.perception.frames.gripper_pose_matrix`). ``render_options`` go to :func:`render_tags`.

    Examples:
        >>> import math
        >>> from occrl.perception import CameraModel, TagCatalogue, TagDetector, gripper_pose_matrix
        >>> from occrl.perception.synthetic import render_objects
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> catalogue = TagCatalogue.from_dict({"objects": [{"type_id": 3, "height": 0.12, "footprint": box,
        ...     "tags": [{"tag_id": 0, "face": 0, "offset": [0.0, 0.06], "size": 0.03}]}]})
        >>> camera = CameraModel.from_fov(640, 480, 70.0)
        >>> gripper = gripper_pose_matrix(0.0, -0.1, 0.0, z=0.06)
        >>> image = render_objects(camera, catalogue, [(3, (0.01, 0.15, 0.1))], gripper)
        >>> (found,) = TagDetector(camera, catalogue).detect(image, gripper)
        >>> found["type_id"], round(found["pose"][0], 2), round(found["pose"][1], 2), round(math.degrees(found["pose"][2]))  # truth: 5.7 degrees
        (3, 0.01, 0.15, 7)
    """
    shelf_gripper = rigid_transform("gripper_pose", gripper_pose)
    camera_shelf = invert_transform(shelf_gripper @ camera.hand_camera)
    tags = []
    for type_id, pose in objects:
        shelf_object = gripper_pose_matrix(*pose)
        for entry in catalogue.tags_of(type_id):
            tags.append((entry.tag_id, camera_shelf @ shelf_object @ entry.tag_in_object, entry.size))
    return render_tags(camera, tags, dictionary=catalogue.dictionary, **render_options)
