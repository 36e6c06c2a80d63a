"""The perception boundary: turning the observation tensordict back into shelf-frame geometry.

Everything on the planning side goes through these functions, so a real robot plugs in by filling
the same keys the simulated envs fill (see :func:`observation_from_detections`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase

from occrl.envs import world_constants as C
from occrl.envs.observation import MAX_POLY_VERTICES, MAX_SLOTS, MAX_TYPE_ID, detected_world_polygons, pad_polygon
from occrl.envs.scene import canonical_polygon, validate_vertices
from occrl.perception.checks import finite_array, strict_int


__all__ = ["detected_polygons", "observation_from_detections", "DETECTION_KEYS", "OBSERVATION_KEYS"]

DETECTION_KEYS = ("type_id", "pose", "vertices")
# What a decision maker that reads only perception may read of an observation (besides the
# network input "pixels" and the episode-start flag "is_init"): the gripper's state, the
# detections under "objects", and the target's type and shape (observation_from_detections).
OBSERVATION_KEYS = (
    "gripper_pose",
    "gripper_opening",
    "gripper_closed",
    "objects",
    "target_type",
    "target_vertices",
    "target_num_vertices",
)


def detected_polygons(obs: TensorDictBase) -> list[tuple[list[np.ndarray], list[bool]]]:
    """For each element of a flat batch of observations: the detected objects' shelf-frame
    polygons and which of them is the target (its type id equals ``"target_type"``).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.perception import detected_polygons, observation_from_detections
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> obs = observation_from_detections((0.0, -0.1, 0.0), 0.085,
        ...     [{"type_id": 3, "pose": (0.1, 0.2, 0.0), "vertices": box}], target_type=3,
        ...     target_vertices=np.array(box))
        >>> (polygons, is_target), = detected_polygons(obs)
        >>> polygons[0][0].round(3).tolist(), is_target
        ([0.08, 0.18], [True])
    """
    det = obs.get(("objects", "detected")).cpu().numpy()
    if det.ndim == 1:
        raise ValueError("expected a batch of observations with shape [B]; add a batch dimension")
    objects = obs.get("objects")
    return detected_world_polygons(
        det,
        objects.get("type_id").cpu().numpy(),
        objects.get("pose").cpu().numpy(),
        objects.get("vertices").cpu().numpy(),
        objects.get("num_vertices").cpu().numpy(),
        obs.get("target_type").cpu().numpy(),
    )


def observation_from_detections(
    gripper_pose: Sequence[float],
    gripper_opening: float,
    detections: Sequence[dict],
    target_type: int,
    target_vertices: np.ndarray,
    gripper_closed: bool = False,
) -> TensorDict:
    """Build a one-element observation tensordict from a perception system's output.

    This is where a real robot enters: ``detections`` are the objects it currently sees
    (more than 50 % visible), each ``{"type_id": int, "pose": (x, y, theta), "vertices":
    [[x, y], ...]}`` with the vertices of the type's shape about the pose (the task prior).
    The result has the keys of :class:`~occrl.envs.ShelfEnv`'s observation (without
    ``"privileged"``), so transforms, networks and planners run on it unchanged.

    Everything is checked as :meth:`~occrl.envs.Scene.from_objects` checks a scene: poses are 3
    finite numbers, the opening lies within the 85 mm stroke, ``gripper_closed`` is a bool, type ids
    are ints in [1, 1,000,000) and unique among the detections, and every shape (the target's too)
    is a convex polygon of 3 to 8 finite vertices (clockwise order is turned counter-clockwise).
    Anything else raises ``ValueError`` (``TypeError`` for a wrong kind of value) naming the field,
    the value and what is allowed.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.perception import observation_from_detections
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> td = observation_from_detections((0.0, -0.1, 0.0), 0.085,
        ...     [{"type_id": 3, "pose": (0.1, 0.2, 0.0), "vertices": box}], target_type=1,
        ...     target_vertices=np.array(box))
        >>> td["objects", "detected"].sum().item()
        1
    """
    gp = finite_array("gripper_pose", gripper_pose, (3,), "(x, y, theta)")
    if np.ndim(gripper_opening) != 0:
        raise ValueError(f"gripper_opening must be one number (m), got {gripper_opening!r}")
    opening = float(finite_array("gripper_opening", [gripper_opening], (1,), "one number (m)")[0])
    if not 0.0 <= opening <= C.GRIPPER_STROKE:
        raise ValueError(f"gripper_opening must be in [0, {C.GRIPPER_STROKE}] m (the stroke), got {opening}")
    if not isinstance(gripper_closed, (bool, np.bool_)):
        raise TypeError(f"gripper_closed must be a bool (the last gripper command), got {gripper_closed!r}")
    target = strict_int("target_type", target_type, 1, MAX_TYPE_ID)
    tv = canonical_polygon(validate_vertices("target_vertices", target_vertices), "target_vertices")
    if isinstance(detections, (str, bytes, dict)) or not isinstance(detections, Sequence):
        raise TypeError(f"detections must be a list of dicts, got {type(detections).__name__}")
    if len(detections) > MAX_SLOTS:
        raise ValueError(f"at most {MAX_SLOTS} detections fit the observation, got {len(detections)}")
    N, V = MAX_SLOTS, MAX_POLY_VERTICES
    det = np.zeros((1, N), bool)
    type_id = np.zeros((1, N), np.int64)
    pose = np.zeros((1, N, 3), np.float32)
    verts = np.zeros((1, N, V, 2), np.float32)
    nv = np.zeros((1, N), np.int64)
    seen: dict[int, int] = {}
    for k, d in enumerate(detections):
        if not isinstance(d, dict):
            raise TypeError(f"detections[{k}] must be a dict with 'type_id', 'pose', 'vertices', got {type(d).__name__}")
        missing = [key for key in DETECTION_KEYS if key not in d]
        if missing:
            raise ValueError(f"detections[{k}] is missing {missing}; required: {list(DETECTION_KEYS)}")
        tid = strict_int(f"detections[{k}]['type_id']", d["type_id"], 1, MAX_TYPE_ID)
        if tid in seen:
            raise ValueError(f"detections[{k}] and detections[{seen[tid]}] have the same type_id {tid}; a detection names one object")
        seen[tid] = k
        p = finite_array(f"detections[{k}]['pose']", d["pose"], (3,), "(x, y, theta)")
        v = canonical_polygon(validate_vertices(f"detections[{k}]['vertices']", d["vertices"]), f"detections[{k}]['vertices']")
        det[0, k] = True
        type_id[0, k] = tid
        pose[0, k] = p
        verts[0, k] = pad_polygon(v)
        nv[0, k] = len(v)
    t = torch.from_numpy
    return TensorDict(
        {
            "gripper_pose": torch.tensor([gp.tolist()], dtype=torch.float32),
            "gripper_opening": torch.tensor([[opening]], dtype=torch.float32),
            "gripper_closed": torch.tensor([[bool(gripper_closed)]]),
            "target_type": torch.tensor([[target]]),
            "target_vertices": t(pad_polygon(tv)[None]),
            "target_num_vertices": torch.tensor([[len(tv)]]),
            "objects": TensorDict(
                {"detected": t(det), "type_id": t(type_id), "pose": t(pose), "vertices": t(verts), "num_vertices": t(nv)},
                batch_size=(1, N),
            ),
            "success": torch.zeros(1, 1, dtype=torch.bool),
            "dropped": torch.zeros(1, 1, dtype=torch.bool),
        },
        batch_size=(1,),
    )
