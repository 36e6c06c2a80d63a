"""The planning side of the perception boundary: recreate a pymunk state from detections.

Only ``ShelfEnv``'s observation keys are read (detected objects' type, pose and shape prior, the
gripper, the target's type and shape); never ``"privileged"``. This is also where a real robot's
detections enter (see :func:`occrl.envs.observation_from_detections`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Sequence

import numpy as np
from tensordict import TensorDictBase

from occrl.envs import world_constants as C
from occrl.envs.geometry import edge_normals, pad_polygons, transform_points
from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS
from occrl.envs.scene import Scene, SceneObject
from occrl.envs.shelf_geometry import gripper_polygons
from occrl.envs.pymunk2d.fingers import grasp_candidate
from occrl.envs.pymunk2d.world import ShelfWorld

__all__ = ["RecreatedState", "recreate", "with_target", "make_world", "WorldPool"]

# the planners' imagined worlds: the execution physics, without the validity measure
PLANNING_PHYSICS = replace(DEFAULT_PHYSICS, measure_validity=False)


@dataclass(frozen=True)
class RecreatedState:
    """What the robot knows now: detected objects, gripper, and the target's type and shape.

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState(objects=(), gripper_pose=(0.0, -0.1, 0.0), opening=0.085, closed=False,
        ...                        target_type=1, target_vertices=box)
        >>> state.target_detected, state.polygons()
        (False, [])
    """

    objects: tuple[SceneObject, ...]
    gripper_pose: tuple[float, float, float]
    opening: float
    closed: bool
    target_type: int
    target_vertices: np.ndarray
    # the target is taken to be in hand although the camera does not see it (closed fingers that
    # stopped apart with no detected object between them): imagined worlds keep it unseen while held
    target_unseen_in_hand: bool = False

    @property
    def target_detected(self) -> bool:
        return any(o.is_target for o in self.objects)

    def polygons(self) -> list[np.ndarray]:
        return [o.world_vertices() for o in self.objects]

    @cached_property
    def obstacle_outlines(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """What a hypothesised target must not overlap: each known object's and gripper part's
        shelf-frame outline with its bounding box's corners (outline, lo, hi); computed once per
        state (:func:`target_fits` tries many poses against it)."""
        outlines = self.polygons() + [transform_points(p, self.gripper_pose) for p in gripper_polygons(self.opening)]
        return [(p, p.min(0), p.max(0)) for p in outlines]

    @cached_property
    def obstacle_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """The :attr:`obstacle_outlines`' bounding boxes' corners as two (O, 2) arrays (lo, hi),
        for testing a pose against all of them at once."""
        outlines = self.obstacle_outlines
        return np.array([lo for _, lo, _ in outlines]).reshape(-1, 2), np.array([hi for _, _, hi in outlines]).reshape(-1, 2)

    @cached_property
    def obstacle_axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The :attr:`obstacle_outlines` for the separating-axis test of many poses at once: their
        points (O, V, 2), unit outward edge normals (O, V, 2) and offsets (O, V)
        (:func:`~occrl.envs.geometry.edge_normals`, each outline's bit for bit its own), padded
        to the most vertices V by repeating each outline's first point, normal and offset (which
        changes neither its least projection on an axis nor whether one of its edges separates)."""
        points = pad_polygons([p for p, _, _ in self.obstacle_outlines])  # (the gripper's parts at least)
        counts = np.array([len(p) for p, _, _ in self.obstacle_outlines], dtype=np.int64)
        real = np.arange(points.shape[1]) < counts[:, None]  # (O, V): the outline's own edges
        with np.errstate(invalid="ignore"):  # the padding's zero-length edges: replaced below
            normals, offsets = edge_normals(points)
        normals = np.where(real[..., None], normals, normals[:, :1])
        offsets = np.where(real, offsets, offsets[:, :1])
        return points, normals, offsets


