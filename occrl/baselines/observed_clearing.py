"""The clearing retriever reading only what the camera reports: a teacher the network can follow.

:class:`~occrl.baselines.clearing.ClearingRetriever` plans from the true state, so on the
learner's own states its choices (which blocker, carried where) depend on objects the learner
cannot see, and a network imitating it learns an average of its plans (docs/lab/training-clearing.md).
:class:`ObservedClearingRetriever` makes the same decisions from the observation
history alone: every object detected so far in the episode where it was last seen (a detector's
identity, the type id; stale memories dropped as the hierarchical planner drops them,
:func:`~occrl.baselines.object_memory.current_objects`), and an object held between closed
fingers carried along with them. Its actions are then a function of the observation history,
which a recurrent network can learn.

It does not search: before the target has been detected in an episode it has nothing to
retrieve and holds still with the gripper open (:data:`NO_TARGET_ACTION`). As a teacher
(``occrl train --imitation-teacher clearing-observed``) it takes over in a share of the episodes
at the first detection and the frames it acts on are the labels; its answers on the learner's
own states are mostly "back out first", which the learner, trained
on them, learned to do everywhere (docs/lab/training-clearing.md).
"""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.envs import world_constants as C
from occrl.envs.geometry import transform_points
from occrl.envs.perception import OBSERVATION_KEYS
from occrl.envs.pymunk2d.fingers import grasp_candidate
from occrl.envs.shelf_geometry import gripper_polygons, inverse_pose
from occrl.planners.recreate import HELD_MIN_OPENING, recreate

from occrl.baselines.clearing import ClearingRetriever
from occrl.baselines.object_memory import KnownObject, current_objects

__all__ = ["ObservedClearingRetriever", "NO_TARGET_ACTION"]

#: what it does while the target has not been detected in the episode: nothing, gripper open
NO_TARGET_ACTION = np.array([0.0, 0.0, 0.0, -1.0])
_KEY_RESOLUTION = 1e-3  # m: target poses closer than this share a cached plan


class ObservedClearingRetriever(TensorDictModuleBase):
    """Clear the target's corridor and retrieve it, from observations only (module docstring).

    Per world it keeps, within an episode (``"is_init"`` starts one; without it, call
    :meth:`reset` between episodes), every object detected so far by type id with its last seen
    pose, and the pose in the gripper's frame of an object the closed fingers hold, which then
    moves with the gripper while the camera does not report it. Never reads ``"privileged"``.

    Args:
        lateral_tolerance, clear, simulate: as :class:`~occrl.baselines.clearing.ClearingRetriever`
            (``simulate`` simulates carries in a pymunk world of the known objects).

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.baselines.observed_clearing import ObservedClearingRetriever
        >>> env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False)
        >>> td = env.rollout(50, policy=ObservedClearingRetriever())  # the target is in view from the start
        >>> bool(td["next", "success"].any())
        True
    """

    def __init__(self, lateral_tolerance: float = 0.006, clear: str = "band", simulate: bool = True) -> None:
        super().__init__()
        self.retriever = ClearingRetriever(lateral_tolerance, clear, simulate)
        self.in_keys = ["is_init", *OBSERVATION_KEYS]
        self.out_keys = ["action"]
        self._memory: dict[int, dict[int, KnownObject]] = {}  # world -> type id -> what was seen of it
        self._steps: dict[int, int] = {}  # world -> observations in the episode so far
        self._held: dict[int, tuple[int, np.ndarray]] = {}  # world -> (type id, pose in the gripper frame)

    def reset(self) -> None:
        """Forget every world's episode and the retriever's cached plans."""
        self.retriever.reset()
        self._memory.clear()
        self._steps.clear()
        self._held.clear()

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        n = flat.shape[0]
        # without "is_init" (a plain ShelfEnv, no InitTracker) call reset() between episodes
        starts = flat.get("is_init").reshape(n).cpu().numpy().astype(bool) if "is_init" in flat.keys() else np.zeros(n, bool)
        actions = [self.act_on(b, flat[b], bool(starts[b])) for b in range(n)]
        action = torch.as_tensor(np.stack(actions), dtype=torch.float32)
        tensordict.set("action", action.reshape(*tensordict.shape, C.ACTION_DIM))
        return tensordict

    def act_on(self, world: int, obs: TensorDictBase, episode_start: bool) -> np.ndarray:
        """The action for world ``world`` from its observation (a tensordict without batch dims)."""
        if episode_start or world not in self._memory:
            self._memory[world], self._steps[world] = {}, 0
            self._held.pop(world, None)
        memory, step = self._memory[world], self._steps[world] + 1
        self._steps[world] = step
        state = recreate(obs)
        pose = np.asarray(state.gripper_pose, float)
        for o in state.objects:  # this observation's detections (and a target taken to be in hand)
            memory[o.type_id] = KnownObject(o.type_id, np.asarray(o.vertices, float), np.asarray(o.pose, float), o.is_target, step)
        holding = state.closed and state.opening >= HELD_MIN_OPENING
        if not holding:
            self._held.pop(world, None)
        elif world in self._held:  # the held object moves with the fingers, seen or not
            tid, local = self._held[world]
            if tid in memory and memory[tid].seen_step != step:
                position = transform_points(local[None, :2], pose)[0]
                memory[tid].pose, memory[tid].seen_step = np.array([*position, pose[2] + local[2]]), step
        gripper = [transform_points(p, pose) for p in gripper_polygons(state.opening)]
        known = current_objects(memory.values(), step, gripper)
        targets = [poly for k, poly in known if k.is_target]
        if not targets:
            return NO_TARGET_ACTION.copy()
        target = targets[0]
        ids = [k.type_id for k, _ in known if not k.is_target]
        clutter = [poly for k, poly in known if not k.is_target]
        held_target = holding and (state.target_unseen_in_hand or grasp_candidate(pose, state.opening + 2e-3, [target, *clutter])[0] == 0)
        if holding and not held_target and world not in self._held:
            between, _ = grasp_candidate(pose, state.opening + 2e-3, clutter)
            if between is not None:  # remember where in the fingers it sits
                k = memory[ids[between]]
                local = transform_points(k.pose[None, :2], inverse_pose(pose))[0]
                self._held[world] = (k.type_id, np.array([*local, k.pose[2] - pose[2]]))
        # cached plans hold for one target pose and one set of known objects (the retriever keys a
        # blocker by its place in ``clutter``, ordered by type id)
        key = np.round(target.mean(0) / _KEY_RESOLUTION).astype(np.int64).tobytes() + np.array(ids, np.int64).tobytes()
        return self.retriever.act(pose, state.closed, held_target, target, clutter, key)
