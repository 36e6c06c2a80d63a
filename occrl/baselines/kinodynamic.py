"""OMPL kinodynamic planning in the pymunk shelf world (the low level of the hierarchical baseline).

OMPL formulation (:class:`SimControlProblem`):

* State space: compound of SE2 (the gripper pose; bounds = the arm's workspace; rotation weight
  0.1, so 15 degrees weigh like 2.6 cm), R^2 *features* of the manipulated object (reach: its
  centre in the gripper frame; extract/place: its position; weight 1, so that nearest neighbours
  tell apart states whose gripper poses agree but whose object was pushed away) and R^1 holding
  an *index into a Python-side table of world snapshots* (weight 0). The propagator restores the
  parent's snapshot (:meth:`ShelfWorld.restore`, bit-exact), steps the real pymunk physics with
  the control, appends the child's snapshot to the table and writes its index, gripper pose and
  features into the child state. The OMPL state stays small while the full physical state is
  exact and deterministic: the same state and control always give the same child.
* Control space: the 4-number action ``[forward, lateral, rotation, gripper]``, bounds [-1, 1]
  except the gripper entry, bounded to the query's mode (open: [-1, -0.5]; closed: [0.5, 1]). One
  control is one env step (propagation step size 1, control duration 1).
* Validity: invalid if an object left the shelf (a drop) or the gripper or an object penetrates a
  wall by more than ``WALL_TOLERANCE``; while the target is unlocated (Rearrange, Move_out), also
  if the gripper's outline or an object enters the :class:`HidingRegion`, where the hidden target
  may be (pushing through it would push the target).
* Goals are regions (:class:`ompl.base.GoalSampleableRegion`): ``distanceGoal`` is 0 inside the
  region, else a heuristic distance; ``sampleGoal`` gives a heuristic state for RRT's goal bias
  (reach: a grasp pose from :func:`grasp_poses`, kept relative to the object; extract/place: the
  start pose moved by what the object has to move).
* Planner: ``oc.RRT`` (default; goal bias 0.25) or ``oc.KPIECE1`` (projection: the SE2 part's
  default, x and y), stopped by a timed termination condition and restarted with a fresh tree
  every ``restart_seconds`` (0.75 s; run times are heavy-tailed) until the query's budget
  ``plan_seconds`` is spent. OMPL is re-seeded for every attempt, so an attempt is a function of
  its seed (only where the time slices end depends on the machine). No exact solution in the
  budget is a logged failure (logger ``occrl.baselines.hierarchical``, WARNING); the robot then
  moves out and searches again.
* Shortcutting (post-processing in the same simulator; random controls make RRT paths long and an
  episode has 50 actions): from the earliest path state on, straight closed-loop steering to the
  solution's final gripper pose, or to the best heuristic goal poses, directly or through a
  pre-pose on the approach line; the shortest attempt that reaches the goal region through valid
  states replaces the rest of the path (up to another 25 % of the budget, at least 0.2 s). The
  final action list is replayed from the start snapshot to confirm validity and the goal, and its
  end state becomes the robot's prediction of the objects it no longer sees.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import polygons_overlap, transform_points
from occrl.envs.world import ShelfWorld, gripper_polygons, inverse_pose, wall_polygons

try:  # OMPL 2.x (nanobind bindings)
    from ompl import base as ob
    from ompl import control as oc
    from ompl import util as ou

    ou.setLogLevel(ou.LogLevel.LOG_WARN)
except ImportError:  # pragma: no cover - the baseline needs OMPL
    ob = oc = ou = None

from occrl.baselines.hiding import HidingRegion, _probe_points

__all__ = [
    "SimControlProblem",
    "PlanResult",
    "ReachGoal",
    "HoldGoal",
    "grasp_poses",
    "steer_action",
    "ompl_seed",
    "OPEN",
    "CLOSE",
    "WALL_TOLERANCE",
]

logger = logging.getLogger("occrl.baselines.hierarchical")

WALL_TOLERANCE = 0.003  # m of wall penetration that counts as invalid
OPEN = -1.0
CLOSE = 1.0
_WALLS = wall_polygons()
_WALL_BOXES = [(w[:, 0].min(), w[:, 0].max(), w[:, 1].min(), w[:, 1].max()) for w in _WALLS]
_STROKE_HALF = C.GRIPPER_STROKE / 2
_OUT_Y = -0.07  # gripper origin behind this line (and |theta| <= 45 deg): no part is in the shelf
_MAX_GRASP_ANGLE = math.radians(50.0)  # reach goals: grasps with the arm turned at most this much
_STALE_OVERLAP = 0.005  # a remembered object overlapping a fresher one or the gripper deeper than this is stale


def ompl_seed(seed: int) -> None:
    """Seed OMPL's random numbers: every sampler and planner made afterwards draws its seed from
    this. (OMPL complains when seeds were drawn before; that message is silenced: re-seeding
    before each query is what makes a query a function of its seed.)

    Examples:
        >>> from ompl import util as ou
        >>> from occrl.baselines.kinodynamic import ompl_seed
        >>> ompl_seed(5); a = ou.RNG().uniform01()
        >>> ompl_seed(5); b = ou.RNG().uniform01()
        >>> ompl_seed(6); c = ou.RNG().uniform01()
        >>> a == b, a == c
        (True, False)
    """
    ou.noOutputHandler()
    try:
        ou.RNG.setSeed(int(seed) % (2**31 - 1) + 1)  # OMPL refuses seed 0
    finally:
        ou.restorePreviousOutputHandler()


# ====================================================================== motion primitives
def steer_action(pose, target, grip: float) -> np.ndarray:
    """The action that moves the gripper straight towards ``target`` (x, y, theta) at full speed:
    the world-frame displacement is converted to the gripper frame and all three motion entries
    are scaled by the same factor so that the largest is at most 1 (a straight line).

    Examples:
        >>> from occrl.baselines.kinodynamic import CLOSE, OPEN, steer_action
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