def recreate(obs: TensorDictBase) -> RecreatedState:
    """Recreate the known state from one observation (a tensordict without batch dims).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs import observation_from_detections
        >>> from occrl.planners import recreate
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> obs = observation_from_detections((0.0, -0.1, 0.0), 0.085,
        ...     [{"type_id": 2, "pose": (0.1, 0.2, 0.0), "vertices": box}], target_type=1,
        ...     target_vertices=np.array(box))
        >>> state = recreate(obs[0])
        >>> len(state.objects), state.objects[0].type_id, state.target_detected, state.closed
        (1, 2, False, False)
    """
    det = obs.get(("objects", "detected")).cpu().numpy().astype(bool)
    type_id = obs.get(("objects", "type_id")).cpu().numpy()
    pose = obs.get(("objects", "pose")).cpu().numpy().astype(float)
    verts = obs.get(("objects", "vertices")).cpu().numpy().astype(float)
    nv = obs.get(("objects", "num_vertices")).cpu().numpy()
    target_type = int(obs.get("target_type").reshape(-1)[0])
    objects = tuple(
        SceneObject(int(type_id[k]), verts[k, : nv[k]], tuple(pose[k]), bool(type_id[k] == target_type)) for k in np.flatnonzero(det)
    )
    tnv = int(obs.get("target_num_vertices").reshape(-1)[0])
    return _with_unseen_held_target(
        RecreatedState(
            objects=objects,
            gripper_pose=tuple(float(v) for v in obs.get("gripper_pose").cpu().numpy()),
            opening=float(obs.get("gripper_opening").reshape(-1)[0]),
            closed=bool(obs.get("gripper_closed").reshape(-1)[0]),
            target_type=target_type,
            target_vertices=obs.get("target_vertices").cpu().numpy().astype(float)[:tnv],
        )
    )


AABB_MARGIN = 1e-6  # m: target_fits skips the separating-axis test for polygons whose boxes are further apart
HELD_MIN_OPENING = 0.005  # m: closed fingers further apart than this stopped on something


def _with_unseen_held_target(state: RecreatedState) -> RecreatedState:
    """Closed fingers that stopped apart hold something. If no detected object lies between them
    and the target is not detected, the held thing is taken to be the target (the fingers and the
    camera's closeness hide an object in hand): it is placed between the fingers, turned so that
    its width across them matches the opening, so the recreated world holds it too."""
    if not state.closed or state.target_detected or state.opening < HELD_MIN_OPENING:
        return state
    _, touching = grasp_candidate(state.gripper_pose, state.opening + 2e-3, state.polygons())
    if touching:  # a detected object between the fingers explains the opening
        return state
    angles = np.linspace(0.0, np.pi, 36, endpoint=False)
    best, best_err, local = 0.0, np.inf, state.target_vertices
    for a in angles:
        c, s = np.cos(a), np.sin(a)
        rot = state.target_vertices @ np.array([[c, s], [-s, c]])
        err = abs(np.ptp(rot[:, 0]) - state.opening)
        if err < best_err:
            best, best_err, local = a, err, rot
    y = float(np.clip(-local[:, 1].min() + 1e-3, 0.0, C.FINGER_LENGTH))  # centred across, inside the finger length
    position = transform_points(np.array([[0.0, y]]), state.gripper_pose)[0]
    pose = (float(position[0]), float(position[1]), float(state.gripper_pose[2] + best))
    held = SceneObject(state.target_type, state.target_vertices, pose, True)
    return replace(state, objects=state.objects + (held,), target_unseen_in_hand=True)


def target_fits(state: RecreatedState, pose) -> bool:
    """Can the target sit at ``pose`` without overlapping known objects, walls or the gripper?"""
    return first_fitting_pose(state, [pose]) == 0


