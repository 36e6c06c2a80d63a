"""Goal regions of the hierarchical baseline's OMPL queries: reach (the object alone between the
open fingers) and hold (the object held, pulled out or placed), with the heuristic distances and
goal samples the planner uses (see :mod:`occrl.baselines.kinodynamic` for the formulation), and
the simulated state the goals are evaluated on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import polygons_overlap, transform_points
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons, inverse_pose
from occrl.envs.pymunk2d.world import ShelfWorld

from occrl.baselines.motion import between_fingers
from occrl.baselines.scripted import plan_grasp

__all__ = ["SimEntry", "GoalSpec", "ReachGoal", "HoldGoal", "grasp_poses", "compose_pose", "MAX_GRASP_ANGLE"]

MAX_GRASP_ANGLE = math.radians(50.0)  # reach goals: grasps with the arm turned at most this much


@dataclass
class SimEntry:
    """One simulated world state: the snapshot and what the planner needs of it."""

    snap: dict
    gripper_pose: np.ndarray
    object_poses: np.ndarray
    opening: float
    closed: bool
    held: int | None
    valid: bool


def compose_pose(a, b) -> np.ndarray:
    """Pose ``b`` (given in the frame of pose ``a``) in the frame ``a`` is given in."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])


class GoalSpec:
    """A goal region on the simulator state (a table entry), with what the planner needs besides:
    two *features* of a state that join the gripper pose in the OMPL state (so that nearest
    neighbours tell apart states whose gripper poses agree but whose objects do not), their
    bounds, a heuristic distance outside the region, and goal samples (gripper pose, features)."""

    name = "goal"
    feature_bounds = ((-0.4, 0.4), (-0.3, 0.6))

    def satisfied(self, e: "SimEntry") -> bool:  # pragma: no cover - interface
        raise NotImplementedError

    def distance(self, e: "SimEntry") -> float:  # pragma: no cover - interface
        raise NotImplementedError

    def features(self, e: "SimEntry") -> tuple[float, float]:  # pragma: no cover - interface
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, tuple[float, float]]:  # pragma: no cover - interface
        raise NotImplementedError


class ReachGoal(GoalSpec):
    """Object ``index`` alone between the open fingers, ``margin`` inside the grasp rule: lying
    across the axis with ``margin`` to either finger, its centre ``margin`` within the fingers.

    ``grasp_poses`` (world frame, best first, for the object at ``object_pose``) are heuristic
    gripper poses in the region; they are kept relative to the object, so they follow it when it
    is pushed. Features: the object's centre in the gripper frame. Goal samples are drawn from the
    grasp poses (the best most often); the distance outside the region is to the nearest one.

    Examples:
        >>> from occrl.baselines.goals import ReachGoal, grasp_poses
        >>> from occrl.baselines.kinodynamic import SimControlProblem
        >>> from occrl.baselines.motion import OPEN
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
        self.relative = np.array([compose_pose(inv, g) for g in grasps])  # grasp poses in the object frame
        self.grasp_poses = grasps
        w = 1.0 / (1.0 + np.arange(len(grasps)))
        self._p = w / w.sum()

    def satisfied(self, e: "SimEntry") -> bool:
        if e.closed or e.opening < C.GRIPPER_STROKE - 1e-6 or abs(e.gripper_pose[2]) > MAX_GRASP_ANGLE:
            return False
        return between_fingers(e.gripper_pose, e.opening, self.vertices, e.object_poses, self.index, self.margin)

    def distance(self, e: "SimEntry") -> float:
        if self.satisfied(e):
            return 0.0
        obj = e.object_poses[self.index]
        best = math.inf
        for rel in self.relative:
            g = compose_pose(obj, rel)
            d = math.hypot(g[0] - e.gripper_pose[0], g[1] - e.gripper_pose[1]) + 0.1 * abs(g[2] - e.gripper_pose[2])
            best = min(best, d)
        return 1e-3 + best

    def features(self, e: "SimEntry") -> tuple[float, float]:
        p = transform_points(e.object_poses[self.index][None, :2], inverse_pose(e.gripper_pose))[0]
        return float(p[0]), float(p[1])

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, tuple[float, float]]:
        k = rng.choice(len(self.relative), p=self._p)
        pose = self.grasp_poses[k] + rng.normal(0.0, [0.003, 0.003, 0.02])
        f = compose_pose(inverse_pose(self.relative[k]), np.zeros(3))  # the object in the grasp frame
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
        >>> from occrl.baselines.goals import grasp_poses
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs import world_constants as C
        >>> from occrl.envs.pymunk2d.fingers import grasp_candidate
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> world = ShelfWorld(Scene.from_objects([{"vertices": box, "pose": (0.0, 0.15, 0.0), "is_target": True}]))
        >>> poses = grasp_poses(world, 0)
        >>> poses.shape, poses[0].round(3).tolist()  # best first: straight on, palm 5 mm short of the box
        ((8, 3), [0.0, 0.125, 0.0])
        >>> grasp_candidate(poses[0], C.GRIPPER_STROKE, world.object_world_polygons())[0]  # closing there holds it
        0
    """
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
            if not between_fingers(pose, C.GRIPPER_STROKE, world.nominal_vertices, poses, index, margin):
                continue
            g = [transform_points(p, pose) for p in parts]
            if any(polygons_overlap(q, w, clearance=0.002) for q in g for w in SHELF_WALLS):
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


class HoldGoal(GoalSpec):
    """Object ``index`` held, with its centroid past ``max_y`` (retrieve) or within ``radius`` of
    ``spot`` (rearrange). Features: the object's position. Goal samples: the start gripper pose
    moved by what the object has to move.

    Examples:
        >>> from occrl.baselines.goals import HoldGoal
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

    def _error(self, e: "SimEntry") -> float:
        p = e.object_poses[self.index]
        if self.spot is None:
            return max(0.0, p[1] - self.max_y)
        return max(0.0, math.hypot(p[0] - self.spot[0], p[1] - self.spot[1]) - self.radius)

    def satisfied(self, e: "SimEntry") -> bool:
        return e.held == self.index and self._error(e) <= 0.0

    def distance(self, e: "SimEntry") -> float:
        if e.held != self.index:
            d = self.goal_pose - e.gripper_pose
            return 1.0 + math.hypot(d[0], d[1])
        err = self._error(e)
        return 0.0 if err <= 0.0 else 1e-3 + err

    def features(self, e: "SimEntry") -> tuple[float, float]:
        p = e.object_poses[self.index]
        return float(p[0]), float(p[1])

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, tuple[float, float]]:
        jitter = rng.normal(0.0, [0.01, 0.01, 0.05])
        return self.goal_pose + jitter, (float(self.goal_xy[0] + jitter[0]), float(self.goal_xy[1] + jitter[1]))