def _at(pose, target, tol_xy: float = 1e-3, tol_th: float = math.radians(0.5)) -> bool:
    return math.hypot(pose[0] - target[0], pose[1] - target[1]) < tol_xy and abs(pose[2] - target[2]) < tol_th


def _inside(pose) -> bool:
    """Some part of the (open) gripper may be in the shelf."""
    return pose[1] > _OUT_Y or abs(pose[2]) > math.pi / 4


# ====================================================================== goals
def _compose(a, b) -> np.ndarray:
    """Pose ``b`` (given in the frame of pose ``a``) in the frame ``a`` is given in."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])


class _GoalSpec:
    """A goal region on the simulator state (a table entry), with what the planner needs besides:
    two *features* of a state that join the gripper pose in the OMPL state (so that nearest
    neighbours tell apart states whose gripper poses agree but whose objects do not), their
    bounds, a heuristic distance outside the region, and goal samples (gripper pose, features)."""

    name = "goal"
    feature_bounds = ((-0.4, 0.4), (-0.3, 0.6))

    def satisfied(self, e: "_Entry") -> bool:  # pragma: no cover - interface
        raise NotImplementedError

    def distance(self, e: "_Entry") -> float:  # pragma: no cover - interface
        raise NotImplementedError

    def features(self, e: "_Entry") -> tuple[float, float]:  # pragma: no cover - interface
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, tuple[float, float]]:  # pragma: no cover - interface
        raise NotImplementedError


class ReachGoal(_GoalSpec):
    """Object ``index`` alone between the open fingers, ``margin`` inside the grasp rule: lying
    across the axis with ``margin`` to either finger, its centre ``margin`` within the fingers.

    ``grasp_poses`` (world frame, best first, for the object at ``object_pose``) are heuristic
    gripper poses in the region; they are kept relative to the object, so they follow it when it
    is pushed. Features: the object's centre in the gripper frame. Goal samples are drawn from the
    grasp poses (the best most often); the distance outside the region is to the nearest one.

    Examples:
        >>> from occrl.baselines.kinodynamic import OPEN, ReachGoal, SimControlProblem, grasp_poses
        >>> from occrl.envs import Scene, ShelfWorld
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> world = ShelfWorld(Scene.from_objects([{"vertices": box, "pose": (0.0, 0.15, 0.0), "is_target": True}],
        ...                                       gripper_pose=(0.0, -0.1, 0.0)))
        >>> goal = ReachGoal(0, world.nominal_vertices, grasp_poses(world, 0), world.object_poses()[0])
        >>> problem = SimControlProblem(world, goal, grip=OPEN)
        >>> start = problem.table[0]  # the start state's simulator entry
        >>> goal.name, goal.satisfied(start), round(float(goal.distance(start)), 3)  # 22.5 cm from the best grasp
        ('reach', False, 0.226)
        >>> problem.close()  # frees the OMPL objects, which reference the problem from C++
    """

    name = "reach"
    feature_bounds = ((-1.0, 1.0), (-1.0, 1.0))

    def __init__(self, index: int, vertices: list[np.ndarray], grasp_poses, object_pose, margin: float = 0.003) -> None:
        self.index = int(index)
        self.vertices = vertices
        self.margin = margin
        grasps = np.atleast_2d(np.asarray(grasp_poses, float))
        inv = inverse_pose(object_pose)
        self.relative = np.array([_compose(inv, g) for g in grasps])  # grasp poses in the object frame
        self.grasp_poses = grasps
        w = 1.0 / (1.0 + np.arange(len(grasps)))
        self._p = w / w.sum()

    def satisfied(self, e: "_Entry") -> bool:
        if e.closed or e.opening < C.GRIPPER_STROKE - 1e-6 or abs(e.gripper_pose[2]) > _MAX_GRASP_ANGLE:
            return False
        return _between_fingers(e.gripper_pose, e.opening, self.vertices, e.object_poses, self.index, self.margin)

    def distance(self, e: "_Entry") -> float:
        if self.satisfied(e):
            return 0.0
        obj = e.object_poses[self.index]
        best = math.inf
        for rel in self.relative:
            g = _compose(obj, rel)
            d = math.hypot(g[0] - e.gripper_pose[0], g[1] - e.gripper_pose[1]) + 0.1 * abs(g[2] - e.gripper_pose[2])
            best = min(best, d)
        return 1e-3 + best

    def features(self, e: "_Entry") -> tuple[float, float]:
        p = transform_points(e.object_poses[self.index][None, :2], inverse_pose(e.gripper_pose))[0]
        return float(p[0]), float(p[1])

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, tuple[float, float]]:
        k = rng.choice(len(self.relative), p=self._p)
        pose = self.grasp_poses[k] + rng.normal(0.0, [0.003, 0.003, 0.02])
        f = _compose(inverse_pose(self.relative[k]), np.zeros(3))  # the object in the grasp frame
        return pose, (float(f[0]), float(f[1]))


def grasp_poses(world: ShelfWorld, index: int, prefer_angle: float = 0.0, limit: int = 8, margin: float = 0.004) -> np.ndarray:
    """Gripper poses (best first) where object ``index`` would be alone between the open fingers
    (the grasp rule with ``margin``) with no part of the gripper touching the object itself or a
    wall, in the world's current configuration. Candidates: approach angles
    within 45 degrees, lateral offsets up to 3 cm, the palm 5 mm short of the object; ranked by
    turn from ``prefer_angle`` and offset, poses whose palm or forearm would have to push another
    object after the collision-free ones. Falls back to
    :func:`~occrl.baselines.scripted.plan_grasp`'s pose when nothing fits.

    Examples:
        >>> from occrl.baselines.kinodynamic import grasp_poses
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs import world_constants as C
        >>> from occrl.envs.world import grasp_candidate
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> world = ShelfWorld(Scene.from_objects([{"vertices": box, "pose": (0.0, 0.15, 0.0), "is_target": True}]))
        >>> poses = grasp_poses(world, 0)
        >>> poses.shape, poses[0].round(3).tolist()  # best first: straight on, palm 5 mm short of the box
        ((8, 3), [0.0, 0.125, 0.0])
        >>> grasp_candidate(poses[0], C.GRIPPER_STROKE, world.object_world_polygons())[0]  # closing there holds it
        0
    """
    from occrl.baselines.scripted import plan_grasp

    poses = world.object_poses()
    polys = world.object_world_polygons()
    target = polys[index]
    centre = target.mean(axis=0)
    parts = gripper_polygons(C.GRIPPER_STROKE)
    found = []  # (class, score, order, pose); class 0: collision-free, 1: the palm or forearm pushes something
    angles = np.radians(np.arange(-45.0, 45.1, 5.0))
    for a in angles[np.argsort(np.abs(angles - prefer_angle), kind="stable")]:
        a = float(a)
        local = transform_points(target - centre, (0.0, 0.0, -a))  # object in an approach frame at its centre
        xmid = 0.5 * (local[:, 0].min() + local[:, 0].max())
        c, s = math.cos(a), math.sin(a)
        for off in (0.0, -0.006, 0.006, -0.012, 0.012, -0.02, 0.02, -0.03, 0.03):
            lx, ly = xmid + off, local[:, 1].min() - 0.005  # gripper origin in the approach frame
            pose = np.array([centre[0] + c * lx - s * ly, centre[1] + s * lx + c * ly, a])
            if not _between_fingers(pose, C.GRIPPER_STROKE, world.nominal_vertices, poses, index, margin):
                continue
            g = [transform_points(p, pose) for p in parts]
            if any(polygons_overlap(q, w, clearance=0.002) for q in g for w in _WALLS):
                continue
            if any(polygons_overlap(q, target, clearance=0.001) for q in g):
                continue
            pushes = any(polygons_overlap(q, o, clearance=0.002) for q in g for j, o in enumerate(polys) if j != index)
            score = abs(a - prefer_angle) / math.radians(5.0) + abs(off) / 0.006
            found.append((int(pushes), score, len(found), pose))
    if not found:
        angle, grasp = plan_grasp(target, [p for j, p in enumerate(polys) if j != index], prefer_angle=prefer_angle)
        return np.array([[grasp[0], grasp[1], angle]])
    found.sort(key=lambda f: f[:3])
    return np.array([f[3] for f in found[:limit]])


class HoldGoal(_GoalSpec):
    """Object ``index`` held, with its centroid past ``max_y`` (retrieve) or within ``radius`` of
    ``spot`` (rearrange). Features: the object's position. Goal samples: the start gripper pose
    moved by what the object has to move.

    Examples:
        >>> from occrl.baselines.kinodynamic import HoldGoal
        >>> goal = HoldGoal(0, start_pose=(0.0, 0.12, 0.0), start_object_pose=(0.0, 0.15, 0.0), max_y=-0.05)
        >>> goal.name, goal.goal_pose.round(3).tolist()  # the gripper moved as far as the object must
        ('extract', [0.0, -0.1, 0.0])
        >>> HoldGoal(0, (0.0, 0.12, 0.0), (0.0, 0.15, 0.0), spot=(0.1, 0.2)).name
        'place'
        >>> HoldGoal(0, (0.0, 0.12, 0.0), (0.0, 0.15, 0.0))
        Traceback (most recent call last):
            ...
        ValueError: give exactly one of max_y (retrieve) and spot (rearrange)
    """

    feature_bounds = ((-0.5, 0.5), (-0.5, 0.5))

    def __init__(self, index: int, start_pose, start_object_pose, max_y: float | None = None, spot=None, radius: float = 0.03):
        if (max_y is None) == (spot is None):
            raise ValueError("give exactly one of max_y (retrieve) and spot (rearrange)")
        self.index = int(index)
        self.max_y = max_y
        self.spot = None if spot is None else np.asarray(spot, float)
        self.radius = radius
        self.name = "extract" if spot is None else "place"
        self.goal_xy = self.spot if spot is not None else np.array([start_object_pose[0], max_y - 0.02])
        shift = self.goal_xy - np.asarray(start_object_pose[:2], float)
        self.goal_pose = np.array([start_pose[0] + shift[0], start_pose[1] + shift[1], start_pose[2]])

    def _error(self, e: "_Entry") -> float:
        p = e.object_poses[self.index]
        if self.spot is None:
            return max(0.0, p[1] - self.max_y)
        return max(0.0, math.hypot(p[0] - self.spot[0], p[1] - self.spot[1]) - self.radius)

    def satisfied(self, e: "_Entry") -> bool:
        return e.held == self.index and self._error(e) <= 0.0

    def distance(self, e: "_Entry") -> float:
        if e.held != self.index:
            d = self.goal_pose - e.gripper_pose
            return 1.0 + math.hypot(d[0], d[1])
        err = self._error(e)
        return 0.0 if err <= 0.0 else 1e-3 + err

    def features(self, e: "_Entry") -> tuple[float, float]:
        p = e.object_poses[self.index]
        return float(p[0]), float(p[1])

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, tuple[float, float]]:
        jitter = rng.normal(0.0, [0.01, 0.01, 0.05])
        return self.goal_pose + jitter, (float(self.goal_xy[0] + jitter[0]), float(self.goal_xy[1] + jitter[1]))


def _between_fingers(gripper_pose, opening, vertices, object_poses, index, margin, palm_gap: float = 0.002) -> bool:
    """The grasp rule (:func:`~occrl.envs.world.grasp_candidate`) for one object, with margins,
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


