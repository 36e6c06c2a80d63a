"""A privileged scripted retriever that clears the way first: it moves the objects in the corridor
to the target aside, one by one, then retrieves the target as :class:`ScriptedRetriever` does.

It is not a method of the paper. It is a teacher for imitation: every step is a straight,
predictable motion (as the scripted retriever's), and it rearranges clutter as the hierarchical
planner does (paper Alg. 3), but from the true state. It reads ``"privileged"`` entries, so it
must never be used where only perception is allowed.

Strategy, re-planned every step from the true state (closed loop):

1. Plan the target's approach with the fewest *blockers* (:func:`clearing_plan`, cached while the
   target does not move): objects whose bounding box, in the approach frame, reaches into the
   corridor the fingers sweep on the way in (``clear="band"``: the space between the fingers;
   ``clear="lanes"``: the fingers too), preferring blockers the fingers can take.
2. No blocker left: retrieve the target (the scripted retriever's steps).
3. Otherwise take the front-most blocker (reach and close as for the target), then carry it to
   a *spot* clear of the fingers' way to the target: back along the arm to a depth, then
   sideways, or straight there; spots are tried from the shortest carry up. A spot counts when
   the swept outlines of the object and the closed gripper touch nothing, the open gripper fits
   there and backs out freely (:func:`find_spot`); if none does, the cheapest carries are
   simulated in a pymunk world of the true state, pushing allowed (:func:`find_spot_by_simulation`).
   The gripper opens at the spot and backs out. A blocker without a spot is left to be pushed
   (as the scripted retriever does).
"""

from __future__ import annotations

import math

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import convex_hull, min_width, polygon_centroid, polygons_overlap, transform_points
from occrl.envs.scene import SceneObject
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons

from occrl.planners.recreate import RecreatedState, make_world

from occrl.baselines.scripted import (
    FIT_WIDTH,
    ScriptedRetriever,
    fingertips_inside,
    grasp_candidates,
    move_action,
    path_clear,
    plan_grasp,
    way_out,
)

__all__ = ["ClearingRetriever", "CLEARING_MODES", "clearing_plan", "find_spot", "find_spot_by_simulation"]

CLEARING_MODES = ("band", "lanes")
_LANE_MARGIN = 0.005  # a placed object keeps this far (m) from the fingers' way to the target
_CLEARANCE = 0.003  # swept outlines keep this far (m) from other objects and the walls
_MIN_CARRY_Y = 0.035  # a carried object's centroid stays this deep in the shelf (front edge: y = 0)
_AT_SPOT = 0.006  # the carried object is at its spot within this distance (m)
_SIDE_STEPS = np.arange(0.01, 0.301, 0.005)
_DEPTH_STEP = 0.02
_SIMULATED_TRIES = 30  # carries simulated when no spot is clear of everything
_MAX_CARRY_STEPS = 10


