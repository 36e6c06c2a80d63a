"""The hybrid planner planning from what it could not know: a diagnosis, and a privileged teacher.

:class:`OracleRootsPlanner` is the paper's hybrid planner (Alg. 1-2, the network's policy and
value unchanged) with its roots replaced by privileged ones, and optionally its value by roll-outs
to the episode's end:

- ``which="state"``: one root, the true state (:func:`true_state`): every object on the shelf at
  its true pose and shape, hidden ones included. At noise 0 the roll-outs then simulate the real
  future exactly, up to the policy's sampling.
- ``which="target"``: the recreated state (detected objects only) with the target at its true
  pose while it is not detected: a perfect heat-map.
- ``which="own"``: the planner's own roots (nothing privileged read).

``to_the_end=True``: each roll-out runs to the episode's action limit and is scored by its rewards
alone (no value at a horizon): a Monte-Carlo stand-in for a perfect value of the network's own
policy (about 10 s per stage-2 task on one core).

It reads ``"privileged"`` (the true state) unless ``which="own"``: analysis
(``scripts/oracle_roots.py``) and training labels (``TrainConfig.teacher_roots``), never a method.
"""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDictBase

from occrl.envs import SceneObject
from occrl.envs import world_constants as C
from occrl.planners import HybridPlanner, RecreatedState, Root, recreate, with_target
from occrl.planners.rhp import NetworkStepper

__all__ = ["ORACLE_ROOTS", "OracleRootsPlanner", "ZeroValueStepper", "true_state"]

ORACLE_ROOTS = ("state", "target", "own")


def true_state(obs: TensorDictBase) -> RecreatedState:
    """The true state of one observation (it reads ``"privileged"``): every object on the shelf at
    its true pose and shape, hidden ones included, the target where it is; the gripper as recreated.
    A held object is between the fingers at its true pose, so the imagined world grasps it."""
    state = recreate(obs)
    priv = obs.get("privileged")
    slot = int(priv.get("target_slot").reshape(-1)[0])
    poses = priv.get("object_pose").cpu().numpy().astype(float)
    present = priv.get("object_present").cpu().numpy().astype(bool)
    vertices = priv.get("object_vertices").cpu().numpy().astype(float)
    counts = priv.get("object_num_vertices").cpu().numpy()
    # rendering tells only the target from the rest: any other type id will do for clutter
    clutter_type = state.target_type + 1
    objects = tuple(
        SceneObject(state.target_type if k == slot else clutter_type, vertices[k, : counts[k]], tuple(poses[k]), k == slot)
        for k in np.flatnonzero(present)
    )
    return RecreatedState(objects, state.gripper_pose, state.opening, state.closed, state.target_type, state.target_vertices)


class ZeroValueStepper(NetworkStepper):
    """The roll-outs' network calls with a value of 0 at the horizon."""

    def value(self, out: dict[str, torch.Tensor]) -> torch.Tensor:
        return torch.zeros(out["loc"].shape[0])


class OracleRootsPlanner(HybridPlanner):
    """The hybrid planner planning from privileged roots (``which``: ``"state"`` or ``"target"``)
    or its own (``"own"``, no privileged key read); ``to_the_end``: roll-outs to the episode's
    action limit, scored by their rewards alone. The other arguments are
    :class:`~occrl.planners.HybridPlanner`'s; with ``to_the_end`` each world's roll-outs have
    their own depth, so its worlds are planned one by one (``batch_worlds=False``).

    Raises:
        ValueError: for an unknown ``which``, or ``to_the_end`` with ``batch_worlds=True``.
    """

    def __init__(self, net, which: str, to_the_end: bool = False, **kwargs) -> None:
        if which not in ORACLE_ROOTS:
            raise ValueError(f"which must be one of {ORACLE_ROOTS}, got {which!r}")
        if to_the_end and kwargs.get("batch_worlds", False):
            raise ValueError("to_the_end plans each world to its own episode's end: batch_worlds must be False")
        super().__init__(net, **kwargs)
        self.which = which
        self.to_the_end = to_the_end
        if to_the_end:  # the same network calls (spread floor, backend), the value left out
            self.stepper = ZeroValueStepper(net, self.stepper.min_scale, backend=self.inference)
        self.in_keys = [*self.in_keys, *(["privileged"] if which != "own" else []), "step_count"]

    def decide(self, obs: TensorDictBase, heatmap: np.ndarray, hidden):
        if self.to_the_end:  # the roll-outs' depth: the actions left in the episode
            self.h = max(1, C.MAX_EPISODE_STEPS - int(obs.get("step_count").reshape(-1)[0]))
        return super().decide(obs, heatmap, hidden)

    def roots(self, obs: TensorDictBase, heatmap: np.ndarray) -> list[Root]:
        if self.which == "own":
            return super().roots(obs, heatmap)
        if self.which == "state":
            return [Root(true_state(obs), 1.0)]
        state = recreate(obs)
        if state.target_detected:
            return [Root(state, 1.0)]
        priv = obs.get("privileged")
        slot = int(priv.get("target_slot").reshape(-1)[0])
        return [Root(with_target(state, tuple(priv.get("object_pose")[slot].cpu().numpy().astype(float))), 1.0)]