def _intrusions(gripper_pose, opening, vertices, object_poses, forbidden) -> np.ndarray:
    """How many probe points of the gripper (entry 0) and of each object (centroid and vertices)
    lie in the ``forbidden`` region."""
    parts = [transform_points(_probe_points(opening), gripper_pose)]
    parts += [transform_points(np.vstack([v, v.mean(axis=0)]), p) for v, p in zip(vertices, object_poses)]
    inside = forbidden(np.concatenate(parts))
    return np.add.reduceat(inside.astype(int), np.cumsum([0] + [len(q) for q in parts[:-1]]))


def _allowed(gripper_pose, opening, vertices, object_poses, forbidden=None, baseline=None) -> bool:
    """No part of the gripper or object penetrates a wall by more than ``WALL_TOLERANCE`` and,
    with a ``forbidden`` region, none of them is further in it than in the ``baseline`` counts
    of :func:`_intrusions` (the start state: touching it there is not the plan's doing)."""
    if forbidden is not None:
        counts = _intrusions(gripper_pose, opening, vertices, object_poses, forbidden)
        if np.any(counts > (0 if baseline is None else baseline)):
            return False
    polys = [transform_points(p, gripper_pose) for p in gripper_polygons(opening)]
    polys += [transform_points(v, p) for v, p in zip(vertices, object_poses)]
    tol = WALL_TOLERANCE
    for poly in polys:
        x0, y0 = poly.min(axis=0)
        x1, y1 = poly.max(axis=0)
        for (wx0, wx1, wy0, wy1), wall in zip(_WALL_BOXES, _WALLS):
            if x1 < wx0 + tol or x0 > wx1 - tol or y1 < wy0 + tol or y0 > wy1 - tol:
                continue  # bounding boxes overlap less than the tolerance
            if polygons_overlap(poly, wall, clearance=-tol):
                return False
    return True


