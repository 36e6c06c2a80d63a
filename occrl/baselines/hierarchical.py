"""The hierarchical baseline (paper Alg. 3): scripted search, then OMPL kinodynamic planning in
the pymunk world recreated from accumulated detections.

High level (one state machine per world of the batch)::

    while target not retrieved:
        Search()            # outside the shelf, sweep far left -> far right, camera pointing in
        if target not located:
            Rearrange(closest object to the robot)  # to a free spot at the back of the shelf
            Move_out()
        else:
            Retrieve(target)

Perception boundary. Only observation keys are read (detections, gripper pose/opening/closed, the
target's type and shape), never ``"privileged"``. Detections are accumulated by type id (a
detector's object identity): the last pose seen of every object and whether it is the target.
Objects that leave the view keep their last seen pose, or the pose the planner predicted for them
at the end of an executed plan.

Search and Move_out are hand-crafted motion primitives (closed-loop steering in the gripper frame).
Search moves out of the shelf if needed, then sweeps along ``y = search_y`` with the camera
pointing in (theta = 0) from ``x = -sweep_x`` to ``x = +sweep_x`` at full lateral speed; every
intermediate view adds detections. The very first Search of an episode always sweeps; a later one
is skipped when the target is already located (the camera often sees it while the arm moves out
after a rearrangement) unless a plan failed, in which case it always sweeps (so every failure
costs actions, never a silent re-planning loop).

Low level. Retrieve and Rearrange are each two OMPL control queries in a nominal pymunk
:class:`~occrl.envs.ShelfWorld` built from the accumulated detections (:func:`make_world`):

* Retrieve: (1) *reach*: gripper open, goal region = the target alone between the fingers, well
  inside (the grasp rule with margins); (2) *extract*: gripper closed, goal region = target held
  and its centroid ``extract_margin`` past the retrieval line (``RETRIEVED_Y``).
* Rearrange: (1) *reach* the object; (2) *place*: gripper closed, goal region = object held with
  its centroid within ``place_radius`` of a free spot at the back of the shelf, followed by one
  opening action (checked in the simulator too). Then Move_out.

Each query re-plans from the current observation after the previous one was executed open-loop
(one planned action per env step, from a queue).

OMPL formulation (:class:`SimControlProblem`):

* State space: compound of SE2 (the gripper pose; bounds = the arm's workspace, rotation weight
  0.1 so that 15 degrees weigh about as much as 2.6 cm) and R^1 holding an *index into a
  Python-side table of world snapshots* (distance weight 0). The propagator restores the parent's
  snapshot (:meth:`ShelfWorld.restore`, bit-exact), steps the real pymunk physics with the control,
  appends the child's snapshot and outcome to the table and writes its index and gripper pose into
  the child state. So the OMPL state stays small while the full physical state (object poses,
  grasp) is exact and deterministic: the same state and control always give the same child.
* Control space: the 4-number action ``[forward, lateral, rotation, gripper]``, bounds [-1, 1]
  except the gripper entry, which is bounded to the query's mode (open: [-1, -0.5]; closed:
  [0.5, 1]), i.e. each query is one motion primitive with a fixed gripper command. One control is
  one env step (propagation step size 1, control duration 1).
* Validity: a state is invalid if an object left the shelf (a drop) or the gripper, the held
  object or any object penetrates a wall by more than ``WALL_TOLERANCE``.
* Goals are regions (:class:`ompl.base.GoalSampleableRegion`): ``distanceGoal`` is 0 inside the
  region, else a heuristic distance; ``sampleGoal`` returns a heuristic gripper pose (a grasp from
  :func:`~occrl.baselines.scripted.plan_grasp`, or the start pose shifted so that the held object
  reaches its goal) for RRT's goal bias.
* Planner: ``oc.RRT`` (default; goal bias 0.25) or ``oc.KPIECE1`` (projection: the SE2 part's
  default, x and y), stopped by a timed termination condition: a query that finds no exact
  solution within ``plan_seconds`` is a logged failure (logger ``occrl.baselines.hierarchical``),
  after which the robot moves out and searches again.
* Shortcutting (post-processing, in the same simulator): random controls make RRT paths long, and
  an episode has at most 50 actions. From the earliest path state on, the planner tries to steer
  straight (closed-loop in the simulator, full speed) to the gripper pose of the solution's final
  state; the first attempt that reaches the goal region through valid states and is shorter
  replaces the rest of the path. The final action list is replayed once more from the start
  snapshot to confirm validity and the goal, and its end state becomes the robot's prediction.

Timing: ``planning_seconds`` accumulates the wall time of all low-level planning (world building,
OMPL, shortcutting, replay) of the current episode; it is reset when ``is_init`` is true. It counts
toward the task's 2-minute limit; past ``time_limit`` the planner stops planning (logged) and only
backs out.
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.envs import world_constants as C
from occrl.envs.geometry import polygons_overlap, transform_points
from occrl.envs.scene import SceneObject
from occrl.envs.visibility import visible_fractions
from occrl.envs.world import ShelfWorld, gripper_polygons, inverse_pose, wall_polygons
from occrl.planners.recreate import RecreatedState, make_world

try:  # OMPL 2.x (nanobind bindings)
    from ompl import base as ob
    from ompl import control as oc
    from ompl import util as ou

    ou.setLogLevel(ou.LogLevel.LOG_WARN)
except ImportError:  # pragma: no cover - the baseline needs OMPL
    ob = oc = ou = None

__all__ = [
    "HierarchicalPlanner",
    "SimControlProblem",
    "PlanResult",
    "ReachGoal",
    "HoldGoal",
    "steer_action",
    "ompl_seed",
]

logger = logging.getLogger(__name__)

WALL_TOLERANCE = 0.003  # m of wall penetration that counts as invalid
OPEN = -1.0
CLOSE = 1.0
_WALLS = wall_polygons()
_WALL_BOXES = [(w[:, 0].min(), w[:, 0].max(), w[:, 1].min(), w[:, 1].max()) for w in _WALLS]
_STROKE_HALF = C.GRIPPER_STROKE / 2
_OUT_Y = -0.07  # gripper origin behind this line (and |theta| <= 45 deg): no part is in the shelf
_SEEDED = False


def ompl_seed(seed: int) -> None:
    """Seed OMPL's random numbers (once per process, before the first planner is made)."""
    global _SEEDED
    if not _SEEDED:
        ou.RNG.setSeed(int(seed))
        _SEEDED = True