def first_fitting_pose(state: RecreatedState, poses) -> int | None:
    """The index of the first of ``poses`` ((K, 3), tried in order) at which the target fits
    (:func:`target_fits`), or None: the same answer as trying them one by one, with the shelf
    bounds, the bounding boxes and then the separating-axis test of every pose that passes both
    and comes near an obstacle tested at once (bit for bit the one-by-one test's projections).

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, with_target
        >>> from occrl.planners.recreate import first_fitting_pose
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = with_target(RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, 1, box), (0.0, 0.2, 0.0))
        >>> first_fitting_pose(state, [(0.0, 0.2, 0.0), (0.0, -0.1, 0.0), (0.1, 0.2, 0.0)])  # on it; off the shelf; free
        2
    """
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    # every pose's outline: transform_points' arithmetic, pose by pose (math.cos / math.sin), the same values
    cos_sin = np.array([(math.cos(th), math.sin(th)) for th in poses[:, 2].tolist()]).reshape(-1, 2)
    c, s = cos_sin[:, 0, None], cos_sin[:, 1, None]
    p = np.asarray(state.target_vertices, dtype=float)
    polys = np.empty((len(poses), *p.shape))
    polys[..., 0] = c * p[..., 0] - s * p[..., 1] + poses[:, 0, None]
    polys[..., 1] = s * p[..., 0] + c * p[..., 1] + poses[:, 1, None]
    lo, hi = polys.min(1), polys.max(1)  # (K, 2)
    on_shelf = (lo[:, 0] >= -C.SHELF_HALF_WIDTH) & (hi[:, 0] <= C.SHELF_HALF_WIDTH) & (lo[:, 1] >= 0.0) & (hi[:, 1] <= C.SHELF_DEPTH)
    # the separating-axis test (polygons_overlap's) only where the bounding boxes come within
    # AABB_MARGIN (boxes further apart cannot overlap: the test would say so too, the margin keeps
    # its rounding out), for every such pose and obstacle at once
    los, his = state.obstacle_boxes
    near = np.logical_and.reduce((los - hi[:, None] <= AABB_MARGIN) & (lo[:, None] - his <= AABB_MARGIN), 2)  # (K, O)
    candidates = np.flatnonzero(on_shelf)
    if not len(candidates) or not near[candidates[0]].any():  # none on the shelf, or the first is clear of everything
        return int(candidates[0]) if len(candidates) else None
    pose, obstacle = np.nonzero(near[candidates])  # the pairs to test (pose: an index into candidates)
    blocked = np.zeros(len(candidates), bool)
    blocked[pose[_overlapping(state, polys[candidates], pose, obstacle)]] = True
    clear = np.flatnonzero(~blocked)
    return int(candidates[clear[0]]) if len(clear) else None


def _overlapping(state: RecreatedState, polys: np.ndarray, pose: np.ndarray, obstacle: np.ndarray) -> np.ndarray:
    """Whether target outline ``polys[pose[j]]`` overlaps obstacle outline ``obstacle[j]``
    (:attr:`RecreatedState.obstacle_axes`), for every pair j: the separating-axis test of
    :func:`~occrl.envs.geometry.polygons_overlap`, bit for bit (the projections are the same
    products, one matrix product per pair as ``separated_along`` makes them)."""
    points, normals, offsets = state.obstacle_axes
    own_normals, own_offsets = edge_normals(polys)  # (K, V, 2), (K, V)
    # the obstacle's points all beyond one of the target's edges
    least = np.matmul(points[obstacle], own_normals[pose].transpose(0, 2, 1)).min(1)  # (J, V)
    separated = np.logical_or.reduce(least - own_offsets[pose] >= 0.0, 1)
    # else the target's points all beyond one of the obstacle's edges
    rest = np.flatnonzero(~separated)
    if len(rest):
        least = np.matmul(polys[pose[rest]], normals[obstacle[rest]].transpose(0, 2, 1)).min(1)
        separated[rest] = np.logical_or.reduce(least - offsets[obstacle[rest]] >= 0.0, 1)
    return ~separated


def with_target(state: RecreatedState, pose) -> RecreatedState:
    """The state with the target hypothesised at ``pose`` (for a heat-map root).

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> hypothesis = with_target(state, (-0.1, 0.2, 0.0))
        >>> hypothesis.target_detected, len(hypothesis.objects), len(state.objects)  # the input is unchanged
        (True, 1, 0)
    """
    target = SceneObject(state.target_type, state.target_vertices, tuple(float(v) for v in pose), True)
    return replace(state, objects=state.objects + (target,))


def make_world(state: RecreatedState) -> ShelfWorld:
    """A nominal (noise-free) pymunk world of a recreated state, gripper and grasp included.
    It integrates as the execution world does (``DEFAULT_PHYSICS``) but skips the validity
    measure, which no planner reads. A target taken to be in hand unseen stays unseen by the
    world's camera while it is held (as the real camera did not see it there).

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, make_world, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> world = make_world(with_target(state, (-0.1, 0.2, 0.0)))
        >>> world.gripper_pose().round(3).tolist(), world.object_poses().round(3).tolist()
        ([0.0, -0.1, 0.0], [[-0.1, 0.2, 0.0]])
    """
    world = ShelfWorld(Scene.unchecked(state.objects, state.gripper_pose), physics=PLANNING_PHYSICS)
    _set_gripper(world, state)
    return world


def _set_gripper(world: ShelfWorld, state: RecreatedState) -> None:
    held = None
    if state.closed:
        held, _ = grasp_candidate(state.gripper_pose, state.opening + 2e-3, state.polygons())
    world.set_gripper_state(state.opening, state.closed, held)
    world.unseen_while_held = world.target_index if state.target_unseen_in_hand else None