class ClearingRetriever(ScriptedRetriever):
    """Privileged scripted policy that moves blockers out of the target's corridor before the
    reach, writing ``"action"`` (see the module docstring).

    Args:
        lateral_tolerance: how well (m) the gripper must be lined up before it advances onto an object.
        clear: which objects count as blockers: ``"lanes"`` (anything the fingers would touch on
            the way in) or ``"band"`` (only what would end up between the fingers).
        simulate: when no spot is clear of everything, try the cheapest carries in a pymunk world
            of the true state (:func:`find_spot_by_simulation`) before giving up on the blocker.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.baselines.clearing import ClearingRetriever
        >>> env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False)
        >>> td = env.rollout(50, policy=ClearingRetriever())
        >>> bool(td["next", "success"].any())
        True
    """

    def __init__(self, lateral_tolerance: float = 0.006, clear: str = "band", simulate: bool = True) -> None:
        if clear not in CLEARING_MODES:
            raise ValueError(f"clear must be one of {CLEARING_MODES}, got {clear!r}")
        super().__init__(lateral_tolerance)
        self.clear = clear
        self.simulate = simulate
        self._spots: dict[tuple[bytes, int], tuple[np.ndarray, np.ndarray] | None] = {}  # carry legs by (target key, blocker)

    def reset(self) -> None:
        super().reset()
        self._spots.clear()

    @property
    def carries(self) -> int:
        """How many objects it has set out to carry aside (spots found) since the last reset."""
        return sum(legs is not None for legs in self._spots.values())

    def act(self, gripper_pose, closed: bool, held: bool, target: np.ndarray, clutter: list, key: bytes | None = None) -> np.ndarray:
        """The action for one world from the true target and clutter polygons (shelf frame)."""
        if held or key is None:
            return super().act(gripper_pose, closed, held, target, clutter, key)
        approach, grasp = self.grasp_plan(target, clutter, float(gripper_pose[2]), key)
        if closed:
            k = _object_between_fingers(gripper_pose, clutter)
            if k is None:  # a missed grasp, or the target (then ``held`` says so)
                return super().act(gripper_pose, closed, held, target, clutter, key)
            legs = self._carry_legs(key, k, gripper_pose, target, clutter, approach, grasp)
            if legs is None:  # nowhere to put it: let go and push through
                return np.array([0.0, 0.0, 0.0, -1.0])
            return _carry(gripper_pose, clutter[k], legs)
        lanes = _corridor_lanes(grasp, approach, self.clear)
        blockers = [k for k, poly in enumerate(clutter) if _in_lanes(poly, lanes) and min_width(poly) <= FIT_WIDTH]
        blockers = [k for k in blockers if self._spots.get((key, k), True) is not None]  # skip those without a spot
        if not blockers:
            return super().act(gripper_pose, closed, held, target, clutter, key)
        k = min(blockers, key=lambda j: _lane_coords(clutter[j], lanes)[2])  # the front-most
        others = [target, *(p for j, p in enumerate(clutter) if j != k)]
        return super().act(gripper_pose, closed, False, clutter[k], others, b"blocker" + key + bytes([k]))

    def plan(self, target: np.ndarray, clutter: list, heading: float) -> tuple[float, np.ndarray]:
        """Approach angle and grasp position for the target: :func:`clearing_plan`."""
        return clearing_plan(target, clutter, heading, self.clear)

    def _carry_legs(self, key, k, gripper_pose, target, clutter, approach, grasp):
        if (key, k) not in self._spots:
            if len(self._spots) > 4096:
                self._spots.clear()
            others = [target, *(p for j, p in enumerate(clutter) if j != k)]
            lanes = _corridor_lanes(grasp, approach, self.clear)
            legs = find_spot(gripper_pose, clutter[k], others, lanes)
            if legs is None and self.simulate:
                legs = find_spot_by_simulation(gripper_pose, k, target, clutter, lanes)
            self._spots[(key, k)] = legs
        return self._spots[(key, k)]


def clearing_plan(target: np.ndarray, clutter: list[np.ndarray], heading: float = 0.0, clear: str = "band") -> tuple[float, np.ndarray]:
    """The target's approach angle and grasp position with the fewest objects to carry aside:
    among the wall-free ways in (:func:`~occrl.baselines.scripted.grasp_candidates`, from
    ``heading`` outwards), the fewest blockers the fingers cannot take, then the fewest blockers,
    then the fewest objects in front of the fingers. Nothing fits: :func:`plan_grasp`'s choice."""
    graspable = np.array([min_width(p) <= FIT_WIDTH for p in clutter], bool)
    best = None
    for a, grasps, band, lanes in grasp_candidates(target, clutter, heading):
        blocked = lanes if clear == "lanes" else band
        costs = np.stack([blocked[~graspable].sum(0), blocked.sum(0), lanes.sum(0)], 1)
        for k in np.lexsort(costs.T[::-1]):  # cheapest first, centred first among equals
            cost = tuple(int(c) for c in costs[k])
            if best is not None and cost >= best[0]:
                break
            if path_clear(grasps[k], a):
                best = (cost, a, grasps[k])
                break
        if best is not None and best[0] == (0, 0, 0):
            break
    return (best[1], best[2]) if best is not None else plan_grasp(target, clutter, heading)


def _corridor_lanes(grasp: np.ndarray, approach: float, clear: str) -> tuple:
    """The corridor as (grasp, approach, half width, near end, far end) in the approach frame."""
    half = C.GRIPPER_STROKE / 2 + (C.FINGER_WIDTH if clear == "lanes" else 0.0)
    return grasp, approach, half, -way_out(grasp, approach), C.FINGER_LENGTH


