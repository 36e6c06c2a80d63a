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
* Planner: set up as OMPL's demos do (``oc.SimpleSetup`` on the space information: start state,
  goal region, planner, ``solve``), ``oc.RRT`` (default; goal bias 0.25) or ``oc.KPIECE1`` (projection: the SE2 part's
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

The goal regions live in :mod:`occrl.baselines.goals`, steering and validity in
:mod:`occrl.baselines.motion`; this module holds the OMPL problem.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.pymunk2d.world import ShelfWorld

try:  # OMPL 2.x (nanobind bindings)
    from ompl import base as ob
    from ompl import control as oc
    from ompl import util as ou

    ou.setLogLevel(ou.LogLevel.LOG_WARN)
except ImportError:  # pragma: no cover - the baseline needs OMPL
    ob = oc = ou = None

from occrl.baselines.goals import GoalSpec, ReachGoal, SimEntry, compose_pose
from occrl.baselines.hiding import HidingRegion
from occrl.baselines.motion import count_intrusions, is_at, motion_allowed, steer_action

__all__ = ["SimControlProblem", "PlanResult", "ompl_seed"]

logger = logging.getLogger("occrl.baselines.hierarchical")


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


@dataclass
class PlanResult:
    """What one low-level query produced.

    Examples:
        >>> from occrl.baselines.goals import ReachGoal, grasp_poses
        >>> from occrl.baselines.kinodynamic import SimControlProblem
        >>> from occrl.baselines.motion import OPEN
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
    final: SimEntry | None = field(default=None, repr=False)
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
        >>> from occrl.baselines.goals import ReachGoal, grasp_poses
        >>> from occrl.baselines.kinodynamic import SimControlProblem
        >>> from occrl.baselines.motion import OPEN
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
        goal: GoalSpec,
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
            self._baseline = count_intrusions(world.gripper_pose(), world.opening, self.vertices, world.object_poses(), self.forbidden)
        self.table: list[SimEntry] = [self._entry(valid=None)]
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
    def _entry(self, valid: bool | None) -> SimEntry:
        w = self.world
        e = SimEntry(w.snapshot(), w.gripper_pose(), w.object_poses(), w.opening, w.closed, w.held, True)
        e.valid = self._penetration_free(e) if valid is None else valid
        return e

    def _penetration_free(self, e: SimEntry) -> bool:
        return motion_allowed(e.gripper_pose, e.opening, self.vertices, e.object_poses, self.forbidden, self._baseline)

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
            # the OMPL recipe: space information, start, goal region, planner, solve
            setup = oc.SimpleSetup(self.si)
            setup.addStartState(self.start_state())
            setup.setGoal(self._make_goal())
            if self.planner_name == "rrt":
                planner = oc.RRT(self.si)
                planner.setGoalBias(self.goal_bias)
            else:
                planner = oc.KPIECE1(self.si)
            setup.setPlanner(planner)
            budget = max(min(remaining, self.restart_seconds or remaining), 1e-6)
            status_text = setup.solve(ob.timedPlannerTerminationCondition(budget)).asString()
            if setup.haveExactSolutionPath():
                break
            setup.clear()
        self.attempts = attempts
        if not setup.haveExactSolutionPath():
            self.world.restore(start.snap)
            status_text = f"{status_text} ({attempts} attempts)"
            return PlanResult(name, False, [], status_text, time.perf_counter() - t0, self.propagations, 0, None)
        path = setup.getSolutionPath()
        indices = [self.index_of(st) for st in path.getStates()]
        controls = [np.array([path.getControl(i)[k] for k in range(C.ACTION_DIM)]) for i in range(path.getControlCount())]
        setup.clear()
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
            while not is_at(self.table[k].gripper_pose, target):
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
                targets += [compose_pose(obj, rel) for rel in self.goal.relative[:2]]
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