# ====================================================================== motion primitives
def steer_action(pose, target, grip: float) -> np.ndarray:
    """The action that moves the gripper straight towards ``target`` (x, y, theta) at full speed:
    the world-frame displacement is converted to the gripper frame and all three motion entries
    are scaled by the same factor so that the largest is at most 1 (a straight line)."""
    x, y, th = (float(v) for v in pose)
    dx, dy = float(target[0]) - x, float(target[1]) - y
    c, s = math.cos(th), math.sin(th)
    a = np.array([(-s * dx + c * dy) / C.MAX_FORWARD, (c * dx + s * dy) / C.MAX_LATERAL, (float(target[2]) - th) / C.MAX_ROTATION])
    a /= max(1.0, float(np.abs(a).max()))
    return np.array([a[0], a[1], a[2], grip])


def _at(pose, target, tol_xy: float = 1e-3, tol_th: float = math.radians(0.5)) -> bool:
    return math.hypot(pose[0] - target[0], pose[1] - target[1]) < tol_xy and abs(pose[2] - target[2]) < tol_th


def _inside(pose) -> bool:
    """Some part of the (open) gripper may be in the shelf."""
    return pose[1] > _OUT_Y or abs(pose[2]) > math.pi / 4


# ====================================================================== goals
class _GoalSpec:
    """A goal region on the simulator state (a table entry), with a heuristic for the planner."""

    name = "goal"

    def satisfied(self, e: "_Entry") -> bool:  # pragma: no cover - interface
        raise NotImplementedError

    def distance(self, e: "_Entry") -> float:  # pragma: no cover - interface
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


class ReachGoal(_GoalSpec):
    """Object ``index`` alone between the open fingers, ``margin`` inside the grasp rule: lying
    across the axis with ``margin`` to either finger, its centre ``margin`` within the fingers."""

    name = "reach"

    def __init__(self, index: int, vertices: list[np.ndarray], grasp_pose, margin: float = 0.003) -> None:
        self.index = int(index)
        self.vertices = vertices
        self.grasp_pose = np.asarray(grasp_pose, float)
        self.margin = margin

    def satisfied(self, e: "_Entry") -> bool:
        if e.closed or e.opening < C.GRIPPER_STROKE - 1e-6:
            return False
        return _between_fingers(e.gripper_pose, e.opening, self.vertices, e.object_poses, self.index, self.margin)

    def distance(self, e: "_Entry") -> float:
        if self.satisfied(e):
            return 0.0
        d = self.grasp_pose - e.gripper_pose
        return 1e-3 + math.hypot(d[0], d[1]) + 0.1 * abs(d[2])

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        return self.grasp_pose + rng.normal(0.0, [0.004, 0.004, 0.03])


