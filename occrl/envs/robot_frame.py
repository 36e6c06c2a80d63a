"""The robot-centric window: which shelf-frame point each pixel of the network input shows.

The window is a square of ``window`` metres, ``size`` pixels a side, that moves and turns with the
gripper: the image's up direction is the gripper's approach axis and its centre lies
``forward_offset`` metres ahead of the gripper, so the camera sits below the image centre and most
of the window shows what is in front of the gripper.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["robot_centric_points", "robot_centric_xy", "robot_centric_pixels", "DEFAULT_WINDOW", "DEFAULT_SIZE", "DEFAULT_FORWARD_OFFSET"]

DEFAULT_WINDOW = 0.8  # m
DEFAULT_SIZE = 64  # pixels
DEFAULT_FORWARD_OFFSET = 0.15  # m: the window spans 0.25 m behind to 0.55 m ahead of the gripper


@lru_cache(maxsize=8)
def _local_axes(window: float, size: int, forward_offset: float) -> tuple[np.ndarray, np.ndarray]:
    """The gripper-frame x of each pixel column and y of each pixel row, (size,) each (read-only,
    computed once per window): the pixel centre of row r, column k is (x[k], y[r])."""
    pix = window / size
    k = np.arange(size) + 0.5
    xl = (k - size / 2) * pix  # columns -> gripper +x (to the right in the image)
    yl = forward_offset + (size / 2 - k) * pix  # rows -> gripper +y (up in the image)
    xl.flags.writeable = yl.flags.writeable = False
    return xl, yl


def robot_centric_xy(
    gripper_poses: np.ndarray,
    window: float = DEFAULT_WINDOW,
    size: int = DEFAULT_SIZE,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`robot_centric_points` as two arrays, the shelf-frame x and y (..., size, size) of
    each pixel centre (the same values, without the stacking: for callers that use x and y
    apart, e.g. :meth:`occrl.envs.render.Canvas.pixel_indices_xy`).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.robot_frame import robot_centric_pixels, robot_centric_xy
        >>> poses = np.array([[0.1, -0.1, 0.3], [0.0, 0.0, -1.0]])
        >>> x, y = robot_centric_xy(poses)
        >>> x.shape
        (2, 64, 64)
        >>> # the inverse map takes row 1, column 2 of each window back to that pixel's centre
        >>> points = np.stack([x[:, 1, 2], y[:, 1, 2]], -1)[:, None]
        >>> robot_centric_pixels(points, poses).round(6).tolist()
        [[[2.0, 1.0]], [[2.0, 1.0]]]
    """
    poses = np.asarray(gripper_poses, dtype=float)
    xl, yl = _local_axes(window, size, forward_offset)
    c, s = np.cos(poses[..., 2])[..., None, None], np.sin(poses[..., 2])[..., None, None]
    # each pixel's rotated offset (c x - s y, s x + c y): the products are a column's or a row's,
    # computed once per column or row and broadcast (the same values as per pixel)
    x = c * xl - s * yl[:, None]
    x += poses[..., 0, None, None]
    y = s * xl + c * yl[:, None]
    y += poses[..., 1, None, None]
    return x, y


def robot_centric_points(
    gripper_poses: np.ndarray,
    window: float = DEFAULT_WINDOW,
    size: int = DEFAULT_SIZE,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
) -> np.ndarray:
    """Shelf-frame centres of the window's pixels for each gripper pose.

    Args:
        gripper_poses: (..., 3) poses (x, y, theta).

    Returns:
        (..., size, size, 2) points; row 0 is the far edge of the window.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.robot_frame import robot_centric_points
        >>> robot_centric_points(np.zeros(3), window=0.8, size=4, forward_offset=0.0)[0, 0].round(2).tolist()
        [-0.3, 0.3]
    """
    return np.stack(robot_centric_xy(gripper_poses, window, size, forward_offset), -1)


def robot_centric_pixels(
    points: np.ndarray,
    gripper_poses: np.ndarray,
    window: float = DEFAULT_WINDOW,
    size: int = DEFAULT_SIZE,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
) -> np.ndarray:
    """The inverse map: shelf-frame ``points`` (B, K, 2) to continuous (col, row) pixel
    coordinates of the window of each gripper pose (B, 3); integers are pixel centres.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.robot_frame import robot_centric_pixels
        >>> # the window's centre lies forward_offset (0.15 m) ahead of the gripper
        >>> robot_centric_pixels(np.array([[[0.0, 0.15]]]), np.zeros((1, 3))).round(6).tolist()
        [[[31.5, 31.5]]]
    """
    poses = np.asarray(gripper_poses, dtype=float)
    d = np.asarray(points, dtype=float) - poses[:, None, :2]
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    xl = c * d[..., 0] + s * d[..., 1]
    yl = -s * d[..., 0] + c * d[..., 1]
    pix = window / size
    return np.stack([xl / pix + size / 2 - 0.5, size / 2 - (yl - forward_offset) / pix - 0.5], -1)