def _object_set(state: RecreatedState) -> tuple:
    """What a world is built from besides poses: each object's type, shape and target flag."""
    return (PLANNING_PHYSICS,) + tuple((o.type_id, np.asarray(o.vertices, float).tobytes(), o.is_target) for o in state.objects)


class WorldPool:
    """Imagined worlds kept between uses, so that the planner does not rebuild pymunk worlds.

    :meth:`take` hands out one world per state: a kept world built for the same objects (types,
    shapes, which is the target) is set to the state (``ShelfWorld.set_poses`` and the gripper);
    else a kept world with as many objects takes the new ones (``ShelfWorld.rebuild``); only
    when there is neither is a new one built with :func:`make_world`. Either way the world steps
    bit for bit as ``make_world(state)`` would (tested). Each call takes back every world the
    previous call handed out, so a caller holds one call's worlds at a time; at most
    ``max_kept`` idle worlds are kept (the least recently built object sets go first). The
    default keeps every roll-out world of a batch of 16 worlds planned with up to 3 roots x 6
    roll-outs (288) until the same world's next decision (a world takes about 0.1 MB).

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, WorldPool, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> pool = WorldPool()
        >>> first = pool.take([with_target(state, (-0.1, 0.2, 0.0))] * 2)
        >>> again = pool.take([with_target(state, (0.1, 0.2, 0.0))])  # the same objects elsewhere: kept world reused
        >>> any(again[0] is w for w in first), again[0].object_poses().round(3).tolist(), pool.built
        (True, [[0.1, 0.2, 0.0]], 2)
        >>> other = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=2, target_vertices=2 * box)
        >>> pool.take([with_target(other, (0.0, 0.2, 0.0))])[0] is again[0], pool.built, pool.rebuilt  # as many objects
        (True, 2, 1)
    """

    def __init__(self, max_kept: int = 512) -> None:
        if isinstance(max_kept, bool) or not isinstance(max_kept, int) or max_kept < 0:
            raise ValueError(f"max_kept must be an int >= 0, got {max_kept!r}")
        self.max_kept = max_kept
        self.built = 0  # worlds built so far
        self.rebuilt = 0  # kept worlds that took other objects (ShelfWorld.rebuild); the rest were set to new poses
        self._idle: dict[tuple, list[ShelfWorld]] = {}
        self._lent: list[tuple[tuple, ShelfWorld]] = []

    def __getstate__(self) -> dict:
        # a cache: copies and pickles (process workers) start empty rather than carry pymunk spaces
        return {"max_kept": self.max_kept, "built": 0, "rebuilt": 0, "_idle": {}, "_lent": []}

    def take(self, states: Sequence[RecreatedState]) -> list[ShelfWorld]:
        """One world per state, set to it; the worlds of the previous call come back to the pool."""
        for key, world in self._lent:
            self._idle.setdefault(key, []).append(world)
        self._lent = []
        worlds = []
        for state in states:
            key = _object_set(state)
            if key in self._idle:
                world = self._pop_idle(key)
                world.set_poses(state.gripper_pose, np.array([o.pose for o in state.objects], float))
                _set_gripper(world, state)
            elif (other := self._idle_key_with(len(state.objects))) is not None:
                world = self._pop_idle(other)
                world.rebuild(Scene.unchecked(state.objects, state.gripper_pose))
                _set_gripper(world, state)
                self.rebuilt += 1
            else:
                world = make_world(state)
                self.built += 1
            self._lent.append((key, world))
            worlds.append(world)
        self._trim()
        return worlds

    def _pop_idle(self, key: tuple) -> ShelfWorld:
        """An idle world of the object set ``key``; a set without idle worlds leaves the pool (so
        that a long run does not collect the keys of every object set it has seen)."""
        worlds = self._idle[key]
        world = worlds.pop()
        if not worlds:
            del self._idle[key]
        return world

    def _idle_key_with(self, count: int) -> tuple | None:
        """The least recently kept object set with ``count`` objects (and the planning physics)
        that has an idle world, or None."""
        for key in self._idle:  # (the count first: comparing physics settings costs more)
            if len(key) - 1 == count and key[0] == PLANNING_PHYSICS:
                return key
        return None

    def _trim(self) -> None:
        kept = sum(len(v) for v in self._idle.values())
        for key in list(self._idle):
            if kept <= self.max_kept:
                break
            kept -= len(self._idle.pop(key))