# ====================================================================== the OMPL problem
@dataclass
class _Entry:
    """One simulated world state: the snapshot and what the planner needs of it."""

    snap: dict
    gripper_pose: np.ndarray
    object_poses: np.ndarray
    opening: float
    closed: bool
    held: int | None
    valid: bool


@dataclass
class PlanResult:
    """What one low-level query produced.

    Examples:
        >>> from occrl.baselines.kinodynamic import OPEN, ReachGoal, SimControlProblem, grasp_poses
        >>> from occrl.envs import Scene, ShelfWorld
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> world = ShelfWorld(Scene.from_objects([{"vertices": box, "pose": (0.0, 0.15, 0.0), "is_target": True}],
        ...                                       gripper_pose=(0.0, -0.1, 0.0)))
        >>> goal = ReachGoal(0, world.nominal_vertices, grasp_poses(world, 0), world.object_poses()[0])
        >>> problem = SimControlProblem(world, goal, grip=OPEN, seed=0)
        >>> result = problem.solve(seconds=1.0)
        >>> problem.close()
        >>> result.name, result.success, result.status, result.propagations > 0
        ('reach', True, 'Exact solution', True)
    """

    name: str
    success: bool
    actions: list[np.ndarray]
    status: str
    seconds: float
    propagations: int
    raw_length: int = 0  # actions of the OMPL path before shortcutting
    final: _Entry | None = field(default=None, repr=False)
    gripper_poses: list[np.ndarray] = field(default_factory=list, repr=False)  # after each action, as replayed


