"""Remembered detections: every object detected earlier in the episode kept at its last seen pose.

Beyond the paper (docs/lab/network-probes.md, "Remembered detections"). The paper's observation shows
only what the camera detects now; a target seen once and then hidden or out of view is left to
the LSTM to remember, and the network forgets it within a few actions (its heat-map's mass on
the target falls from 27 % while seen to 11 % one action after and 2.5 % eight or more after).
:class:`RememberedDetections` writes the memory into the detections themselves, so the image
draws a remembered object where it was last seen, in the robot-centric window of the current
pose, and the planners' recreated worlds hold it.

Rules, per world and episode (the same as the observation-only planners' memory,
:func:`occrl.baselines.object_memory.current_objects`):

- an object slot detected now takes the current detection, and the memory keeps it;
- a slot detected earlier and not now is filled from the memory (its type, pose and shape as
  last seen) and flagged in ``("objects", "remembered")``, unless its remembered outline overlaps
  an object detected now, a fresher remembered object, or the gripper by more than
  :data:`STALE_OVERLAP` (it has moved: the slot stays empty this step);
- an episode start (``"is_init"``, from TorchRL's ``InitTracker``) empties the world's memory.

Only observation keys are read, never ``"privileged"``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Categorical, Composite
from torchrl.envs.transforms import Transform

from occrl.envs.geometry import polygons_overlap, transform_points
from occrl.envs.shelf_geometry import gripper_polygons

__all__ = ["STALE_OVERLAP", "RememberedDetections", "still_where_seen"]

STALE_OVERLAP = 0.005  # m: a remembered outline overlapping a fresher one or the gripper deeper than this is stale
SLOT_KEYS = ("detected", "type_id", "pose", "vertices", "num_vertices")


def still_where_seen(outlines: Sequence[np.ndarray], fresher: Sequence[np.ndarray], gripper: Sequence[np.ndarray] = ()) -> list[bool]:
    """The staleness rule of every memory of detections: whether each remembered outline, in the
    order given (freshest first), is taken to be still where it was seen. One that overlaps a
    ``fresher`` outline, an outline kept before it, or a ``gripper`` outline by more than
    :data:`STALE_OVERLAP` has moved and is left out (pymunk lets bodies in contact overlap by a few
    millimetres: only deeper overlaps mean stale). Shared by :class:`RememberedDetections` and
    :func:`occrl.baselines.object_memory.current_objects`.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.remembered import still_where_seen
        >>> box = np.array([[0.0, 0.0], [0.04, 0.0], [0.04, 0.04], [0.0, 0.04]])
        >>> # a box seen now at the origin; remembered ones 3 mm, 2 cm and 10 cm to its right
        >>> still_where_seen([box + [0.037, 0.0], box + [0.02, 0.0], box + [0.1, 0.0]], fresher=[box])
        [True, False, True]
    """
    kept = list(fresher)
    keep = []
    for outline in outlines:
        ok = not any(polygons_overlap(outline, q, clearance=-STALE_OVERLAP) for q in (*kept, *gripper))
        keep.append(ok)
        if ok:
            kept.append(outline)
    return keep


class RememberedDetections(Transform):
    """Fill the undetected object slots with the episode's earlier detections (module docstring).

    Place it after ``InitTracker`` and before :class:`~occrl.envs.OcclusionRender`
    (``make_env(remembered_detections=True)`` does). Writes ``("objects", "remembered")``: which
    slots come from the memory.

    Examples:
        >>> import torch
        >>> from occrl.envs import make_env
        >>> env = make_env(batch_size=1, stage=2, seed=4, heatmap_target=False, remembered_detections=True)
        >>> td = env.rollout(6, lambda td: td.set("action", torch.tensor([[0.0, 1.0, 0.0, -1.0]])))
        >>> remembered = td["next", "objects", "remembered"]
        >>> bool((remembered <= td["next", "objects", "detected"]).all())  # a remembered slot is drawn as detected
        True
    """

    def __init__(self) -> None:
        super().__init__(in_keys=["objects", "gripper_pose", "gripper_opening", "is_init"], out_keys=[("objects", "remembered")])
        self._memory: dict[str, np.ndarray] | None = None  # per world and slot: last detection, and when
        self._clock: np.ndarray | None = None  # per world: observations so far in the episode

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        return self._call(tensordict_reset)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Apply to one observation of each world outside an env (batch ``(B,)``; successive calls
        are successive steps)."""
        return self._call(tensordict)

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        if "is_init" not in next_tensordict.keys():
            raise KeyError("RememberedDetections needs 'is_init' (put torchrl's InitTracker before it; make_env does)")
        if next_tensordict.batch_dims != 1:
            raise ValueError(
                f"RememberedDetections takes one observation per world, batch (B,); got batch {tuple(next_tensordict.batch_size)}"
            )
        td = next_tensordict
        objects = td.get("objects")
        now = {k: objects.get(k).cpu().numpy().copy() for k in SLOT_KEYS}
        B, N = now["detected"].shape
        if self._memory is None or self._memory["detected"].shape != (B, N):
            self._memory = {k: np.zeros_like(v) for k, v in now.items()}
            self._memory["seen"] = np.zeros((B, N), np.int64)
            self._clock = np.zeros(B, np.int64)
        memory, clock = self._memory, self._clock
        start = td.get("is_init").cpu().numpy().reshape(B)
        memory["detected"][start] = False
        clock[start] = 0
        clock += 1
        detected = now["detected"]
        for k in SLOT_KEYS:
            memory[k][detected] = now[k][detected]
        memory["seen"][detected] = np.broadcast_to(clock[:, None], (B, N))[detected]
        remembered = np.zeros((B, N), bool)
        poses = td.get("gripper_pose").cpu().numpy().astype(float)
        openings = td.get("gripper_opening").cpu().numpy().reshape(B).astype(float)
        for b in np.flatnonzero((memory["detected"] & ~detected).any(axis=1)):
            fresher = [self._outline(now, b, k) for k in np.flatnonzero(detected[b])]
            gripper = [transform_points(p, poses[b]) for p in gripper_polygons(float(openings[b]))]
            candidates = np.flatnonzero(memory["detected"][b] & ~detected[b])
            candidates = candidates[np.argsort(-memory["seen"][b, candidates], kind="stable")]  # freshest first
            keep = still_where_seen([self._outline(memory, b, k) for k in candidates], fresher, gripper)
            remembered[b, candidates[keep]] = True
        for k in SLOT_KEYS:
            now[k][remembered] = memory[k][remembered]
        shape = objects.batch_size
        for k in SLOT_KEYS:
            objects.set(k, torch.from_numpy(now[k]).reshape(*shape, *now[k].shape[2:]))
        objects.set("remembered", torch.from_numpy(remembered).reshape(shape))
        return next_tensordict

    @staticmethod
    def _outline(arrays: dict[str, np.ndarray], b: int, k: int) -> np.ndarray:
        """Shelf-frame outline of slot ``k`` of world ``b``."""
        return transform_points(arrays["vertices"][b, k, : arrays["num_vertices"][b, k]].astype(float), arrays["pose"][b, k].astype(float))

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        detected = observation_spec["objects", "detected"]
        observation_spec["objects", "remembered"] = Categorical(2, shape=detected.shape, dtype=torch.bool)
        return observation_spec
