"""The perception boundary: turning the observation tensordict back into shelf-frame geometry.

Everything on the planning side goes through these functions, so a real robot plugs in by filling
the same keys the simulated envs fill (see :func:`observation_from_detections`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase

from occrl.envs.geometry import transform_polygons


__all__ = ["detected_polygons", "observation_from_detections"]


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
    verts = obs.get(("objects", "vertices")).cpu().numpy().astype(np.float64)
    poses = obs.get(("objects", "pose")).cpu().numpy().astype(np.float64)
    nv = obs.get(("objects", "num_vertices")).cpu().numpy()
    type_id = obs.get(("objects", "type_id")).cpu().numpy()
    target_type = obs.get("target_type").cpu().numpy().reshape(-1)
    world = transform_polygons(verts, poses)
    out = []
    for b in range(det.shape[0]):
        idx = np.flatnonzero(det[b])
        out.append(([world[b, k, : nv[b, k]] for k in idx], [bool(type_id[b, k] == target_type[b]) for k in idx]))
    return out


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
    from occrl.envs.shelf_env import MAX_POLY_VERTICES, MAX_SLOTS, pad_polygon

    if len(detections) > MAX_SLOTS:
        raise ValueError(f"at most {MAX_SLOTS} detections fit the observation, got {len(detections)}")
    N, V = MAX_SLOTS, MAX_POLY_VERTICES
    det = np.zeros((1, N), bool)
    type_id = np.zeros((1, N), np.int64)
    pose = np.zeros((1, N, 3), np.float32)
    verts = np.zeros((1, N, V, 2), np.float32)
    nv = np.zeros((1, N), np.int64)
    for k, d in enumerate(detections):
        v = np.asarray(d["vertices"], dtype=float)
        if v.ndim != 2 or v.shape[1] != 2 or not 3 <= len(v) <= V:
            raise ValueError(f"detection {k}: vertices must be 3 to {V} [x, y] pairs, got shape {v.shape}")
        p = np.asarray(d["pose"], dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)) or not np.all(np.isfinite(v)):
            raise ValueError(f"detection {k}: pose must be 3 finite numbers and vertices finite")
        det[0, k] = True
        type_id[0, k] = int(d["type_id"])
        pose[0, k] = p
        verts[0, k] = pad_polygon(v)
        nv[0, k] = len(v)
    tv = np.asarray(target_vertices, dtype=float)
    t = torch.from_numpy
    return TensorDict(
        {
            "gripper_pose": torch.tensor([list(map(float, gripper_pose))], dtype=torch.float32),
            "gripper_opening": torch.tensor([[float(gripper_opening)]], dtype=torch.float32),
            "gripper_closed": torch.tensor([[bool(gripper_closed)]]),
            "target_type": torch.tensor([[int(target_type)]]),
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