class SimControlProblem:
    """One OMPL control query in a pymunk world: see the module docstring for the formulation.

    Args:
        world: the (recreated, nominal) world in its start state; it is used as the simulator.
        goal: a goal region (:class:`ReachGoal`, :class:`HoldGoal`).
        grip: the gripper command of this motion primitive (<= 0 open, > 0 closed).
        planner: ``"rrt"`` or ``"kpiece"``.
        goal_bias: RRT's probability of extending towards a goal sample.
        restart_seconds: restart the planner with a fresh tree (same snapshot table) after this
            long without a solution, until the query's budget is used (None: one run).
        forbidden: a :class:`HidingRegion`; states where the gripper's outline or an object is
            further in it than at the start are invalid.
        seed: seeds OMPL (re-seeded at each :meth:`solve`) and the goal samples' jitter.

    Examples:
        >>> from occrl.baselines.kinodynamic import OPEN, ReachGoal, SimControlProblem, grasp_poses
        >>> from occrl.envs import Scene, ShelfWorld
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> world = ShelfWorld(Scene.from_objects([{"vertices": box, "pose": (0.0, 0.15, 0.0), "is_target": True}],
        ...                                       gripper_pose=(0.0, -0.1, 0.0)))
        >>> goal = ReachGoal(0, world.nominal_vertices, grasp_poses(world, 0), world.object_poses()[0])
        >>> problem = SimControlProblem(world, goal, grip=OPEN, seed=0)
        >>> result = problem.solve(seconds=1.0)
        >>> problem.close()  # frees the OMPL objects, which reference the problem from C++
        >>> result.success, len(result.actions) <= result.raw_length  # shortcutting never lengthens
        (True, True)
        >>> for action in result.actions:
        ...     _ = world.step(action)
        >>> goal.satisfied(result.final), bool((world.object_poses() == result.final.object_poses).all())
        (True, True)
    """

    def __init__(
        self,
        world: ShelfWorld,
        goal: _GoalSpec,
        grip: float,
        planner: str = "rrt",
        goal_bias: float = 0.25,
        restart_seconds: float | None = 0.75,
        seed: int = 0,
        forbidden: "HidingRegion | None" = None,
    ):
        if ob is None:  # pragma: no cover
            raise ImportError('the hierarchical planner needs OMPL 2.x: pip install -e ".[ompl]"')
        if planner not in ("rrt", "kpiece"):
            raise ValueError(f"planner must be 'rrt' or 'kpiece', got {planner!r}")
        self.world = world
        self.goal = goal
        self.grip = float(grip)
        self.planner_name = planner
        self.goal_bias = goal_bias
        self.restart_seconds = restart_seconds
        self.finish: list[np.ndarray] = []
        self._reached: dict[int, bool] = {}
        self.forbidden = None if forbidden is None or forbidden.empty else forbidden
        self.attempts = 0
        self.seed = int(seed)
        self.rng = np.random.default_rng(seed)
        self.vertices = world.nominal_vertices
        self._baseline = None
        if self.forbidden is not None:
            self._baseline = _intrusions(world.gripper_pose(), world.opening, self.vertices, world.object_poses(), self.forbidden)
        self.table: list[_Entry] = [self._entry(valid=None)]
        self.propagations = 0

        se2 = ob.SE2StateSpace()
        bounds = ob.RealVectorBounds(2)
        bounds.setLow(0, C.GRIPPER_X_LIMITS[0])
        bounds.setHigh(0, C.GRIPPER_X_LIMITS[1])
        bounds.setLow(1, C.GRIPPER_Y_LIMITS[0])
        bounds.setHigh(1, C.GRIPPER_Y_LIMITS[1])
        se2.setBounds(bounds)
        se2.setSubspaceWeight(1, 0.1)
        feats = ob.RealVectorStateSpace(2)
        fb = ob.RealVectorBounds(2)
        for k, (lo, hi) in enumerate(goal.feature_bounds):
            fb.setLow(k, lo)
            fb.setHigh(k, hi)
        feats.setBounds(fb)
        index = ob.RealVectorStateSpace(1)
        index.setBounds(0.0, 1e12)
        space = ob.CompoundStateSpace()
        space.addSubspace(se2, 1.0)
        space.addSubspace(feats, 1.0)
        space.addSubspace(index, 0.0)
        space.registerDefaultProjection(ob.SubspaceProjectionEvaluator(space, 0))
        cspace = oc.RealVectorControlSpace(space, C.ACTION_DIM)
        cb = ob.RealVectorBounds(C.ACTION_DIM)
        cb.setLow(-1.0)
        cb.setHigh(1.0)
        if self.grip > 0:
            cb.setLow(3, 0.5)
        else:
            cb.setHigh(3, -0.5)
        cspace.setBounds(cb)
        si = oc.SpaceInformation(space, cspace)
        si.setStatePropagator(self.propagate)
        si.setStateValidityChecker(self.is_valid)
        si.setPropagationStepSize(1.0)
        si.setMinMaxControlDuration(1, 1)
        si.setup()
        self.space, self.cspace, self.si = space, cspace, si
        self._keep = (se2, feats, index, bounds, fb, cb)  # keep the Python handles alive with the problem

    # ------------------------------------------------------------------ simulator side
    def _entry(self, valid: bool | None) -> _Entry:
        w = self.world
        e = _Entry(w.snapshot(), w.gripper_pose(), w.object_poses(), w.opening, w.closed, w.held, True)
        e.valid = self._penetration_free(e) if valid is None else valid
        return e

    def _penetration_free(self, e: _Entry) -> bool:
        return _allowed(e.gripper_pose, e.opening, self.vertices, e.object_poses, self.forbidden, self._baseline)

    def simulate(self, parent: int, action) -> int:
        """Restore table entry ``parent``, apply one action, append the child; its index."""
        self.world.restore(self.table[parent].snap)
        out = self.world.step(action)
        self.propagations += 1
        self.table.append(self._entry(valid=None if not out.dropped else False))
        return len(self.table) - 1

    # ------------------------------------------------------------------ OMPL callbacks
    def propagate(self, start, control, duration, result) -> None:
        child = self.simulate(int(start[2][0]), [control[0], control[1], control[2], control[3]])
        self._write(result, child)

    def _write(self, state, k: int) -> None:
        e = self.table[k]
        se2, feats = state[0], state[1]
        se2.setX(float(e.gripper_pose[0]))
        se2.setY(float(e.gripper_pose[1]))
        se2.setYaw(float(e.gripper_pose[2]))
        fx, fy = self.goal.features(e)
        feats[0] = fx
        feats[1] = fy
        state[2][0] = float(k)

    @staticmethod
    def index_of(state) -> int:
        """The snapshot-table index stored in an OMPL state."""
        return int(state[2][0])

    def is_valid(self, state) -> bool:
        k = int(state[2][0])
        return 0 <= k < len(self.table) and self.table[k].valid

    def start_state(self):
        st = self.space.allocState()
        self._write(st, 0)
        return st

    def _make_goal(self):
        problem = self

        class _Region(ob.GoalSampleableRegion):
            def distanceGoal(self, state) -> float:
                k = int(state[2][0])
                if not 0 <= k < len(problem.table):
                    return math.inf
                d = problem.goal.distance(problem.table[k])
                if d <= 0.0 and not problem.reached(k):
                    d = 1e-3  # in the region, but the finishing actions fail from there
                return d

            def sampleGoal(self, state) -> None:
                (x, y, th), (fx, fy) = problem.goal.sample(problem.rng)
                state[0].setX(float(np.clip(x, *C.GRIPPER_X_LIMITS)))
                state[0].setY(float(np.clip(y, *C.GRIPPER_Y_LIMITS)))
                state[0].setYaw(float(np.clip(th, *C.GRIPPER_THETA_LIMITS)))
                state[1][0] = fx
                state[1][1] = fy
                state[2][0] = -1.0

            def maxSampleCount(self) -> int:
                return 1_000_000

        region = _Region(self.si)
        region.setThreshold(1e-9)
        return region

    # ------------------------------------------------------------------ solve
    def solve(self, seconds: float, shortcut: bool = True, finish: list | None = None) -> PlanResult:
        """Plan for at most ``seconds`` (OMPL's timed termination). ``finish``: actions appended
        after the path (e.g. the release of a placed object), simulated and checked too."""
        t0 = time.perf_counter()
        self.finish = [np.asarray(a, float) for a in finish or []]
        self._reached = {}
        name = self.goal.name
        start = self.table[0]
        if not start.valid:
            return PlanResult(name, False, [], "invalid start", time.perf_counter() - t0, 0, 0, None)
        if self.reached(0):
            return self._finish(name, [], 0, t0, finish, "already satisfied")
        deadline = t0 + max(float(seconds), 1e-6)
        attempts, status_text = 0, "no attempt"
        while True:  # restarts: a fresh tree every restart_seconds (run times are heavy-tailed)
            remaining = deadline - time.perf_counter()
            if remaining <= 0.0 and attempts > 0:
                break
            attempts += 1
            ompl_seed(self.seed * 7919 + attempts)  # each attempt a function of (seed, attempt)
            self.rng = np.random.default_rng([self.seed, attempts])
            pdef = ob.ProblemDefinition(self.si)
            pdef.addStartState(self.start_state())
            pdef.setGoal(self._make_goal())
            if self.planner_name == "rrt":
                planner = oc.RRT(self.si)
                planner.setGoalBias(self.goal_bias)
            else:
                planner = oc.KPIECE1(self.si)
            planner.setProblemDefinition(pdef)
            planner.setup()
            budget = max(min(remaining, self.restart_seconds or remaining), 1e-6)
            status_text = planner.solve(ob.timedPlannerTerminationCondition(budget)).asString()
            if pdef.hasExactSolution():
                break
            pdef.clearSolutionPaths()
            planner.clear()
        self.attempts = attempts
        if not pdef.hasExactSolution():
            self.world.restore(start.snap)
            status_text = f"{status_text} ({attempts} attempts)"
            return PlanResult(name, False, [], status_text, time.perf_counter() - t0, self.propagations, 0, None)
        path = pdef.getSolutionPath()
        indices = [self.index_of(st) for st in path.getStates()]
        controls = [np.array([path.getControl(i)[k] for k in range(C.ACTION_DIM)]) for i in range(path.getControlCount())]
        pdef.clearSolutionPaths()
        planner.clear()
        self.world.restore(start.snap)
        raw = len(controls)
        if shortcut:
            controls = self.shortcut(indices, controls, deadline=time.perf_counter() + max(0.2, 0.25 * seconds))
        return self._finish(name, controls, raw, t0, finish, status_text)

    def _finish(self, name, controls, raw, t0, finish, status_text) -> PlanResult:
        """Replay the actions from the start: every state valid, goal reached before ``finish``."""
        k = 0
        poses = []
        for a in controls:
            k = self.simulate(k, a)
            poses.append(self.table[k].gripper_pose.copy())
            if not self.table[k].valid:
                status_text = "replay left the valid states"
                return PlanResult(name, False, [], status_text, time.perf_counter() - t0, self.propagations, raw, None)
        if not self.reached(k):
            return PlanResult(name, False, [], "replay missed the goal", time.perf_counter() - t0, self.propagations, raw, None)
        actions = [np.asarray(a, float) for a in controls]
        for a in self.finish:
            k = self.simulate(k, a)
            actions.append(a)
            poses.append(self.table[k].gripper_pose.copy())
        self.world.restore(self.table[0].snap)
        return PlanResult(name, True, actions, status_text, time.perf_counter() - t0, self.propagations, raw, self.table[k], poses)

    def reached(self, k: int) -> bool:
        """Table entry ``k`` is in the goal region and the finishing actions (if any) stay valid
        from it (simulated once per entry)."""
        if not self.goal.satisfied(self.table[k]):
            return False
        if not self.finish:
            return True
        ok = self._reached.get(k)
        if ok is None:
            j, ok = k, True
            for a in self.finish:
                j = self.simulate(j, a)
                if not self.table[j].valid:
                    ok = False
                    break
            self._reached[k] = ok
        return ok

    def close(self) -> None:
        """Free the OMPL objects and the snapshot table (they reference each other through C++,
        which Python's garbage collector cannot see)."""
        self.si = self.space = self.cspace = self._keep = None
        self.table = self.table[:1]

    def steer(self, start: int, waypoints, max_steps: int) -> tuple[list[np.ndarray], int] | None:
        """Closed-loop straight steering in the simulator from entry ``start`` through the gripper
        poses ``waypoints``, at most ``max_steps`` actions; the goal is checked after every step
        and reaching it ends the steering. Returns the actions and the final entry, or None if a
        state is invalid or the goal is not reached."""
        k, actions = start, []
        for target in waypoints:
            while not _at(self.table[k].gripper_pose, target):
                if len(actions) >= max_steps:
                    return None
                a = steer_action(self.table[k].gripper_pose, target, self.grip)
                k = self.simulate(k, a)
                actions.append(a)
                if not self.table[k].valid:
                    return None
                if self.reached(k):
                    return actions, k
                if len(actions) >= 2 and np.allclose(self.table[k].gripper_pose, self.table[k - 1].gripper_pose, atol=2e-4):
                    return None  # stalled against something
        return None

    def _routes(self, start: int, final: int) -> list[list[np.ndarray]]:
        """Waypoint lists to try from entry ``start``: the final pose of the OMPL path and, for a
        reach, the best heuristic grasp poses relative to where the object is at ``start`` and at
        the end of the path; each directly and through a pre-pose on its approach line (backed
        off out of the shelf, or 6 cm)."""
        targets = [self.table[final].gripper_pose]
        if isinstance(self.goal, ReachGoal):
            for k in (start, final):
                obj = self.table[k].object_poses[self.goal.index]
                targets += [_compose(obj, rel) for rel in self.goal.relative[:2]]
        routes = []
        for g in targets:
            routes.append([g])
            c = math.cos(g[2])
            back = np.array([math.sin(g[2]), -c, 0.0])  # unit step backwards along the heading
            out = (g[1] + C.FINGER_LENGTH + 0.01) / max(c, 0.3)
            for d in (out, 0.06):
                if d > 0.01:
                    routes.append([g + d * back, g])
        return routes

    def shortcut(self, indices: list[int], controls: list[np.ndarray], deadline: float) -> list[np.ndarray]:
        """Shorten an OMPL path: from its earliest state possible, steer along each route of
        :meth:`_routes`; the shortest attempt that reaches the goal through valid states replaces
        the rest of the path."""
        best = list(controls)
        for i in range(len(controls) - 1):
            if time.perf_counter() > deadline or i >= len(best) - 1:
                break
            for route in self._routes(indices[i], indices[-1]):
                budget = len(best) - i - 1  # must be strictly shorter than the best so far
                if budget <= 0 or time.perf_counter() > deadline:
                    break
                got = self.steer(indices[i], route, budget)
                if got is not None:
                    best = list(controls[:i]) + got[0]
        return best
