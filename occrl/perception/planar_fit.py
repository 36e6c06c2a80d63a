"""An object's planar pose fitted to its tags' corners: the object stands upright on the shelf
floor, so its pose in the shelf frame has three unknowns (x, y and the heading theta), not a
tag's six.

A tag's own pose (OpenCV's IPPE) also estimates the tag's tilt, which the object cannot have, and
an error in that tilt moves the object's centre: the centre lies a lever arm (half the object's
depth) behind the tag. :func:`fit_planar_pose` instead moves (x, y, theta) until the catalogue's
corners of every decoded tag of the object, placed by that pose and seen through the calibrated
camera, land on the decoded corners (Levenberg-Marquardt on the pixel residuals, started from a
pose the tags' own poses give). The decoded corners are undistorted once, so the fit itself is a
pinhole's, with an exact Jacobian.
"""

from __future__ import annotations

import math

import numpy as np

from occrl.perception.frames import invert_transform, rotation_about_z
from occrl.perception.opencv import require_opencv

__all__ = ["fit_planar_pose", "shelf_object_matrix", "MAX_ITERATIONS"]

MAX_ITERATIONS = 12
STEP_TOLERANCE = 1e-7  # m or rad: an update this small ends the fit


def shelf_object_matrix(pose: tuple[float, float, float]) -> np.ndarray:
    """The 4x4 pose in the shelf frame of an object standing on the floor at planar ``pose``."""
    t = np.eye(4)
    t[:3, :3] = rotation_about_z(pose[2])
    t[:3, 3] = [pose[0], pose[1], 0.0]
    return t


def fit_planar_pose(
    points_in_object: np.ndarray,
    pixels: np.ndarray,
    start: tuple[float, float, float],
    shelf_camera: np.ndarray,
    camera_matrix: np.ndarray,
    distortion: np.ndarray,
) -> tuple[tuple[float, float, float], float]:
    """The planar pose (x, y, theta) of an object standing on the shelf floor whose points
    ``points_in_object`` (N, 3; its tags' corners in the object frame) are seen at ``pixels``
    (N, 2), started from ``start``; with the RMS reprojection error (pixels) at that pose.

    Args:
        shelf_camera: the camera's 4x4 pose in the shelf frame.
        camera_matrix, distortion: the camera's intrinsics (OpenCV's).

    Examples:
        >>> import numpy as np
        >>> from occrl.perception.camera import CameraModel
        >>> from occrl.perception.frames import invert_transform
        >>> from occrl.perception.planar_fit import fit_planar_pose, shelf_object_matrix
        >>> camera = CameraModel.from_fov(640, 480, 70.0)
        >>> shelf_camera = np.array([[1.0, 0, 0, 0], [0, 0, 1, -0.1], [0, -1, 0, 0.07], [0, 0, 0, 1]])  # looking along +y
        >>> corners = np.array([[-0.015, -0.02, 0.085], [0.015, -0.02, 0.085], [0.015, -0.02, 0.055], [-0.015, -0.02, 0.055]])
        >>> true = (0.03, 0.25, 0.2)
        >>> camera_corners = (invert_transform(shelf_camera) @ shelf_object_matrix(true) @ np.c_[corners, np.ones(4)].T)[:3].T
        >>> pixels = camera_corners[:, :2] / camera_corners[:, 2:] * camera.fx + [camera.cx, camera.cy]
        >>> pose, rms = fit_planar_pose(corners, pixels, (0.0, 0.22, 0.0), shelf_camera, camera.intrinsic_matrix, camera.distortion_array)
        >>> np.round(pose, 6).tolist(), rms < 1e-6
        ([0.03, 0.25, 0.2], True)
    """
    cv2 = require_opencv()
    points = np.asarray(points_in_object, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    # the decoded corners undistorted once: the model is then a pinhole's X / Z, Y / Z
    seen = cv2.undistortPoints(np.asarray(pixels, dtype=np.float64).reshape(-1, 1, 2), camera_matrix, distortion).reshape(n, 2)
    focal = np.array([camera_matrix[0][0], camera_matrix[1][1]], dtype=np.float64)  # residuals in pixels
    camera_shelf = invert_transform(np.asarray(shelf_camera, dtype=np.float64))
    rotation, translation = camera_shelf[:3, :3], camera_shelf[:3, 3]

    # a point of the object at pose (x, y, theta), in the camera frame:
    # cos(theta) * along + sin(theta) * across + fixed + x * rotation[:, 0] + y * rotation[:, 1]
    along = np.c_[points[:, :2], np.zeros(n)] @ rotation.T
    across = np.c_[-points[:, 1], points[:, 0], np.zeros(n)] @ rotation.T
    fixed = np.outer(points[:, 2], rotation[:, 2]) + translation

    def residual(p: np.ndarray, jacobian: bool = False):
        c, s = math.cos(p[2]), math.sin(p[2])
        in_camera = c * along + s * across + fixed + p[0] * rotation[:, 0] + p[1] * rotation[:, 1]
        z = in_camera[:, 2:3]
        projected = in_camera[:, :2] / z
        r = ((projected - seen) * focal).reshape(-1)
        if not jacobian:
            return r
        # d camera-frame point / d (x, y, theta): (n, 3 coordinates, 3 unknowns)
        d_point = np.empty((n, 3, 3))
        d_point[:, :, 0] = rotation[:, 0]
        d_point[:, :, 1] = rotation[:, 1]
        d_point[:, :, 2] = c * across - s * along
        # d (X / Z, Y / Z) / d unknowns, in pixels
        d_pixel = (d_point[:, :2, :] - projected[:, :, None] * d_point[:, 2:3, :]) / z[:, :, None] * focal[None, :, None]
        return r, d_pixel.reshape(2 * n, 3)

    p = np.asarray(start, dtype=np.float64).copy()
    r, jac = residual(p, jacobian=True)
    cost = float(r @ r)
    damping = 1e-3
    for _ in range(MAX_ITERATIONS):
        normal, gradient = jac.T @ jac, jac.T @ r
        while True:
            try:
                step = -np.linalg.solve(normal + damping * np.diag(np.diag(normal) + 1e-12), gradient)
            except np.linalg.LinAlgError:  # degenerate corners (all on one line of sight): keep the pose so far
                step = np.zeros(3)
            r_trial = residual(p + step)
            cost_trial = float(r_trial @ r_trial)
            if cost_trial <= cost or damping > 1e6:
                break
            damping *= 10.0
        if not cost_trial <= cost:  # no step lowers the error (a NaN one neither)
            break
        p = p + step
        cost = cost_trial
        damping = max(damping / 10.0, 1e-7)
        if np.abs(step).max() < STEP_TOLERANCE:
            break
        r, jac = residual(p, jacobian=True)
    theta = math.atan2(math.sin(p[2]), math.cos(p[2]))
    return (float(p[0]), float(p[1]), theta), math.sqrt(cost / n)
