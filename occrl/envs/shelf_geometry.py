"""The shelf's fixed geometry: its walls and the gripper's outline (in the gripper's frame), and the
pose algebra the worlds, the renderer and the planners share. A leaf module: no occrl imports but
the constants, so scenes, worlds and planners all import it without cycles.
"""

from __future__ import annotations

import math

import numpy as np

from occrl.envs import world_constants as C

__all__ = ["gripper_polygons", "gripper_polygons_batch", "wall_polygons", "SHELF_WALLS", "beyond_walls", "inverse_pose"]


def gripper_polygons(opening: float) -> list[np.ndarray]:
    """Gripper outline in its own frame: palm, left finger, right finger, forearm (CCW boxes).

    Examples:
        >>> from occrl.envs.shelf_geometry import gripper_polygons
        >>> palm, left, right, forearm = gripper_polygons(0.085)
        >>> round(float(right[:, 0].min() - left[:, 0].max()), 3)  # the gap between the fingers
        0.085
    """
    h = opening / 2.0
    return [
        _box(-C.PALM_WIDTH / 2, -C.PALM_DEPTH, C.PALM_WIDTH / 2, 0.0),
        _box(-h - C.FINGER_WIDTH, 0.0, -h, C.FINGER_LENGTH),
        _box(h, 0.0, h + C.FINGER_WIDTH, C.FINGER_LENGTH),
        _box(-C.FOREARM_WIDTH / 2, -C.PALM_DEPTH - C.FOREARM_LENGTH, C.FOREARM_WIDTH / 2, -C.PALM_DEPTH),
    ]


def gripper_polygons_batch(openings: np.ndarray) -> np.ndarray:
    """:func:`gripper_polygons` of many openings (B,) at once: (B, 4 parts, 4 corners, 2), the
    same values (the closed outline's fingers moved by -h and +h: ``-h + (-w)`` is ``-h - w``).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.shelf_geometry import gripper_polygons_batch
        >>> parts = gripper_polygons_batch(np.array([0.085, 0.02]))
        >>> parts.shape, (parts[:, 2, 0, 0] - parts[:, 1, 1, 0]).round(3).tolist()  # each gap between the fingers
        ((2, 4, 4, 2), [0.085, 0.02])
    """
    h = np.asarray(openings, dtype=float).reshape(-1, 1) / 2.0
    parts = np.repeat(_CLOSED_GRIPPER[None], len(h), axis=0)
    parts[:, 1, :, 0] = -h + _CLOSED_GRIPPER[1, :, 0]
    parts[:, 2, :, 0] = h + _CLOSED_GRIPPER[2, :, 0]
    return parts


def wall_polygons() -> list[np.ndarray]:
    """Left, right and back wall of the shelf in the shelf frame.

    Examples:
        >>> from occrl.envs.shelf_geometry import wall_polygons
        >>> left, right, back = wall_polygons()
        >>> float(back[:, 1].min())  # the back wall starts at the shelf depth
        0.35
    """
    w, d, t = C.SHELF_HALF_WIDTH, C.SHELF_DEPTH, C.WALL_THICKNESS
    return [
        _box(-w - t, 0.0, -w, d + t),
        _box(w, 0.0, w + t, d + t),
        _box(-w - t, d, w + t, d + t),
    ]


def beyond_walls(poses: np.ndarray) -> bool:
    """Whether a centroid of ``poses`` (n, 2 or 3) lies beyond the back wall, or beyond a side wall
    level with the shelf (in front of the shelf, y < 0, an object is off it, not through a wall).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.shelf_geometry import beyond_walls
        >>> bool(beyond_walls(np.array([[0.0, 0.36, 0.0]]))), bool(beyond_walls(np.array([[0.3, -0.1, 0.0]])))
        (True, False)
    """
    x, y = poses[:, 0], poses[:, 1]
    return bool(np.any((y > C.SHELF_DEPTH) | ((y >= C.FRONT_EDGE_Y) & (np.abs(x) > C.SHELF_HALF_WIDTH))))


def _box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


_CLOSED_GRIPPER = np.stack(gripper_polygons(0.0))  # gripper_polygons_batch moves its fingers apart

# The shelf's walls, computed once (left, right, back; read-only by convention).
SHELF_WALLS = tuple(wall_polygons())


def inverse_pose(pose) -> tuple[float, float, float]:
    """The pose that maps shelf-frame points into the frame of ``pose``.

    Examples:
        >>> import math
        >>> from occrl.envs.geometry import transform_points
        >>> from occrl.envs.shelf_geometry import inverse_pose
        >>> pose = (0.1, 0.2, math.pi / 2)
        >>> transform_points([[0.1, 0.2]], inverse_pose(pose)).round(6).tolist()  # the pose's origin
        [[0.0, 0.0]]
    """
    x, y, th = (float(v) for v in pose)
    c, s = math.cos(th), math.sin(th)
    return (-(c * x + s * y), -(-s * x + c * y), -th)