class HoldGoal(_GoalSpec):
    """Object ``index`` held, with its centroid past ``max_y`` (retrieve) or within ``radius`` of
    ``spot`` (rearrange)."""

    def __init__(self, index: int, start_pose, start_object_pose, max_y: float | None = None, spot=None, radius: float = 0.03):
        self.index = int(index)
        self.max_y = max_y
        self.spot = None if spot is None else np.asarray(spot, float)
        self.radius = radius
        self.name = "extract" if spot is None else "place"
        # heuristic goal pose: the start gripper pose moved by what the object has to move
        goal_xy = np.array([start_object_pose[0], (max_y - 0.02) if spot is None else 0.0])
        if spot is not None:
            goal_xy = self.spot
        self.goal_pose = np.array([start_pose[0] + goal_xy[0] - start_object_pose[0], start_pose[1] + goal_xy[1] - start_object_pose[1], start_pose[2]])
        if spot is None:
            self.goal_pose[2] = 0.0

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

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        return self.goal_pose + rng.normal(0.0, [0.01, 0.01, 0.05])


def _between_fingers(gripper_pose, opening, vertices, object_poses, index, margin) -> bool:
    """The grasp rule (:func:`~occrl.envs.world.grasp_candidate`) for one object, with margins."""
    h = opening / 2.0
    inv = inverse_pose(gripper_pose)
    band = np.array([[-h, 0.0], [h, 0.0], [h, C.FINGER_LENGTH], [-h, C.FINGER_LENGTH]])
    local = transform_points(transform_points(vertices[index], object_poses[index]), inv)
    xmin, xmax = local[:, 0].min(), local[:, 0].max()
    cy = local[:, 1].mean()
    if not (xmin > -h + margin and xmax < h - margin and xmin < -margin and xmax > margin):
        return False
    if not (margin <= cy <= C.FINGER_LENGTH - margin):
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
    """What one low-level query produced."""

    name: str
    success: bool
    actions: list[np.ndarray]
    status: str
    seconds: float
    propagations: int
    raw_length: int = 0  # actions of the OMPL path before shortcutting
    final: _Entry | None = field(default=None, repr=False)


