"""What a planner that reads only observations knows of the shelf: every object detected so far in
the episode.

A detector reports, per observation, the objects in view with their type id (the detector's
object identity), shape and pose. :class:`ObjectMemory` accumulates them over an episode: the
last pose seen of every object and whether it is the target; objects out of view keep their last
seen pose, or the pose a simulated plan predicted for them once that plan was executed to its end.
:func:`current_objects` turns the memory into a state to plan in: a remembered pose that overlaps
a fresher object or the gripper by more than :data:`~occrl.baselines.motion.STALE_OVERLAP` is
stale and dropped. Every observation's camera pose is kept with the object outlines known at that
moment (for :class:`~occrl.baselines.hiding.HidingRegion`).

:class:`~occrl.baselines.hierarchical.HierarchicalPlanner` keeps one memory per world;
:class:`~occrl.baselines.observed_clearing.ObservedClearingRetriever` shares
:class:`KnownObject` and :func:`current_objects`. Only observation keys are read, never
``"privileged"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable

import numpy as np
from tensordict import TensorDictBase

from occrl.envs.geometry import transform_points
from occrl.envs.remembered import still_where_seen
from occrl.envs.scene import SceneObject
from occrl.envs.shelf_geometry import gripper_polygons
from occrl.planners.recreate import RecreatedState

__all__ = ["KnownObject", "ObjectMemory", "current_objects"]


@dataclass
class KnownObject:
    """What the planner remembers of an object it has seen: its type id (a detector's object
    identity), shape, last seen (or predicted) pose, whether it is the target, and when it was
    last seen (decision step)."""

    type_id: int
    vertices: np.ndarray
    pose: np.ndarray
    is_target: bool
    seen_step: int


def current_objects(known: Iterable[KnownObject], step: int, gripper: list[np.ndarray]) -> list[tuple[KnownObject, np.ndarray]]:
    """The remembered objects taken to be where they were last seen, each with its shelf-frame
    outline, sorted by type id: freshest first, a remembered pose that overlaps a fresher object,
    or (unless seen at ``step``) the gripper's outlines ``gripper``, by more than
    :data:`~occrl.baselines.motion.STALE_OVERLAP` is stale and left out."""
    ordered = sorted(known, key=lambda k: -k.seen_step)  # freshest first
    outlines = [transform_points(k.vertices, k.pose) for k in ordered]
    fresh = sum(k.seen_step == step for k in ordered)  # the objects seen at ``step`` come first
    keep = still_where_seen(outlines[:fresh], [])
    keep += still_where_seen(outlines[fresh:], [q for q, ok in zip(outlines, keep) if ok], gripper)
    kept = [(k, q) for k, q, ok in zip(ordered, outlines, keep) if ok]
    kept.sort(key=lambda kp: kp[0].type_id)
    return kept


@dataclass
class ObjectMemory:
    """One world's memory of the objects detected in its episode (module docstring); a new
    episode starts a new memory.

    Attributes:
        objects: type id -> :class:`KnownObject`, every object detected so far.
        views: (gripper pose, shelf-frame outlines of the objects known then) of every observation.
        predicted: type id -> pose at the end of the plan being executed (:meth:`expect`), or None.
        target_in_view: whether the last observation detected the target.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.baselines.object_memory import ObjectMemory
        >>> env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False)
        >>> obs = env.reset()[0]
        >>> memory = ObjectMemory()
        >>> memory.observe(obs, obs["gripper_pose"].numpy().astype(float), step=1, plan_running=False)
        >>> memory.target_id() is not None, memory.target_in_view  # stage 1: the target is in view
        (True, True)
    """

    objects: dict = field(default_factory=dict)
    views: list = field(default_factory=list)
    predicted: dict | None = None
    target_in_view: bool = False

    def observe(self, obs: TensorDictBase, pose: np.ndarray, step: int, plan_running: bool) -> None:
        """Take in one observation (a tensordict without batch dims) made at decision ``step``
        with the gripper at ``pose``. Once a plan is no longer running, the objects out of view
        move to where the plan's simulation put them (:meth:`expect`)."""
        objects = obs.get("objects")
        det = objects.get("detected").cpu().numpy().astype(bool)
        type_id = objects.get("type_id").cpu().numpy()
        poses = objects.get("pose").cpu().numpy().astype(float)
        verts = objects.get("vertices").cpu().numpy().astype(float)
        nv = objects.get("num_vertices").cpu().numpy()
        target_type = int(obs.get("target_type").reshape(-1)[0])
        seen = set()
        self.target_in_view = bool(np.any(det & (type_id == target_type)))
        for k in np.flatnonzero(det):
            tid = int(type_id[k])
            seen.add(tid)
            self.objects[tid] = KnownObject(tid, verts[k, : nv[k]].copy(), poses[k].copy(), tid == target_type, step)
        if self.predicted is not None and not plan_running:
            # a plan was executed to its end: objects out of view are where the simulator put them
            for tid, p in self.predicted.items():
                if tid not in seen and tid in self.objects:
                    self.objects[tid].pose = np.asarray(p, float)
            self.predicted = None
        self.views.append((pose.copy(), [transform_points(k.vertices, k.pose) for k in self.objects.values()]))

    def expect(self, predicted: dict | None) -> None:
        """The poses (type id -> pose) a plan about to be executed leaves the objects in, per its
        simulation; None forgets them (the plan was dropped)."""
        self.predicted = predicted

    def target_id(self) -> int | None:
        """The target's type id once it has been detected in the episode, else None."""
        return next((tid for tid, k in self.objects.items() if k.is_target), None)

    def knows_non_target(self) -> bool:
        """Whether an object other than the target has been detected in the episode."""
        return any(not k.is_target for k in self.objects.values())

    def known_state(self, obs: TensorDictBase, pose: np.ndarray, step: int) -> tuple[RecreatedState, list[int]]:
        """The state to plan in: the remembered objects (stale ones that overlap fresher ones or
        the gripper dropped, :func:`current_objects`) and the gripper as observed; with the type id
        of each of the state's objects."""
        opening = float(obs.get("gripper_opening").reshape(-1)[0])
        closed = bool(obs.get("gripper_closed").reshape(-1)[0])
        gripper = [transform_points(p, pose) for p in gripper_polygons(opening)]
        kept = current_objects(self.objects.values(), step, gripper)
        objects = tuple(SceneObject(k.type_id, k.vertices, tuple(float(v) for v in k.pose), k.is_target) for k, _ in kept)
        tv = obs.get("target_vertices").cpu().numpy().astype(float)[: int(obs.get("target_num_vertices").reshape(-1)[0])]
        target_type = int(obs.get("target_type").reshape(-1)[0])
        state = RecreatedState(objects, tuple(float(v) for v in pose), opening, closed, target_type, tv)
        return state, [k.type_id for k, _ in kept]

    def distinct_views(self, most: int = 16) -> list:
        """The :attr:`views` from distinct gripper poses (rounded to the millimetre), thinned
        evenly to about ``most``."""
        views, seen = [], set()
        for v in self.views:
            key = tuple(np.round(v[0], 3))
            if key not in seen:
                seen.add(key)
                views.append(v)
        return views[:: max(1, len(views) // most)]
