"""Motion primitives and validity of the hierarchical baseline's plans: straight closed-loop
steering, where the gripper is, the grasp rule with margins, and what a simulated state may not do
(penetrate a wall, enter the region where an unlocated target may hide).

Used by the goals (:mod:`occrl.baselines.goals`), the OMPL problem
(:mod:`occrl.baselines.kinodynamic`) and the planner's hand-crafted primitives
(:mod:`occrl.baselines.hierarchical`).
"""

from __future__ import annotations

import math

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import polygons_overlap, transform_points
from occrl.envs.remembered import STALE_OVERLAP  # one staleness rule for every memory of detections
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons, inverse_pose

from occrl.baselines.hiding import probe_points

__all__ = [
    "WALL_TOLERANCE",
    "OPEN",
    "CLOSE",
    "STROKE_HALF",
    "OUT_Y",
    "STALE_OVERLAP",
    "steer_action",
    "is_at",
    "is_inside_shelf",
    "between_fingers",
    "count_intrusions",
    "motion_allowed",
]

WALL_TOLERANCE = 0.003  # m of wall penetration that counts as invalid
OPEN = -1.0
CLOSE = 1.0
_WALL_BOXES = [(w[:, 0].min(), w[:, 0].max(), w[:, 1].min(), w[:, 1].max()) for w in SHELF_WALLS]
STROKE_HALF = C.GRIPPER_STROKE / 2
OUT_Y = -0.07  # gripper origin behind this line (and the heading within 45 deg): no part is in the shelf


def steer_action(pose, target, grip: float) -> np.ndarray:
    """The action that moves the gripper straight towards ``target`` (x, y, theta) at full speed:
    the world-frame displacement is converted to the gripper frame and all three motion entries
    are scaled by the same factor so that the largest is at most 1 (a straight line).

    Examples:
        >>> from occrl.baselines.motion import CLOSE, OPEN, steer_action
        >>> steer_action((0.0, 0.0, 0.0), (0.1, 0.0, 0.0), OPEN).tolist()  # 10 cm right: a full lateral step
        [0.0, 1.0, 0.0, -1.0]
        >>> steer_action((0.0, 0.0, 0.0), (0.0, 0.02, 0.0), CLOSE).round(3).tolist()  # 2 cm of a 5 cm step
        [0.4, 0.0, 0.0, 1.0]
    """
    x, y, th = (float(v) for v in pose)
    dx, dy = float(target[0]) - x, float(target[1]) - y
    c, s = math.cos(th), math.sin(th)
    fwd, lat = -s * dx + c * dy, c * dx + s * dy
    a = np.array([fwd / C.MAX_FORWARD, lat / C.MAX_LATERAL, (float(target[2]) - th) / C.MAX_ROTATION])
    a /= max(1.0, float(np.abs(a).max()))
    return np.array([a[0], a[1], a[2], grip])


def is_at(pose, target, tol_xy: float = 1e-3, tol_th: float = math.radians(0.5)) -> bool:
    return math.hypot(pose[0] - target[0], pose[1] - target[1]) < tol_xy and abs(pose[2] - target[2]) < tol_th


def is_inside_shelf(pose) -> bool:
    """Some part of the (open) gripper may be in the shelf."""
    return pose[1] > OUT_Y or abs(pose[2]) > math.pi / 4


def between_fingers(gripper_pose, opening, vertices, object_poses, index, margin, palm_gap: float = 0.002) -> bool:
    """The grasp rule (:func:`~occrl.envs.pymunk2d.fingers.grasp_candidate`) for one object, with margins,
    and the object ``palm_gap`` clear of the palm (not being pushed)."""
    h = opening / 2.0
    inv = inverse_pose(gripper_pose)
    band = np.array([[-h, 0.0], [h, 0.0], [h, C.FINGER_LENGTH], [-h, C.FINGER_LENGTH]])
    local = transform_points(transform_points(vertices[index], object_poses[index]), inv)
    xmin, xmax = local[:, 0].min(), local[:, 0].max()
    cy = local[:, 1].mean()
    if not (xmin > -h + margin and xmax < h - margin and xmin < -margin and xmax > margin):
        return False
    if not (margin <= cy <= C.FINGER_LENGTH - margin) or local[:, 1].min() < palm_gap:
        return False
    for j, (v, p) in enumerate(zip(vertices, object_poses)):
        if j == index:
            continue
        if math.hypot(p[0] - gripper_pose[0], p[1] - gripper_pose[1]) > 0.2:
            continue
        other = transform_points(transform_points(v, p), inv)
        if polygons_overlap(other, band, clearance=0.001):
            return False
    return True


def count_intrusions(gripper_pose, opening, vertices, object_poses, forbidden) -> np.ndarray:
    """How many probe points of the gripper (entry 0) and of each object (centroid and vertices)
    lie in the ``forbidden`` region."""
    parts = [transform_points(probe_points(opening), gripper_pose)]
    parts += [transform_points(np.vstack([v, v.mean(axis=0)]), p) for v, p in zip(vertices, object_poses)]
    inside = forbidden(np.concatenate(parts))
    return np.add.reduceat(inside.astype(int), np.cumsum([0] + [len(q) for q in parts[:-1]]))


def motion_allowed(gripper_pose, opening, vertices, object_poses, forbidden=None, baseline=None) -> bool:
    """No part of the gripper or object penetrates a wall by more than ``WALL_TOLERANCE`` and,
    with a ``forbidden`` region, none of them is further in it than in the ``baseline`` counts
    of :func:`count_intrusions` (the start state: touching it there is not the plan's doing)."""
    if forbidden is not None:
        counts = count_intrusions(gripper_pose, opening, vertices, object_poses, forbidden)
        if np.any(counts > (0 if baseline is None else baseline)):
            return False
    polys = [transform_points(p, gripper_pose) for p in gripper_polygons(opening)]
    polys += [transform_points(v, p) for v, p in zip(vertices, object_poses)]
    tol = WALL_TOLERANCE
    for poly in polys:
        x0, y0 = poly.min(axis=0)
        x1, y1 = poly.max(axis=0)
        for (wx0, wx1, wy0, wy1), wall in zip(_WALL_BOXES, SHELF_WALLS):
            if x1 < wx0 + tol or x0 > wx1 - tol or y1 < wy0 + tol or y0 > wy1 - tol:
                continue  # bounding boxes overlap less than the tolerance
            if polygons_overlap(poly, wall, clearance=-tol):
                return False
    return True