class SimControlProblem:
    """One OMPL control query in a pymunk world: see the module docstring for the formulation.

    Args:
        world: the (recreated, nominal) world in its start state; it is used as the simulator.
        goal: a goal region (:class:`ReachGoal`, :class:`HoldGoal`).
        grip: the gripper command of this motion primitive (<= 0 open, > 0 closed).
        planner: ``"rrt"`` or ``"kpiece"``.
        goal_bias: RRT's probability of extending towards a goal sample.
        seed: seeds the goal samples' jitter.
    """

    def __init__(self, world: ShelfWorld, goal: _GoalSpec, grip: float, planner: str = "rrt", goal_bias: float = 0.25, seed: int = 0):
        if ob is None:  # pragma: no cover
            raise ImportError("the hierarchical planner needs OMPL 2.x (import ompl failed)")
        if planner not in ("rrt", "kpiece"):
            raise ValueError(f"planner must be 'rrt' or 'kpiece', got {planner!r}")
        self.world = world
        self.goal = goal
        self.grip = float(grip)
        self.planner_name = planner
        self.goal_bias = goal_bias
        self.rng = np.random.default_rng(seed)
        self.vertices = world.nominal_vertices
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
        index = ob.RealVectorStateSpace(1)
        index.setBounds(0.0, 1e12)
        space = ob.CompoundStateSpace()
        space.addSubspace(se2, 1.0)
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
        self._keep = (se2, index, bounds, cb)  # keep the Python handles alive with the problem

    # ------------------------------------------------------------------ simulator side
    def _entry(self, valid: bool | None) -> _Entry:
        w = self.world
        e = _Entry(w.snapshot(), w.gripper_pose(), w.object_poses(), w.opening, w.closed, w.held, True)
        e.valid = self._penetration_free(e) if valid is None else valid
        return e

    def _penetration_free(self, e: _Entry) -> bool:
        polys = [transform_points(p, e.gripper_pose) for p in gripper_polygons(e.opening)]
        polys += [transform_points(v, p) for v, p in zip(self.vertices, e.object_poses)]
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

    def simulate(self, parent: int, action) -> int:
        """Restore table entry ``parent``, apply one action, append the child; its index."""
        self.world.restore(self.table[parent].snap)
        out = self.world.step(action)
        self.propagations += 1
        self.table.append(self._entry(valid=None if not out.dropped else False))
        return len(self.table) - 1

    # ------------------------------------------------------------------ OMPL callbacks
    def propagate(self, start, control, duration, result) -> None:
        child = self.simulate(int(start[1][0]), [control[0], control[1], control[2], control[3]])
        pose = self.table[child].gripper_pose
        se2 = result[0]
        se2.setX(float(pose[0]))
        se2.setY(float(pose[1]))
        se2.setYaw(float(pose[2]))
        result[1][0] = float(child)

    def is_valid(self, state) -> bool:
        k = int(state[1][0])
        return 0 <= k < len(self.table) and self.table[k].valid

    def start_state(self):
        st = self.space.allocState()
        pose = self.table[0].gripper_pose
        st[0].setX(float(pose[0]))
        st[0].setY(float(pose[1]))
        st[0].setYaw(float(pose[2]))
        st[1][0] = 0.0
        return st

    def _make_goal(self):
        problem = self

        class _Region(ob.GoalSampleableRegion):
            def distanceGoal(self, state) -> float:
                k = int(state[1][0])
                if not 0 <= k < len(problem.table):
                    return math.inf
                return problem.goal.distance(problem.table[k])

            def sampleGoal(self, state) -> None:
                x, y, th = problem.goal.sample(problem.rng)
                state[0].setX(float(np.clip(x, *C.GRIPPER_X_LIMITS)))
                state[0].setY(float(np.clip(y, *C.GRIPPER_Y_LIMITS)))
                state[0].setYaw(float(np.clip(th, *C.GRIPPER_THETA_LIMITS)))
                state[1][0] = -1.0

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
        name = self.goal.name
        start = self.table[0]
        if not start.valid:
            return PlanResult(name, False, [], "invalid start", time.perf_counter() - t0, 0, 0, None)
        if self.goal.satisfied(start):
            return self._finish(name, [], 0, t0, finish, "already satisfied")
        pdef = ob.ProblemDefinition(self.si)
        pdef.addStartState(self.start_state())
        region = self._make_goal()
        pdef.setGoal(region)
        if self.planner_name == "rrt":
            planner = oc.RRT(self.si)
            planner.setGoalBias(self.goal_bias)
        else:
            planner = oc.KPIECE1(self.si)
        planner.setProblemDefinition(pdef)
        planner.setup()
        status = planner.solve(ob.timedPlannerTerminationCondition(max(float(seconds), 1e-6)))
        status_text = status.asString()
        if not pdef.hasExactSolution():
            pdef.clearSolutionPaths()
            planner.clear()
            return PlanResult(name, False, [], status_text, time.perf_counter() - t0, self.propagations, 0, None)
        path = pdef.getSolutionPath()
        indices = [int(s[1][0]) for s in path.getStates()]
        controls = [np.array([path.getControl(i)[k] for k in range(C.ACTION_DIM)]) for i in range(path.getControlCount())]
        pdef.clearSolutionPaths()
        planner.clear()
        raw = len(controls)
        if shortcut:
            controls = self.shortcut(indices, controls, deadline=time.perf_counter() + max(0.2, 0.25 * seconds))
        return self._finish(name, controls, raw, t0, finish, status_text)

    def _finish(self, name, controls, raw, t0, finish, status_text) -> PlanResult:
        """Replay the actions from the start: every state valid, goal reached before ``finish``."""
        k = 0
        for a in controls:
            k = self.simulate(k, a)
            if not self.table[k].valid:
                return PlanResult(name, False, [], "replay left the valid states", time.perf_counter() - t0, self.propagations, raw, None)
        if not self.goal.satisfied(self.table[k]):
            return PlanResult(name, False, [], "replay missed the goal", time.perf_counter() - t0, self.propagations, raw, None)
        actions = [np.asarray(a, float) for a in controls]
        for a in finish or []:
            k = self.simulate(k, a)
            if not self.table[k].valid:
                return PlanResult(name, False, [], "final action invalid", time.perf_counter() - t0, self.propagations, raw, None)
            actions.append(np.asarray(a, float))
        return PlanResult(name, True, actions, status_text, time.perf_counter() - t0, self.propagations, raw, self.table[k])

    def steer(self, start: int, target, max_steps: int) -> tuple[list[np.ndarray], int] | None:
        """Closed-loop straight steering in the simulator from entry ``start`` to the gripper pose
        ``target`` (the goal is checked after every step: reaching the region ends it early).
        Returns the actions and the final entry, or None if a state is invalid or it stalls."""
        k, actions = start, []
        for _ in range(max_steps):
            e = self.table[k]
            if self.goal.satisfied(e) and actions:
                return actions, k
            if _at(e.gripper_pose, target):
                break
            a = steer_action(e.gripper_pose, target, self.grip)
            k = self.simulate(k, a)
            actions.append(a)
            if not self.table[k].valid:
                return None
        if self.goal.satisfied(self.table[k]) and actions:
            return actions, k
        return None

    def shortcut(self, indices: list[int], controls: list[np.ndarray], deadline: float) -> list[np.ndarray]:
        """Replace the tail of the path, from its earliest state possible, by straight steering to
        the final state's gripper pose (kept only if it reaches the goal and is shorter)."""
        target = self.table[indices[-1]].gripper_pose
        n = len(controls)
        for i in range(n - 1):
            if time.perf_counter() > deadline:
                break
            budget = n - i - 1  # must be strictly shorter than the rest of the path
            got = self.steer(indices[i], target, budget)
            if got is not None:
                return list(controls[:i]) + got[0]
        return controls


