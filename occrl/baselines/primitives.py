"""The hierarchical baseline's hand-crafted primitives (paper Alg. 3): which object Rearrange
moves and where to, and how Move_out backs out of the shelf. They read only the state recreated
from accumulated detections; :class:`~occrl.baselines.hierarchical.HierarchicalPlanner` calls
them from its state machine.

* Move_out: back out of the shelf with the gripper open. Candidate motions (straight back,
  back along the arm, back while turning to face the shelf, sideways then back) are simulated in
  the recreated world and the shortest one that drops nothing, keeps out of the walls and (target
  unlocated) out of the hiding region is executed.
* Choices for Rearrange: the known non-target object nearest to the gripper (objects already
  moved last); a free spot in the back rows, clear of known objects, outside the hiding region,
  preferring a straight way there that crosses no known object and the least hiding region.
"""

from __future__ import annotations

import logging
import math
from typing import Iterable

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import point_in_convex_polygon, polygons_overlap, transform_points
from occrl.planners.recreate import RecreatedState, make_world

from occrl.baselines.hiding import HidingRegion
from occrl.baselines.object_memory import KnownObject
from occrl.baselines.motion import (
    OPEN,
    OUT_Y,
    STROKE_HALF,
    count_intrusions,
    is_at,
    is_inside_shelf,
    motion_allowed,
    steer_action,
)

__all__ = ["closest_object", "free_spot", "move_out"]

logger = logging.getLogger("occrl.baselines.hierarchical")


def closest_object(known: Iterable[KnownObject], rearranged: set, pose: np.ndarray) -> int | None:
    """Rearrange's choice: the type id of the known non-target object closest to the gripper
    (not yet rearranged, if possible); None if no object is known."""
    cands = [k for k in known if not k.is_target]
    fresh = [k for k in cands if k.type_id not in rearranged]
    cands = fresh or cands
    if not cands:
        return None
    return min(cands, key=lambda k: math.hypot(k.pose[0] - pose[0], k.pose[1] - pose[1])).type_id


def free_spot(state: RecreatedState, i: int, hiding: HidingRegion | None) -> np.ndarray | None:
    """Rearrange's destination: a spot at the back of the shelf for ``state.objects[i]``
    (current orientation), clear of the
    known objects by 1.5 cm and far enough from the side walls for the fingers. Preference,
    in order: the spot is outside the region where the unlocated target may hide; the
    straight corridor from the object to the spot (gripper width) crosses no known object;
    it crosses the least hiding region; the back row; the shortest way."""
    obj = state.objects[i]
    others = [o.world_vertices() for j, o in enumerate(state.objects) if j != i]
    r = float(np.linalg.norm(obj.vertices, axis=1).max())
    xmax = C.SHELF_HALF_WIDTH - max(r, STROKE_HALF + C.FINGER_WIDTH) - 0.01
    half = max(r, STROKE_HALF + C.FINGER_WIDTH) * 0.8
    start = np.asarray(obj.pose[:2], float)
    best, best_key = None, None
    for y in (C.SHELF_DEPTH - r - 0.015, C.SHELF_DEPTH - r - 0.065):
        for x in np.arange(-xmax, xmax + 1e-9, 0.01):
            poly = transform_points(obj.vertices, (x, y, obj.pose[2]))
            if any(polygons_overlap(poly, o, clearance=0.015) for o in others):
                continue
            spot = np.array([x, y])
            d = spot - start
            length = float(np.hypot(*d))
            n = np.array([-d[1], d[0]]) / max(length, 1e-9)
            steps = np.linspace(0.0, 1.0, max(2, int(length / 0.01)))[:, None]
            corridor = np.concatenate([start + steps * d + k * half * n for k in (-1.0, 0.0, 1.0)])
            blocked = sum(bool(point_in_convex_polygon(corridor, o).any()) for o in others)
            in_hiding = hiding is not None and bool(hiding(np.vstack([poly, spot])).any())
            crossing = 0 if hiding is None else int(hiding(corridor).sum())
            key = (in_hiding, blocked, crossing, y < C.SHELF_DEPTH - r - 0.04, length)
            if best_key is None or key < best_key:
                best, best_key = spot, key
    return best


def move_out(
    state: RecreatedState, pose: np.ndarray, forbidden: HidingRegion | None, search_y: float
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Move_out: back out of the shelf with the gripper open, to ``search_y`` at most.
    Candidate motions are tried in the simulator of the known state (closed-loop steering):
    straight back (world -y, heading kept), back along the gripper's own axis, straight back
    while turning to face the shelf, and 3 or 6 cm sideways (towards the centre first) then
    straight back; the shortest that drops nothing, keeps out of the walls and (target
    unlocated) out of the hiding region is executed open-loop. Returns its actions and the
    simulated gripper pose after each. ``forbidden``: the region the unlocated target may hide in.

    Examples:
        >>> import numpy as np
        >>> from occrl.baselines.primitives import move_out
        >>> from occrl.planners import RecreatedState
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, 0.15, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> actions, poses = move_out(state, np.array([0.0, 0.15, 0.0]), None, search_y=-0.1)
        >>> bool(poses[-1][1] < 0.0), all(a[3] < 0 for a in actions)  # out of the shelf, gripper open
        (True, True)
    """
    world = make_world(state)
    forbidden = None if forbidden is None or forbidden.empty else forbidden
    start = world.snapshot()
    baseline = None
    if forbidden is not None:
        baseline = count_intrusions(world.gripper_pose(), world.opening, world.nominal_vertices, world.object_poses(), forbidden)
    out_y = min(search_y, OUT_Y - 0.005)
    x, y, th = (float(v) for v in pose)
    toward_centre = -1.0 if x > 0 else 1.0
    candidates = {
        "straight back": [(x, out_y, th)],
        "along the arm": None,
        "back and turn": [(x, out_y, 0.0)],
    }
    for dx in (0.03, 0.06):
        for sign in (toward_centre, -toward_centre):
            candidates[f"sideways {sign * dx:+.2f} then back"] = [(x + sign * dx, y, th), (x + sign * dx, out_y, th)]
    best, best_poses = None, []
    for name, waypoints in candidates.items():
        world.restore(start)
        actions, poses, ok, k = [], [], True, 0
        while is_inside_shelf(world.gripper_pose()) and len(actions) < 15 and (best is None or len(actions) < len(best)):
            p = world.gripper_pose()
            if waypoints is None:
                a = np.array([-1.0, 0.0, 0.0, OPEN])
            else:
                while k < len(waypoints) - 1 and is_at(p, waypoints[k], tol_xy=2e-3, tol_th=math.radians(1.0)):
                    k += 1
                a = steer_action(p, waypoints[k], OPEN)
            out = world.step(a)
            actions.append(a)
            poses.append(world.gripper_pose())
            allowed = motion_allowed(world.gripper_pose(), world.opening, world.nominal_vertices, world.object_poses(), forbidden, baseline)
            if out.dropped or not allowed:
                ok = False
                break
        if ok and not is_inside_shelf(world.gripper_pose()) and (best is None or len(actions) < len(best)):
            best, best_poses = actions, poses
    if best is None:
        logger.warning("move out: every candidate motion collides in the simulator; backing straight out")
        world.restore(start)
        best, best_poses = [], []
        while is_inside_shelf(world.gripper_pose()) and len(best) < 15:
            best.append(steer_action(world.gripper_pose(), candidates["straight back"][0], OPEN))
            world.step(best[-1])
            best_poses.append(world.gripper_pose())
    if not best:
        return [np.array([0.0, 0.0, 0.0, OPEN])], [np.asarray(pose, float)]
    return best, best_poses