def _lane_coords(poly: np.ndarray, lanes: tuple) -> tuple[float, float, float, float]:
    """Bounding box (u0, u1, v0, v1) of a polygon in the approach frame (u across, v along)."""
    grasp, approach, *_ = lanes
    p = transform_points(poly - grasp, (0.0, 0.0, -approach))
    return p[:, 0].min(), p[:, 0].max(), p[:, 1].min(), p[:, 1].max()


def _in_lanes(poly: np.ndarray, lanes: tuple, margin: float = 0.0) -> bool:
    _, _, half, near, far = lanes
    u0, u1, v0, v1 = _lane_coords(poly, lanes)
    return u1 > -half - margin and u0 < half + margin and v1 > near and v0 < far


def _object_between_fingers(gripper_pose, clutter: list) -> int | None:
    """The clutter object whose centroid lies between the fingers (the one the closed gripper holds)."""
    best, best_d = None, math.inf
    for k, poly in enumerate(clutter):
        c = transform_points(poly.mean(axis=0)[None] - gripper_pose[:2], (0.0, 0.0, -gripper_pose[2]))[0]
        if abs(c[0]) < C.GRIPPER_STROKE / 2 and 0.0 <= c[1] <= C.FINGER_LENGTH + 0.01:
            d = abs(c[0]) + abs(c[1] - C.FINGER_LENGTH / 2)
            if d < best_d:
                best, best_d = k, d
    return best


def _swept(polys: list[np.ndarray], shift: np.ndarray) -> list[np.ndarray]:
    """What each convex polygon sweeps when translated by ``shift``."""
    return [convex_hull(np.concatenate([p, p + shift])) for p in polys]


def _touches(polys: list[np.ndarray], obstacles: list[np.ndarray], clearance: float = _CLEARANCE) -> bool:
    return any(polygons_overlap(p, o, clearance) for p in polys for o in obstacles)