# ====================================================================== policy
@dataclass
class _Known:
    type_id: int
    vertices: np.ndarray
    pose: np.ndarray
    is_target: bool
    seen_step: int


@dataclass
class _Episode:
    """Per-world memory and high-level state."""

    step: int = 0
    memory: dict = field(default_factory=dict)  # type id -> _Known
    views: list = field(default_factory=list)  # gripper poses the camera looked from
    queue: deque = field(default_factory=deque)
    stage: str = "search"
    sweep: list | None = None  # waypoints left in the current sweep
    searched: bool = False  # the first sweep of the episode is done
    force_sweep: bool = False  # a plan failed: sweep again even if the target is located
    rearranged: set = field(default_factory=set)  # type ids already moved to the back
    rearrange_id: int | None = None
    predicted: dict | None = None  # type id -> pose at the end of the queued plan
    planning_seconds: float = 0.0
    plans: list = field(default_factory=list)
    failures: int = 0
    out_of_time: bool = False


class HierarchicalPlanner(TensorDictModuleBase):
    """The hierarchical baseline (paper Alg. 3) as a policy: ``env.rollout(50, policy=HierarchicalPlanner())``.

    Args:
        plan_seconds: time budget of one low-level OMPL query.
        planner: ``"rrt"`` (control RRT) or ``"kpiece"`` (control KPIECE1).
        sweep_x: the Search sweep runs from x = -sweep_x to +sweep_x.
        search_y: the sweep line (y of the gripper, outside the shelf).
        extract_margin: how far past the retrieval line the extract plan pulls the target.
        place_radius: how close to the chosen free spot a rearranged object must end.
        time_limit: stop planning when an episode's planning time exceeds this (the task limit).
        shortcut: post-process plans by straight steering in the simulator.
        seed: seeds goal-sample jitter (and OMPL, once per process).

    Attributes:
        planning_seconds: planning time of the current episode (summed over the batch's worlds;
            per world in ``planning_seconds_per_world``).
        last_plans: :class:`PlanResult` of every low-level query of the current episodes.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.baselines.hierarchical import HierarchicalPlanner
        >>> env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False)
        >>> policy = HierarchicalPlanner()
        >>> td = env.rollout(50, policy=policy)
        >>> td["action"].shape[-1]
        4
    """

    in_keys = ["is_init", "gripper_pose", "gripper_opening", "gripper_closed", "objects", "target_type", "target_vertices", "target_num_vertices"]
    out_keys = ["action"]

    def __init__(
        self,
        plan_seconds: float = 3.0,
        planner: str = "rrt",
        sweep_x: float = 0.2,
        search_y: float = -0.1,
        extract_margin: float = 0.01,
        place_radius: float = 0.03,
        time_limit: float = 120.0,
        shortcut: bool = True,
        seed: int = 0,
    ) -> None:
        super().__init__()
        if planner not in ("rrt", "kpiece"):
            raise ValueError(f"planner must be 'rrt' or 'kpiece', got {planner!r}")
        if plan_seconds <= 0:
            raise ValueError(f"plan_seconds must be > 0, got {plan_seconds}")
        if search_y > _OUT_Y:
            raise ValueError(f"search_y must be <= {_OUT_Y} (outside the shelf), got {search_y}")
        self.plan_seconds = float(plan_seconds)
        self.planner = planner
        self.sweep_x = float(sweep_x)
        self.search_y = float(search_y)
        self.extract_margin = float(extract_margin)
        self.place_radius = float(place_radius)
        self.time_limit = float(time_limit)
        self.shortcut = shortcut
        self.seed = int(seed)
        self._queries = 0
        self.episodes: list[_Episode] = []
        ompl_seed(seed)

    # ------------------------------------------------------------------ bookkeeping
    @property
    def planning_seconds(self) -> float:
        return float(sum(ep.planning_seconds for ep in self.episodes))

    @property
    def planning_seconds_per_world(self) -> list[float]:
        return [ep.planning_seconds for ep in self.episodes]

    @property
    def last_plans(self) -> list[PlanResult]:
        return [p for ep in self.episodes for p in ep.plans]

    def reset(self) -> None:
        self.episodes = []

    # ------------------------------------------------------------------ forward
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        n = flat.shape[0]
        if len(self.episodes) != n:
            self.episodes = [_Episode() for _ in range(n)]
        is_init = flat.get("is_init").reshape(n).cpu().numpy() if "is_init" in flat.keys() else np.zeros(n, bool)
        actions = []
        for b in range(n):
            if is_init[b]:
                self.episodes[b] = _Episode()
            actions.append(self.act(self.episodes[b], flat[b]))
        action = torch.as_tensor(np.stack(actions), dtype=torch.float32).reshape(*tensordict.shape, C.ACTION_DIM)
        tensordict.set("action", action)
        return tensordict

    def act(self, ep: _Episode, obs: TensorDictBase) -> np.ndarray:
        """The next action of one world (observation without batch dims)."""
        pose = obs.get("gripper_pose").cpu().numpy().astype(float)
        self._observe(ep, obs, pose)
        ep.step += 1
        if not ep.queue:
            ep.predicted = None
            for _ in range(8):  # stages that produce no action hand over to the next one
                a = self._decide(ep, obs, pose)
                if a is not None:
                    break
            else:  # pragma: no cover - defensive: every cycle of stages contains a sweep
                a = np.array([0.0, 0.0, 0.0, OPEN])
            if not ep.queue:
                return np.clip(a, -1.0, 1.0)
        return np.clip(ep.queue.popleft(), -1.0, 1.0)

    # ------------------------------------------------------------------ perception memory
    def _observe(self, ep: _Episode, obs: TensorDictBase, pose: np.ndarray) -> None:
        objects = obs.get("objects")
        det = objects.get("detected").cpu().numpy().astype(bool)
        type_id = objects.get("type_id").cpu().numpy()
        poses = objects.get("pose").cpu().numpy().astype(float)
        verts = objects.get("vertices").cpu().numpy().astype(float)
        nv = objects.get("num_vertices").cpu().numpy()
        target_type = int(obs.get("target_type").reshape(-1)[0])
        if ep.predicted is not None and not ep.queue:
            pass
        seen = set()
        for k in np.flatnonzero(det):
            tid = int(type_id[k])
            seen.add(tid)
            ep.memory[tid] = _Known(tid, verts[k, : nv[k]].copy(), poses[k].copy(), tid == target_type, ep.step)
        if ep.predicted is not None and not ep.queue:
            # a plan was executed to its end: objects out of view are where the simulator put them
            for tid, p in ep.predicted.items():
                if tid not in seen and tid in ep.memory:
                    ep.memory[tid].pose = np.asarray(p, float)
            ep.predicted = None
        ep.views.append(pose.copy())

    def _target_id(self, ep: _Episode) -> int | None:
        return next((tid for tid, k in ep.memory.items() if k.is_target), None)

    def _state(self, ep: _Episode, obs: TensorDictBase, pose: np.ndarray) -> tuple[RecreatedState, list[int]]:
        """The known state: accumulated objects (stale ones that overlap fresher ones or the
        gripper are dropped), the gripper as observed. Also the type id of each world index."""
        opening = float(obs.get("gripper_opening").reshape(-1)[0])
        closed = bool(obs.get("gripper_closed").reshape(-1)[0])
        gripper = [transform_points(p, pose) for p in gripper_polygons(opening)]
        kept: list[tuple[_Known, np.ndarray]] = []
        for k in sorted(ep.memory.values(), key=lambda k: -k.seen_step):  # freshest first
            poly = transform_points(k.vertices, k.pose)
            fresh = k.seen_step == ep.step
            if any(polygons_overlap(poly, q, clearance=-1e-3) for _, q in kept):
                continue
            if not fresh and any(polygons_overlap(poly, g, clearance=-1e-3) for g in gripper):
                continue
            kept.append((k, poly))
        kept.sort(key=lambda kp: kp[0].type_id)
        objects = tuple(SceneObject(k.type_id, k.vertices, tuple(float(v) for v in k.pose), k.is_target) for k, _ in kept)
        tv = obs.get("target_vertices").cpu().numpy().astype(float)[: int(obs.get("target_num_vertices").reshape(-1)[0])]
        state = RecreatedState(objects, tuple(float(v) for v in pose), opening, closed, int(obs.get("target_type").reshape(-1)[0]), tv)
        return state, [k.type_id for k, _ in kept]

    # ------------------------------------------------------------------ the high level
    def _decide(self, ep: _Episode, obs: TensorDictBase, pose: np.ndarray) -> np.ndarray | None:
        """Advance the state machine by one stage; an action (or None: the next stage decides)."""
        if ep.stage == "move_out":
            a = self._move_out_action(pose)
            if a is not None:
                return a
            ep.stage = "search"
            return None
        if ep.stage == "search":
            if ep.sweep is None:
                located = self._target_id(ep) is not None
                if ep.searched and located and not ep.force_sweep:
                    ep.stage = "decide"  # nothing to search for
                    return None
                ep.sweep = [np.array([-self.sweep_x, self.search_y, 0.0]), np.array([self.sweep_x, self.search_y, 0.0])]
                ep.force_sweep = False
            if _inside(pose):  # Search starts outside the shelf
                return self._move_out_action(pose)
            while ep.sweep and _at(pose, ep.sweep[0], tol_xy=2e-3, tol_th=math.radians(1.0)):
                ep.sweep.pop(0)
            if ep.sweep:
                return steer_action(pose, ep.sweep[0], OPEN)
            ep.sweep = None
            ep.searched = True
            ep.stage = "decide"
            return None
        if ep.out_of_time:
            ep.stage = "move_out"
            a = self._move_out_action(pose)
            return a if a is not None else np.array([0.0, 0.0, 0.0, OPEN])
        if ep.stage == "decide":
            if self._target_id(ep) is not None:
                ep.stage = "retrieve_reach"
            else:
                tid = self._closest_object(ep, pose)
                if tid is None:  # nothing known to move: look again
                    logger.info("no target and no object known: searching again")
                    ep.force_sweep = True
                    ep.stage = "search"
                    return None
                ep.rearrange_id = tid
                ep.stage = "rearrange_reach"
            return None
        # ---- low-level planning stages
        state, ids = self._state(ep, obs, pose)
        if ep.stage == "retrieve_reach":
            plan = self._plan_reach(ep, state, ids, self._target_id(ep))
            return self._queue(ep, plan, ids, next_stage="retrieve_extract")
        if ep.stage == "retrieve_extract":
            tid = self._target_id(ep)
            plan = self._plan_hold(ep, state, ids, tid, max_y=C.RETRIEVED_Y - self.extract_margin)
            return self._queue(ep, plan, ids, next_stage="retrieved")
        if ep.stage == "retrieved":  # the extract plan ran out but the episode goes on: it failed
            logger.warning("retrieval plan executed but the task did not end; moving out and searching again")
            return self._fail(ep)
        if ep.stage == "rearrange_reach":
            if ep.rearrange_id not in ids:
                return self._fail(ep, "the object to rearrange is no longer known")
            plan = self._plan_reach(ep, state, ids, ep.rearrange_id)
            return self._queue(ep, plan, ids, next_stage="rearrange_place")
        if ep.stage == "rearrange_place":
            if ep.rearrange_id not in ids:
                return self._fail(ep, "the object to rearrange is no longer known")
            spot = self._free_spot(ep, state, ids, ep.rearrange_id)
            if spot is None:
                return self._fail(ep, "no free spot at the back of the shelf")
            plan = self._plan_hold(ep, state, ids, ep.rearrange_id, spot=spot, finish=[np.array([0.0, 0.0, 0.0, OPEN])])
            if plan.success:
                ep.rearranged.add(ep.rearrange_id)
            return self._queue(ep, plan, ids, next_stage="move_out")
        raise RuntimeError(f"unknown stage {ep.stage!r}")  # pragma: no cover

    def _fail(self, ep: _Episode, why: str | None = None) -> None:
        if why:
            logger.warning("%s; moving out and searching again", why)
        ep.failures += 1
        ep.force_sweep = True
        ep.stage = "move_out"
        return None

    def _queue(self, ep: _Episode, plan: PlanResult | None, ids: list[int], next_stage: str) -> np.ndarray | None:
        if plan is None or not plan.success:
            return self._fail(ep)
        ep.queue.extend(plan.actions)
        if plan.final is not None:
            ep.predicted = {tid: plan.final.object_poses[i].copy() for i, tid in enumerate(ids)}
        ep.stage = next_stage
        if not ep.queue:
            return None
        return ep.queue.popleft()

    # ------------------------------------------------------------------ low-level queries
    def _budget_ok(self, ep: _Episode) -> bool:
        if ep.planning_seconds >= self.time_limit:
            if not ep.out_of_time:
                logger.warning("planning time %.1f s exceeds the %.0f s limit: no more planning this episode", ep.planning_seconds, self.time_limit)
            ep.out_of_time = True
            return False
        return True

    def _solve(self, ep: _Episode, world: ShelfWorld, goal: _GoalSpec, grip: float, finish=None, t0: float | None = None) -> PlanResult:
        t0 = time.perf_counter() if t0 is None else t0
        self._queries += 1
        problem = SimControlProblem(world, goal, grip, self.planner, seed=self.seed * 100_003 + self._queries)
        seconds = min(self.plan_seconds, max(self.time_limit - ep.planning_seconds, 1e-3))
        plan = problem.solve(seconds, shortcut=self.shortcut, finish=finish)
        elapsed = time.perf_counter() - t0
        ep.planning_seconds += elapsed
        plan.seconds = elapsed
        ep.plans.append(plan)
        if plan.success:
            logger.info("%s plan: %d actions (OMPL path %d) in %.2f s, %d propagations", plan.name, len(plan.actions), plan.raw_length, elapsed, plan.propagations)
        else:
            logger.warning(
                "%s plan not found within %.2f s (%s, %d propagations)", plan.name, seconds, plan.status, plan.propagations
            )
        return plan

    def _plan_reach(self, ep: _Episode, state: RecreatedState, ids: list[int], tid: int | None) -> PlanResult | None:
        if not self._budget_ok(ep):
            return None
        if tid is None or tid not in ids:
            logger.warning("reach: object %s is not in the known state", tid)
            return None
        t0 = time.perf_counter()
        world = make_world(state)
        i = ids.index(tid)
        polys = world.object_world_polygons()
        from occrl.baselines.scripted import plan_grasp

        angle, grasp = plan_grasp(polys[i], [p for j, p in enumerate(polys) if j != i], prefer_angle=float(state.gripper_pose[2]))
        goal = ReachGoal(i, world.nominal_vertices, (grasp[0], grasp[1], angle))
        return self._solve(ep, world, goal, OPEN, t0=t0)

    def _plan_hold(self, ep, state, ids, tid, max_y=None, spot=None, finish=None) -> PlanResult | None:
        if not self._budget_ok(ep):
            return None
        if tid is None or tid not in ids:
            logger.warning("hold: object %s is not in the known state", tid)
            return None
        t0 = time.perf_counter()
        world = make_world(state)
        i = ids.index(tid)
        goal = HoldGoal(i, world.gripper_pose(), world.object_poses()[i], max_y=max_y, spot=spot, radius=self.place_radius)
        return self._solve(ep, world, goal, CLOSE, finish=finish, t0=t0)

    # ------------------------------------------------------------------ heuristics
    def _closest_object(self, ep: _Episode, pose: np.ndarray) -> int | None:
        """The known non-target object closest to the gripper (not yet rearranged, if possible)."""
        cands = [k for k in ep.memory.values() if not k.is_target]
        fresh = [k for k in cands if k.type_id not in ep.rearranged]
        cands = fresh or cands
        if not cands:
            return None
        return min(cands, key=lambda k: math.hypot(k.pose[0] - pose[0], k.pose[1] - pose[1])).type_id

    def _free_spot(self, ep: _Episode, state: RecreatedState, ids: list[int], tid: int) -> np.ndarray | None:
        """A spot at the back of the shelf for object ``tid``: its footprint (current
        orientation) clear of the known objects and walls by 1.5 cm, reachable by the open
        gripper, and preferably seen empty from some view of this episode; among those the
        nearest to the object."""
        i = ids.index(tid)
        obj = state.objects[i]
        others = [o.world_vertices() for j, o in enumerate(state.objects) if j != i]
        r = float(np.linalg.norm(obj.vertices, axis=1).max())
        xmax = C.SHELF_HALF_WIDTH - max(r, _STROKE_HALF + C.FINGER_WIDTH) - 0.01
        views = np.array(ep.views[:: max(1, len(ep.views) // 25)])
        best, best_key = None, None
        for y in (C.SHELF_DEPTH - r - 0.015, C.SHELF_DEPTH - r - 0.065):
            for x in np.arange(-xmax, xmax + 1e-9, 0.01):
                poly = transform_points(obj.vertices, (x, y, obj.pose[2]))
                if any(polygons_overlap(poly, o, clearance=0.015) for o in others):
                    continue
                seen = max((visible_fractions([poly], v, others + _WALLS)[0] for v in views), default=0.0)
                dist = math.hypot(x - obj.pose[0], y - obj.pose[1])
                key = (seen < 0.9, y < C.SHELF_DEPTH - r - 0.04, dist)
                if best_key is None or key < best_key:
                    best, best_key = np.array([x, y]), key
        return best

    def _move_out_action(self, pose: np.ndarray) -> np.ndarray | None:
        """Move_out: back straight out of the shelf (world -y, heading kept, gripper open) until
        no part of the gripper is inside; None when already out."""
        if not _inside(pose):
            return None
        target = np.array([pose[0], min(self.search_y, _OUT_Y - 0.005), pose[2]])
        if abs(pose[2]) > math.pi / 4 and pose[1] <= _OUT_Y:
            target[2] = 0.0  # out, but turned too far to tell: face the shelf
        return steer_action(pose, target, OPEN)
