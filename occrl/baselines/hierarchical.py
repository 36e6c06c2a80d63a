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
detector's object identity) in an :class:`~occrl.baselines.object_memory.ObjectMemory` per world:
the last pose seen of every object and whether it is the target. Objects out of view keep their
last seen pose, or the pose the simulator predicted for them at the end of an executed plan; a
remembered pose that overlaps a fresher object or the gripper by more than 5 mm is dropped as
stale. Every observation's camera pose is kept with the object polygons known at that moment (for
:class:`HidingRegion`).

Hand-crafted primitives (the paper's heuristics):

* Search: move out of the shelf if inside, then sweep along ``y = search_y`` with the camera
  pointing in (theta = 0) from ``x = -sweep_x`` to ``x = +sweep_x`` at full lateral speed; every
  view adds detections. Defaults are literal: every Search is a complete left-to-right sweep.
  ``sweep_from="nearest"`` starts at the end nearer to the gripper and ``stop_when_located``
  ends a sweep as soon as the target is detected (a complete sweep is still forced after a failed
  plan, so a failure always costs actions and never loops silently). These two options are what
  makes Search, Rearrange, Move_out, Search, Retrieve fit into 50 actions.
* Move_out and the choices for Rearrange: :mod:`occrl.baselines.primitives`.

Low level. Retrieve and Rearrange are each two OMPL control queries in a nominal pymunk
:class:`~occrl.envs.ShelfWorld` built from the accumulated detections (:func:`make_world`), each
re-planned from the current observation once the previous plan was executed open-loop (one
planned action per env step, from a queue):

* Retrieve: (1) *reach*: gripper open, goal region = the target alone between the fingers with
  3 mm margins (the grasp rule of :func:`~occrl.envs.pymunk2d.fingers.grasp_candidate`), 2 mm clear of the
  palm (not being pushed), the arm turned at most 50 degrees; (2) *extract*: gripper closed, goal
  region = target held and its centroid ``extract_margin`` past the retrieval line.
* Rearrange: (1) *reach* the object (same region); (2) *place*: gripper closed, goal region =
  object held with its centroid within ``place_radius`` of the free spot and one opening action
  from there valid in the simulator (the release is part of the plan). Then Move_out.

The OMPL formulation is described in :mod:`occrl.baselines.kinodynamic`.

Timing: ``planning_seconds`` accumulates the wall time of all decisions of the current episode
(world building, OMPL, shortcutting, replay, Move_out simulation, hiding region); it is reset when
``is_init`` is true. It counts toward the task's 2-minute limit; past ``time_limit`` the planner
stops planning (logged) and only backs out.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.envs import world_constants as C
from occrl.envs.perception import OBSERVATION_KEYS
from occrl.envs.pymunk2d.world import ShelfWorld
from occrl.planners.recreate import RecreatedState, make_world

from occrl.baselines.hiding import HidingRegion
from occrl.baselines.hierarchical_state import EpisodeState, strayed
from occrl.baselines.goals import GoalSpec, HoldGoal, ReachGoal, grasp_poses
from occrl.baselines.kinodynamic import PlanResult, SimControlProblem, oc
from occrl.baselines.primitives import closest_object, free_spot, move_out
from occrl.baselines.motion import (
    CLOSE,
    OPEN,
    OUT_Y,
    is_at,
    is_inside_shelf,
    steer_action,
)

__all__ = ["HierarchicalPlanner", "ACTION_KINDS"]

# What an action of the planner does (``HierarchicalPlanner.last_action_kinds``): a Search sweep
# step, a Move_out step, or a step of a low-level plan (reach / extract the target, reach / place
# an object being rearranged).
ACTION_KINDS = ("search", "move_out", "reach", "extract", "rearrange_reach", "place")

logger = logging.getLogger(__name__)


class HierarchicalPlanner(TensorDictModuleBase):
    """The hierarchical baseline (paper Alg. 3) as a policy: ``env.rollout(50, policy=HierarchicalPlanner())``.

    Args:
        plan_seconds: time budget of one low-level OMPL query.
        planner: ``"rrt"`` (control RRT) or ``"kpiece"`` (control KPIECE1).
        sweep_x: the Search sweep runs from x = -sweep_x to +sweep_x.
        search_y: the sweep line (y of the gripper, outside the shelf).
        sweep_from: ``"left"`` (the paper: every sweep from the far left to the far right) or
            ``"nearest"`` (start at the end nearer to the gripper: no trip across first).
        stop_when_located: end a sweep as soon as the target is detected (also before it starts)
            instead of completing it; after a failed plan the next sweep is always complete.
        extract_margin: how far past the retrieval line the extract plan pulls the target.
        place_radius: how close to the chosen free spot a rearranged object must end.
        time_limit: stop planning when an episode's planning time exceeds this (the task limit).
        restart_seconds: a query restarts OMPL with a fresh tree after this long without a
            solution (None: one run per query); see :class:`SimControlProblem`.
        shortcut: post-process plans by straight steering in the simulator.
        avoid_hiding: while the target is unlocated, Rearrange's plans keep out of the region
            where it may hide (:class:`HidingRegion`) and the free spot avoids it.
        seed: with the count of queries so far, seeds each query (OMPL is re-seeded before every
            query, so a query is reproducible up to its time limit and restarts).
        follow_tolerance: ``None`` (the paper: a plan is executed open-loop to its end) or
            ``(metres, radians)``: a plan is kept only while the observed gripper pose stays this
            close to the pose the simulator predicted for it after each executed action; otherwise
            it is dropped and the current stage planned again from the observation (a closed-loop
            variant, and what lets the planner label the states another policy visits: see
            :class:`occrl.training.dagger.OnlineTeacherPolicy`).
        replan_inside: ``False`` (the paper: a Search starts outside the shelf, so a gripper
            inside is first moved out) or ``True``: where the planner would back the gripper out
            only to start a Search (a Search due while the gripper is inside the shelf, or a
            Move_out plan the world left), it plans from where the gripper is instead: the
            retrieval of a target it has seen, else the Rearrange of the closest known object.
            For a proposer whose plans another policy often leaves
            (:class:`occrl.baselines.hybrid_ompl.HybridOMPLPlanner`); needs ``follow_tolerance``.

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

    in_keys = ["is_init", *OBSERVATION_KEYS]
    out_keys = ["action"]

    def __init__(
        self,
        plan_seconds: float = 3.0,
        planner: str = "rrt",
        sweep_x: float = 0.2,
        search_y: float = -0.1,
        sweep_from: str = "left",
        stop_when_located: bool = False,
        extract_margin: float = 0.01,
        place_radius: float = 0.03,
        time_limit: float = 120.0,
        restart_seconds: float | None = 0.75,
        shortcut: bool = True,
        avoid_hiding: bool = True,
        seed: int = 0,
        follow_tolerance: tuple[float, float] | None = None,
        replan_inside: bool = False,
    ) -> None:
        super().__init__()
        if oc is None:
            raise ImportError('the hierarchical planner needs OMPL 2.x: pip install -e ".[ompl]"')
        if planner not in ("rrt", "kpiece"):
            raise ValueError(f"planner must be 'rrt' or 'kpiece', got {planner!r}")
        if plan_seconds <= 0:
            raise ValueError(f"plan_seconds must be > 0, got {plan_seconds}")
        if sweep_from not in ("left", "nearest"):
            raise ValueError(f"sweep_from must be 'left' or 'nearest', got {sweep_from!r}")
        if not C.GRIPPER_Y_LIMITS[0] <= search_y <= OUT_Y:
            raise ValueError(f"search_y must be in [{C.GRIPPER_Y_LIMITS[0]}, {OUT_Y}] (outside the shelf, reachable), got {search_y}")
        if not 0.0 < sweep_x <= C.GRIPPER_X_LIMITS[1]:
            raise ValueError(f"sweep_x must be in (0, {C.GRIPPER_X_LIMITS[1]}] m (the reachable width), got {sweep_x}")
        for name, value in (("extract_margin", extract_margin), ("place_radius", place_radius)):
            if not 0.0 <= value <= 0.2:
                raise ValueError(f"{name} must be in [0, 0.2] m, got {value}")
        if not time_limit > 0:
            raise ValueError(f"time_limit must be > 0 s, got {time_limit}")
        if restart_seconds is not None and not restart_seconds > 0:
            raise ValueError(f"restart_seconds must be None or > 0 s, got {restart_seconds}")
        if follow_tolerance is not None:
            if len(follow_tolerance) != 2 or not all(math.isfinite(v) and v > 0 for v in follow_tolerance):
                raise ValueError(f"follow_tolerance must be None or (metres > 0, radians > 0), got {follow_tolerance!r}")
            follow_tolerance = (float(follow_tolerance[0]), float(follow_tolerance[1]))
        if replan_inside and follow_tolerance is None:
            raise ValueError("replan_inside re-plans when the world leaves a Move_out plan: give a follow_tolerance too")
        self.follow_tolerance = follow_tolerance
        self.replan_inside = bool(replan_inside)
        self.plan_seconds = float(plan_seconds)
        self.planner = planner
        self.sweep_x = float(sweep_x)
        self.search_y = float(search_y)
        self.sweep_from = sweep_from
        self.stop_when_located = bool(stop_when_located)
        self.extract_margin = float(extract_margin)
        self.place_radius = float(place_radius)
        self.time_limit = float(time_limit)
        self.restart_seconds = None if restart_seconds is None else float(restart_seconds)
        self.shortcut = shortcut
        self.avoid_hiding = avoid_hiding
        self.seed = int(seed)
        self._queries = 0
        self.episodes: list[EpisodeState] = []

    # ------------------------------------------------------------------ bookkeeping
    @property
    def planning_seconds(self) -> float:
        return float(sum(ep.planning_seconds for ep in self.episodes))

    @property
    def planning_seconds_per_world(self) -> list[float]:
        return [ep.planning_seconds for ep in self.episodes]

    @property
    def last_action_kinds(self) -> list[str]:
        """What the last action of each world did (one of :data:`ACTION_KINDS`)."""
        return [ep.last_kind for ep in self.episodes]

    @property
    def last_plans(self) -> list[PlanResult]:
        return [p for ep in self.episodes for p in ep.plans]

    def planned_actions(self, world: int, count: int) -> np.ndarray:
        """The next ``count`` (at most) actions still queued for world ``world`` by its current
        low-level plan, (k, 4) with k <= count; empty between plans (Search steps are decided one
        at a time). The action :meth:`forward` returned last comes before them."""
        if not 0 <= world < len(self.episodes):
            raise ValueError(f"world must be in [0, {len(self.episodes)}) (the worlds of the last forward), got {world}")
        queued = list(self.episodes[world].queue)[: max(int(count), 0)]
        return np.clip(np.array(queued, dtype=float).reshape(-1, C.ACTION_DIM), -1.0, 1.0)

    def reseed(self, seed: int) -> None:
        """Restart the planner's seed sequence (evaluation reseeds per task for reproducibility)."""
        self.seed = int(seed)
        self._queries = 0

    def reset(self) -> None:
        self.episodes = []

    # ------------------------------------------------------------------ forward
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        actions = self.act_on_worlds(flat, range(flat.shape[0]))
        action = torch.as_tensor(actions, dtype=torch.float32).reshape(*tensordict.shape, C.ACTION_DIM)
        tensordict.set("action", action)
        return tensordict

    def act_on_worlds(self, flat: TensorDictBase, worlds) -> np.ndarray:
        """The next actions of the worlds ``worlds`` (indices) of a flat batch, shape (len(worlds),
        4); the other worlds are not asked, their episodes stand still (a decision maker that
        takes over some worlds, :class:`~occrl.baselines.handover.SearchThenRetrieve`, spares
        their planning)."""
        n = flat.shape[0]
        if len(self.episodes) != n:
            self.episodes = [EpisodeState() for _ in range(n)]
        is_init = flat.get("is_init").reshape(n).cpu().numpy() if "is_init" in flat.keys() else np.zeros(n, bool)
        actions = []
        for b in worlds:
            if is_init[b]:
                self.episodes[b] = EpisodeState()
            actions.append(self.act(self.episodes[b], flat[b]))
        return np.stack(actions) if actions else np.zeros((0, C.ACTION_DIM))

    def act(self, ep: EpisodeState, obs: TensorDictBase) -> np.ndarray:
        """The next action of one world (observation without batch dims)."""
        pose = obs.get("gripper_pose").cpu().numpy().astype(float)
        ep.step += 1
        ep.last_kind = "search"  # unless the action comes from a queued plan (EpisodeState.pop)
        if self.follow_tolerance is not None and ep.awaiting is not None and strayed(pose, ep.awaiting, self.follow_tolerance):
            ep.drop_plan(bool(obs.get("gripper_closed").reshape(-1)[0]), self.replan_inside)
        ep.awaiting = None
        ep.known.observe(obs, pose, ep.step, plan_running=bool(ep.queue))
        if ep.queue:
            return np.clip(ep.pop(), -1.0, 1.0)
        t0 = time.perf_counter()
        for _ in range(8):  # stages that produce no action hand over to the next one
            a = self._decide(ep, obs, pose)
            if a is not None:
                break
        else:  # pragma: no cover - defensive: every cycle of stages contains a sweep
            a = np.array([0.0, 0.0, 0.0, OPEN])
        ep.planning_seconds += time.perf_counter() - t0  # decisions and low-level planning
        return np.clip(a, -1.0, 1.0)

    # ------------------------------------------------------------------ the high level
    def _decide(self, ep: EpisodeState, obs: TensorDictBase, pose: np.ndarray) -> np.ndarray | None:
        """Advance the state machine by one stage; an action (or None: the next stage decides)."""
        if ep.stage == "move_out":
            ep.stage = "search"
            if not is_inside_shelf(pose):
                return None
            state, _ = ep.known.known_state(obs, pose, ep.step)
            actions, poses = move_out(state, pose, self._hiding(ep, state), self.search_y)
            ep.queue.extend(actions)
            ep.expected.clear()
            ep.expected.extend(poses)
            ep.queue_kind = "move_out"
            return ep.pop()
        if ep.stage == "search":
            if ep.sweep is None:  # a new Search
                ends = [np.array([-self.sweep_x, self.search_y, 0.0]), np.array([self.sweep_x, self.search_y, 0.0])]
                if self.sweep_from == "nearest" and pose[0] > 0.0:
                    ends.reverse()
                ep.sweep = ends
                ep.sweep_full = ep.force_sweep or not self.stop_when_located
                ep.force_sweep = False
            if not ep.sweep_full and ep.known.target_in_view:
                ep.sweep = []  # located: this Search is over
            elif is_inside_shelf(pose):  # Search starts outside the shelf
                if ep.plans_inside(self.replan_inside):
                    ep.sweep = None
                    ep.stage = "decide"
                else:
                    ep.stage = "move_out"
                return None
            while ep.sweep and is_at(pose, ep.sweep[0], tol_xy=2e-3, tol_th=math.radians(1.0)):
                ep.sweep.pop(0)
            if ep.sweep:
                return steer_action(pose, ep.sweep[0], OPEN)
            ep.sweep = None
            ep.stage = "decide"
            return None
        if ep.out_of_time:
            if is_inside_shelf(pose):
                ep.stage = "move_out"
                return None
            return np.array([0.0, 0.0, 0.0, OPEN])
        if ep.stage == "decide":
            if ep.known.target_id() is not None:
                ep.stage = "retrieve_reach"
            else:
                tid = closest_object(ep.known.objects.values(), ep.rearranged, pose)
                if tid is None:  # nothing known to move: look again
                    logger.info("no target and no object known: searching again")
                    ep.force_sweep = True
                    ep.stage = "search"
                    return None
                ep.rearrange_id = tid
                ep.stage = "rearrange_reach"
            return None
        # ---- low-level planning stages
        state, ids = ep.known.known_state(obs, pose, ep.step)
        if ep.stage == "retrieve_reach":
            plan = self._plan_reach(ep, state, ids, ep.known.target_id())
            return self._queue(ep, plan, ids, next_stage="retrieve_extract")
        if ep.stage == "retrieve_extract":
            tid = ep.known.target_id()
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
            spot = free_spot(state, ids.index(ep.rearrange_id), self._hiding(ep, state))
            if spot is None:
                return self._fail(ep, "no free spot at the back of the shelf")
            plan = self._plan_hold(ep, state, ids, ep.rearrange_id, spot=spot, finish=[np.array([0.0, 0.0, 0.0, OPEN])])
            if plan is not None and plan.success:
                ep.rearranged.add(ep.rearrange_id)
            return self._queue(ep, plan, ids, next_stage="move_out")
        raise RuntimeError(f"unknown stage {ep.stage!r}")  # pragma: no cover

    def _fail(self, ep: EpisodeState, why: str | None = None) -> None:
        if why:
            logger.warning("%s; moving out and searching again", why)
        ep.failures += 1
        ep.force_sweep = True
        ep.stage = "move_out"
        return None

    def _queue(self, ep: EpisodeState, plan: PlanResult | None, ids: list[int], next_stage: str) -> np.ndarray | None:
        if plan is None or not plan.success:
            return self._fail(ep)
        ep.queue.extend(plan.actions)
        ep.expected.clear()
        ep.expected.extend(plan.gripper_poses)
        ep.queue_kind = {"retrieve_extract": "reach", "retrieved": "extract", "rearrange_place": "rearrange_reach"}.get(next_stage, "place")
        if plan.final is not None:
            ep.known.expect({tid: plan.final.object_poses[i].copy() for i, tid in enumerate(ids)})
        ep.stage = next_stage
        if not ep.queue:
            return None
        return ep.pop()

    # ------------------------------------------------------------------ low-level queries
    def _budget_ok(self, ep: EpisodeState) -> bool:
        if ep.planning_seconds >= self.time_limit:
            if not ep.out_of_time:
                logger.warning(
                    "planning time %.1f s exceeds the %.0f s limit: no more planning this episode", ep.planning_seconds, self.time_limit
                )
            ep.out_of_time = True
            return False
        return True

    def _solve(self, ep: EpisodeState, world: ShelfWorld, goal: GoalSpec, grip: float, finish=None, t0=None, forbidden=None) -> PlanResult:
        t0 = time.perf_counter() if t0 is None else t0
        self._queries += 1
        seed = self.seed * 100_003 + self._queries
        problem = SimControlProblem(world, goal, grip, self.planner, restart_seconds=self.restart_seconds, seed=seed, forbidden=forbidden)
        seconds = min(self.plan_seconds, max(self.time_limit - ep.planning_seconds, 1e-3))
        plan = problem.solve(seconds, shortcut=self.shortcut, finish=finish)
        problem.close()
        elapsed = time.perf_counter() - t0
        plan.seconds = elapsed
        ep.plans.append(plan)
        if plan.success:
            logger.info(
                "%s plan: %d actions (OMPL path %d) in %.2f s, %d propagations",
                plan.name,
                len(plan.actions),
                plan.raw_length,
                elapsed,
                plan.propagations,
            )
        else:
            logger.warning("%s plan not found within %.2f s (%s, %d propagations)", plan.name, seconds, plan.status, plan.propagations)
        return plan

    def _query_world(self, ep: EpisodeState, state: RecreatedState, ids: list[int], tid: int | None, query: str):
        """(start time, world of the known state, index of object ``tid``) for a low-level query,
        or None when the time budget is spent or the object is not known."""
        if not self._budget_ok(ep):
            return None
        if tid is None or tid not in ids:
            logger.warning("%s: object %s is not in the known state", query, tid)
            return None
        return time.perf_counter(), make_world(state), ids.index(tid)

    def _plan_reach(self, ep: EpisodeState, state: RecreatedState, ids: list[int], tid: int | None) -> PlanResult | None:
        prepared = self._query_world(ep, state, ids, tid, "reach")
        if prepared is None:
            return None
        t0, world, i = prepared
        grasps = grasp_poses(world, i, prefer_angle=float(state.gripper_pose[2]))
        goal = ReachGoal(i, world.nominal_vertices, grasps, world.object_poses()[i])
        return self._solve(ep, world, goal, OPEN, t0=t0, forbidden=self._hiding(ep, state))

    def _plan_hold(self, ep, state, ids, tid, max_y=None, spot=None, finish=None) -> PlanResult | None:
        prepared = self._query_world(ep, state, ids, tid, "hold")
        if prepared is None:
            return None
        t0, world, i = prepared
        goal = HoldGoal(i, world.gripper_pose(), world.object_poses()[i], max_y=max_y, spot=spot, radius=self.place_radius)
        return self._solve(ep, world, goal, CLOSE, finish=finish, t0=t0, forbidden=self._hiding(ep, state))

    def _hiding(self, ep: EpisodeState, state: RecreatedState) -> HidingRegion | None:
        """Where the target may hide (None once it is located); cached per decision step."""
        if state.target_detected or not self.avoid_hiding:
            return None
        if ep.hiding is None or ep.hiding[0] != ep.step:
            views = ep.known.distinct_views(16)
            ep.hiding = (ep.step, HidingRegion(state.target_vertices, views, state.polygons()))
        return ep.hiding[1]
