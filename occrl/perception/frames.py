"""Rigid transforms between the shelf, gripper, camera, tag and object frames (4x4 arrays, metres).

The shelf frame is occrl's (:mod:`occrl.envs.world_constants`): x across the shelf, y into it, z up
from the shelf floor. A transform named ``a_b`` (or "the pose of b in a") maps b-frame points to
a-frame points: ``p_a = a_b @ p_b``.
"""

from __future__ import annotations

import math

import numpy as np

from occrl.perception.checks import finite_array

__all__ = [
    "gripper_pose_matrix",
    "invert_transform",
    "planar_pose",
    "tilt_deg",
    "rotation_angle_deg",
    "rotation_about_z",
    "angle_difference",
]


def rotation_about_z(theta: float) -> np.ndarray:
    """The 3x3 rotation by ``theta`` radians about +z."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def gripper_pose_matrix(x: float, y: float, theta: float, z: float = 0.0) -> np.ndarray:
    """The gripper's 4x4 pose in the shelf frame from its planar pose (as in the observation's
    ``"gripper_pose"``) and the height ``z`` of the gripper frame's origin above the shelf floor.

    Examples:
        >>> import math
        >>> from occrl.perception.frames import gripper_pose_matrix
        >>> g = gripper_pose_matrix(0.1, -0.1, math.pi / 2, z=0.045)
        >>> g[:3, 1].round(6).tolist(), g[:3, 3].tolist()  # the approach axis now points along -x
        ([-1.0, 0.0, 0.0], [0.1, -0.1, 0.045])
    """
    p = finite_array("gripper pose", [x, y, theta, z], (4,), "(x, y, theta, z) numbers")
    t = np.eye(4)
    t[:3, :3] = rotation_about_z(p[2])
    t[:3, 3] = [p[0], p[1], p[3]]
    return t


def invert_transform(t: np.ndarray) -> np.ndarray:
    """The inverse of a 4x4 rigid transform."""
    inv = np.eye(4)
    inv[:3, :3] = t[:3, :3].T
    inv[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return inv


def planar_pose(shelf_object: np.ndarray) -> tuple[float, float, float]:
    """(x, y, theta) of an object frame in the shelf frame: its origin's x and y and the heading of
    its x axis in the shelf's floor plane.

    Examples:
        >>> import math
        >>> from occrl.perception.frames import gripper_pose_matrix, planar_pose
        >>> [round(v, 6) for v in planar_pose(gripper_pose_matrix(0.1, 0.2, 0.3, z=0.05))]
        [0.1, 0.2, 0.3]
    """
    return float(shelf_object[0, 3]), float(shelf_object[1, 3]), math.atan2(shelf_object[1, 0], shelf_object[0, 0])


def tilt_deg(shelf_object: np.ndarray) -> float:
    """The angle (degrees) between an object frame's z axis and the shelf's up axis."""
    return math.degrees(math.acos(float(np.clip(shelf_object[2, 2], -1.0, 1.0))))


def rotation_angle_deg(r: np.ndarray) -> float:
    """The angle (degrees) of the 3x3 rotation ``r``; of ``a.T @ b``, the angle between rotations ``a`` and ``b``.

    Examples:
        >>> from occrl.perception.frames import rotation_angle_deg, rotation_about_z
        >>> round(rotation_angle_deg(rotation_about_z(0.5)), 4)  # 0.5 rad
        28.6479
    """
    return float(np.degrees(np.arccos(np.clip((np.trace(r) - 1) / 2, -1.0, 1.0))))


def angle_difference(a: float, b: float) -> float:
    """``a - b`` wrapped to [-pi, pi)."""
    return (a - b + math.pi) % (2 * math.pi) - math.pi