def _spot_candidates(gripper_pose, blocker: np.ndarray, lanes: tuple) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Carry legs (cost, first leg's end, spot) that leave the blocker clear of the corridor,
    cheapest first: back along the arm to a depth, then sideways; or straight to the spot."""
    th = float(gripper_pose[2])
    centre = blocker.mean(axis=0)
    back = np.array([math.sin(th), -math.cos(th)])  # the arm's way back
    candidates = []
    for depth in np.arange(centre[1], _MIN_CARRY_Y - 1e-9, -_DEPTH_STEP):
        start = centre + back * (centre[1] - depth) / max(math.cos(th), 0.3)
        for side in np.concatenate([_SIDE_STEPS, -_SIDE_STEPS]):
            end = start + [side, 0.0]
            if not _in_lanes(blocker + (end - centre), lanes, _LANE_MARGIN):
                candidates.append((float(np.linalg.norm(start - centre) + abs(side)), start, end))
                candidates.append((float(np.linalg.norm(end - centre)), centre, end))  # straight there
    candidates.sort(key=lambda c: c[0])
    return candidates


def _held_opening(gripper_pose, blocker: np.ndarray) -> float:
    """How far apart the closed fingers stand on a held object (its width across the gripper axis)."""
    local = transform_points(blocker - np.asarray(gripper_pose[:2], float), (0.0, 0.0, -float(gripper_pose[2])))
    return float(local[:, 0].max() - local[:, 0].min())


def find_spot(gripper_pose, blocker: np.ndarray, others: list[np.ndarray], lanes: tuple) -> tuple[np.ndarray, np.ndarray] | None:
    """Where to carry a held blocker: the two carry legs' ends (blocker centroid after backing
    along the arm, then after the sideways move), or None when no spot is found. Spots clear of
    the corridor are tried from the shortest carry up; a spot counts when the swept outlines touch
    nothing (see the module docstring)."""
    x, y, th = (float(v) for v in gripper_pose)
    centre = blocker.mean(axis=0)
    offset = np.array([x, y]) - centre  # the gripper relative to the carried object
    palm, left, right, _ = gripper_polygons(_held_opening(gripper_pose, blocker))
    open_parts = gripper_polygons(C.GRIPPER_STROKE)[:3]
    walls = list(SHELF_WALLS)
    back = np.array([math.sin(th), -math.cos(th)])
    held_parts = [transform_points(p, (x, y, th)) for p in (palm, left, right)]
    for _, start, end in _spot_candidates(gripper_pose, blocker, lanes):
        shift1, shift2 = start - centre, end - start
        leg1 = _swept([blocker, *held_parts], shift1)
        if _touches(leg1, others, 0.001):
            continue
        leg2 = _swept([blocker + shift1, *(p + shift1 for p in held_parts)], shift2)
        if _touches(leg2, others) or _touches(leg2, walls):
            continue
        release = (*(end + offset), th)
        opened = [transform_points(p, release) for p in open_parts]
        if _touches(opened, others + walls, 0.001):
            continue
        out = way_out(np.array(release[:2]), th)
        if _touches(_swept(opened, back * out), others, 0.001):
            continue
        return start, end
    return None


def find_spot_by_simulation(
    gripper_pose, index: int, target: np.ndarray, clutter: list[np.ndarray], lanes: tuple, tries: int = _SIMULATED_TRIES
) -> tuple[np.ndarray, np.ndarray] | None:
    """Where to carry held ``clutter[index]`` when no spot is clear of everything: the cheapest
    ``tries`` carries (the candidates :func:`find_spot` tries) are simulated in a pymunk world of the true state
    (pushing allowed), with the release and the way back out; the first after which nothing was
    dropped, the target stayed put (within 5 mm), the blocker lies clear of the corridor and no
    other object was pushed into it wins. None if none does."""
    polygons = [target, *clutter]
    objects = [
        SceneObject(type_id=i + 1, vertices=p - polygon_centroid(p), pose=(*polygon_centroid(p), 0.0), is_target=i == 0)
        for i, p in enumerate(polygons)
    ]
    state = RecreatedState(
        tuple(objects), tuple(float(v) for v in gripper_pose), _held_opening(gripper_pose, clutter[index]), True, 1, objects[0].vertices
    )
    world = make_world(state)
    if world.held != index + 1:
        return None  # the simulator does not see it held
    snap = world.snapshot()
    local = [o.vertices for o in objects]
    blocked_before = {j for j, p in enumerate(clutter) if j != index and _in_lanes(p, lanes)}

    def polygons_now() -> list[np.ndarray]:
        return [transform_points(v, pose) for v, pose in zip(local, world.object_poses())]

    for _, start, end in _spot_candidates(gripper_pose, clutter[index], lanes)[:tries]:
        world.restore(snap)
        ok = False
        for _step in range(_MAX_CARRY_STEPS):
            action = _carry(world.gripper_pose(), polygons_now()[index + 1], (start, end))
            outcome = world.step(action)
            if outcome.dropped:
                break
            if action[3] < 0:  # released: back out of the shelf
                for _back in range(_MAX_CARRY_STEPS):
                    if not fingertips_inside(world.gripper_pose()):
                        break
                    if world.step(np.array([-1.0, 0.0, 0.0, -1.0])).dropped:
                        break
                else:
                    break
                ok = not fingertips_inside(world.gripper_pose())
                break
        if not ok:
            continue
        now = polygons_now()
        if np.linalg.norm(polygon_centroid(now[0]) - polygon_centroid(target)) > 0.005:
            continue
        if _in_lanes(now[index + 1], lanes):
            continue
        if any(_in_lanes(p, lanes) and j not in blocked_before for j, p in enumerate(now[1:]) if j != index):
            continue
        return start, end
    return None


def _carry(gripper_pose, blocker: np.ndarray, legs: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """One step of the carry: back along the arm to the first leg's end, then sideways, then open."""
    start, end = legs
    centre = blocker.mean(axis=0)
    if np.linalg.norm(end - centre) < _AT_SPOT:
        return np.array([0.0, 0.0, 0.0, -1.0])
    goal = end if centre[1] <= start[1] + 0.004 else start
    return move_action(float(gripper_pose[2]), goal - centre, 0.0, grip=1.0)
