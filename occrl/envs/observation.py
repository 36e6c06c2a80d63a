"""One observation pipeline: world -> detections -> the network's robot-centric image.

Every image the network sees goes through these functions: the env's observation
(:class:`~occrl.envs.ShelfEnv` writes :func:`detection_arrays`, the transforms
:class:`~occrl.envs.OcclusionRender` and :class:`~occrl.envs.RobotCentricCrop` apply
:func:`render_shelf_labels` and :func:`crop_to_pixels`) and the worlds the planners imagine
(:func:`world_pixels`). So an imagined world identical to the env's world gives the env's image
pixel for pixel, including the float32 rounding of the observation's poses and shapes.

Steps:

1. **Visibility** (:func:`world_visible_fractions`, :func:`worlds_visible_fractions` for many
   worlds in one vectorised computation): the fraction of each object's angular extent
   the gripper camera sees, objects and shelf walls occluding; an object the world marks as
   unseen while held (``world.unseen_while_held``, set only for recreated worlds) is transparent
   to the camera while the gripper holds it (neither seen nor hiding anything).
2. **Detections** (:func:`detection_arrays`): objects more than 50 % visible fill their slot with
   type, pose and shape (float32, as the observation stores them); the gripper and the target's
   type and shape are always known.
3. **Render** (:func:`render_shelf_labels`): the abstract occlusion-aware image of the detected
   objects as a shelf-frame label map.
4. **Crop** (:func:`crop_to_pixels`): the window that moves with the gripper, coloured.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch

from occrl.envs import world_constants as C
from occrl.envs.geometry import ragged_positions, transform_polygons
from occrl.envs.palette import labels_to_pixels
from occrl.envs.render import DEFAULT_CANVAS, Canvas, render_labels_at_pixels, render_labels_batch
from occrl.envs.robot_frame import DEFAULT_FORWARD_OFFSET, DEFAULT_SIZE, DEFAULT_WINDOW, robot_centric_points, robot_centric_xy
from occrl.envs.shelf_geometry import SHELF_WALLS
from occrl.envs.visibility import detect, visible_fractions_batch

__all__ = [
    "MAX_SLOTS",
    "MAX_POLY_VERTICES",
    "MAX_TYPE_ID",
    "WALLS_PADDED",
    "GRIPPER_AND_TARGET_KEYS",
    "OBJECT_SLOT_KEYS",
    "pad_polygon",
    "world_visible_fractions",
    "worlds_visible_fractions",
    "detection_arrays",
    "detected_world_polygons",
    "worlds_detected_polygons",
    "render_shelf_labels",
    "crop_to_pixels",
    "world_pixels",
]

MAX_SLOTS = C.MAX_OBJECTS
MAX_POLY_VERTICES = C.MAX_VERTICES
MAX_TYPE_ID = 1_000_000
# the observation's perception keys, as detection_arrays names them: top level, and per object slot
# (under "objects")
GRIPPER_AND_TARGET_KEYS = ("gripper_pose", "gripper_opening", "gripper_closed", "target_type", "target_vertices", "target_num_vertices")
OBJECT_SLOT_KEYS = ("detected", "type_id", "pose", "vertices", "num_vertices")


def pad_polygon(vertices: np.ndarray, size: int = MAX_POLY_VERTICES) -> np.ndarray:
    """Pad a polygon to ``size`` vertices by repeating its first vertex (zero-length edges).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.observation import pad_polygon
        >>> padded = pad_polygon(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
        >>> padded.shape, padded.dtype, padded[-1].tolist()
        ((8, 2), dtype('float32'), [0.0, 0.0])
    """
    out = np.empty((size, 2), dtype=np.float32)
    out[: len(vertices)] = vertices
    out[len(vertices) :] = vertices[0]
    return out


# the shelf walls as occluders, padded like the objects (float32-rounded, as always measured)
WALLS_PADDED = np.stack([pad_polygon(w).astype(float) for w in SHELF_WALLS])


def world_visible_fractions(world, poses: np.ndarray | None = None) -> np.ndarray:
    """(n,) visible fraction of each object of a 2D world from its gripper camera.

    ``world`` offers ``padded_vertices`` (n, V, 2), ``object_poses()``, ``gripper_pose()``, ``held`` and optionally
    ``unseen_while_held`` (an object index, or None): while that object is held the camera
    neither sees it (it reads 0) nor is hidden by it (its pose in hand is only a guess).

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs.observation import world_visible_fractions
        >>> world = ShelfWorld(Scene.sample(stage=1, seed=0))
        >>> fractions = world_visible_fractions(world)
        >>> fractions.shape == (world.num_objects,), bool(((fractions >= 0) & (fractions <= 1)).all())
        (True, True)
    """
    return worlds_visible_fractions([world], [poses])[0]


def worlds_visible_fractions(worlds: Sequence, poses: Sequence[np.ndarray | None] | None = None) -> list[np.ndarray]:
    """:func:`world_visible_fractions` of many worlds in one vectorised computation
    (:func:`~occrl.envs.visibility.visible_fractions_batch`; the same values, bit for bit).

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs.observation import world_visible_fractions, worlds_visible_fractions
        >>> worlds = [ShelfWorld(Scene.sample(stage=2, seed=s)) for s in range(3)]
        >>> all((a == world_visible_fractions(w)).all() for a, w in zip(worlds_visible_fractions(worlds), worlds))
        True
    """
    poses = poses if poses is not None else [None] * len(worlds)
    hidden = []
    for w in worlds:
        unseen = getattr(w, "unseen_while_held", None)
        hidden.append(unseen if unseen is not None and w.held == unseen else None)
    if not worlds:
        return []
    # every world's objects in one transform (elementwise: each polygon's values as alone)
    poses = [w.object_poses() if p is None else np.asarray(p, dtype=float) for w, p in zip(worlds, poses)]
    polygons = transform_polygons(np.concatenate([w.padded_vertices for w in worlds]), np.concatenate(poses).reshape(-1, 3))
    ends = np.cumsum([len(p) for p in poses]).tolist()
    objects = [polygons[end - len(p) : end] for p, end in zip(poses, ends)]  # each world's, a view
    cameras = np.array([w.gripper_pose() for w in worlds], dtype=float).reshape(-1, 3)
    return visible_fractions_batch(objects, cameras, WALLS_PADDED, hidden=hidden)


def detection_arrays(worlds: Sequence, fractions: Sequence[np.ndarray], poses: Sequence[np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """The perception part of an observation of each world, as the observation stores it.

    Args:
        worlds: B worlds offering ``gripper_pose()``, ``object_poses()``, ``opening``, ``closed``,
            ``type_ids``, ``padded_vertices``, ``num_vertices``, ``target_index`` (-1: no target).
        fractions: each world's visible fractions (:func:`world_visible_fractions`, or a camera's).
        poses: each world's ``object_poses()`` when the caller has them already.

    Returns:
        ``gripper_pose`` (B, 3), ``gripper_opening`` (B, 1), ``gripper_closed`` (B, 1),
        ``target_type`` (B, 1), ``target_vertices`` (B, V, 2), ``target_num_vertices`` (B, 1), and
        per slot ``detected`` (B, N), ``type_id`` (B, N), ``pose`` (B, N, 3), ``vertices``
        (B, N, V, 2), ``num_vertices`` (B, N); floats are float32, undetected slots zero.

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs.observation import detection_arrays, world_visible_fractions
        >>> world = ShelfWorld(Scene.sample(stage=1, seed=0))
        >>> arrays = detection_arrays([world], [world_visible_fractions(world)])
        >>> arrays["pose"].shape, arrays["pose"].dtype, arrays["detected"].dtype
        ((1, 10, 3), dtype('float32'), dtype('bool'))
    """
    B, N, V = len(worlds), MAX_SLOTS, MAX_POLY_VERTICES
    out = {
        "gripper_pose": np.zeros((B, 3), np.float32),
        "gripper_opening": np.zeros((B, 1), np.float32),
        "gripper_closed": np.zeros((B, 1), bool),
        "target_type": np.zeros((B, 1), np.int64),
        "target_vertices": np.zeros((B, V, 2), np.float32),
        "target_num_vertices": np.zeros((B, 1), np.int64),
        "detected": np.zeros((B, N), bool),
        "type_id": np.zeros((B, N), np.int64),
        "pose": np.zeros((B, N, 3), np.float32),
        "vertices": np.zeros((B, N, V, 2), np.float32),
        "num_vertices": np.zeros((B, N), np.int64),
    }
    if not B:
        return out
    out["gripper_pose"][:] = [w.gripper_pose() for w in worlds]
    out["gripper_opening"][:, 0] = [w.opening for w in worlds]
    out["gripper_closed"][:, 0] = [w.closed for w in worlds]
    for i, w in enumerate(worlds):
        t = w.target_index
        if t >= 0:  # a recreated world may hold no target: type 0 then, which no object has
            out["target_type"][i, 0] = w.type_ids[t]
            out["target_vertices"][i] = w.padded_vertices[t]
            out["target_num_vertices"][i, 0] = w.num_vertices[t]
    # every world's objects at once: world i's object k goes to row i, slot k
    counts = [w.num_objects for w in worlds]
    rows, slots = ragged_positions(counts)
    fractions = [np.asarray(f) for f in fractions]
    if [len(f) for f in fractions] != counts:
        raise ValueError(f"fractions must hold one value per object of each world ({counts}), got {[len(f) for f in fractions]}")
    d = detect(np.concatenate(fractions))
    poses = [w.object_poses() for w in worlds] if poses is None else poses
    out["detected"][rows, slots] = d
    out["vertices"][rows, slots] = np.where(d[:, None, None], np.concatenate([w.padded_vertices for w in worlds]), 0.0)
    out["num_vertices"][rows, slots] = np.where(d, np.concatenate([w.num_vertices for w in worlds]), 0)
    out["type_id"][rows, slots] = np.where(d, np.concatenate([w.type_ids for w in worlds]), 0)
    out["pose"][rows, slots] = np.where(d[:, None], np.concatenate([np.asarray(p).reshape(-1, 3) for p in poses]), 0.0)
    return out


def detected_world_polygons(
    detected: np.ndarray, type_id: np.ndarray, poses: np.ndarray, vertices: np.ndarray, num_vertices: np.ndarray, target_type: np.ndarray
) -> list[tuple[list[np.ndarray], list[bool]]]:
    """Per world: the detected objects' shelf-frame polygons (float64 from the stored values) and
    which of them is the target (its type id equals ``target_type``). Shapes as
    :func:`detection_arrays` returns them; ``target_type`` (B,) or (B, 1).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.observation import detected_world_polygons
        >>> box = np.array([[[[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]]])
        >>> (polygons, is_target), = detected_world_polygons(np.array([[True]]), np.array([[3]]),
        ...     np.array([[[0.1, 0.2, 0.0]]]), box, np.array([[4]]), np.array([3]))
        >>> polygons[0][0].round(3).tolist(), is_target
        ([0.08, 0.18], [True])
    """
    world = transform_polygons(np.asarray(vertices).astype(np.float64), np.asarray(poses).astype(np.float64))
    # every slot's flags and vertex counts as Python values in one conversion each
    is_target = (np.asarray(type_id) == np.asarray(target_type).reshape(-1, 1)).tolist()
    counts, detected = np.asarray(num_vertices).tolist(), np.asarray(detected).tolist()
    out = []
    for b, (row_detected, row_counts, row_target) in enumerate(zip(detected, counts, is_target)):
        slots = [k for k, d in enumerate(row_detected) if d]
        out.append(([world[b, k, : row_counts[k]] for k in slots], [row_target[k] for k in slots]))
    return out


def worlds_detected_polygons(
    worlds: Sequence, fractions: Sequence[np.ndarray], poses: Sequence[np.ndarray] | None = None
) -> list[tuple[list[np.ndarray], list[bool]]]:
    """:func:`detected_world_polygons` of the observation :func:`detection_arrays` would write
    for the worlds, bit for bit (the detected objects' shapes and poses rounded to float32 as the
    observation stores them, then transformed in float64; the target flag by type id), computed
    for the detected objects alone without the observation's padded slot arrays: the planners'
    roll-out images (:func:`world_pixels`). Arguments as :func:`detection_arrays`'.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs.observation import detected_world_polygons, detection_arrays, worlds_detected_polygons, worlds_visible_fractions
        >>> worlds = [ShelfWorld(Scene.sample(stage=2, seed=s)) for s in range(3)]
        >>> fractions = worlds_visible_fractions(worlds)
        >>> a = detection_arrays(worlds, fractions)
        >>> slots = detected_world_polygons(a["detected"], a["type_id"], a["pose"], a["vertices"], a["num_vertices"], a["target_type"])
        >>> direct = worlds_detected_polygons(worlds, fractions)
        >>> all(f == g and all(np.array_equal(p, q) for p, q in zip(ps, qs)) for (ps, f), (qs, g) in zip(slots, direct))
        True
    """
    return _detections(worlds, fractions, poses)[0]


def _detections(worlds: Sequence, fractions: Sequence[np.ndarray], poses: Sequence[np.ndarray] | None) -> tuple[list, np.ndarray]:
    """:func:`worlds_detected_polygons`, and the detected polygons of every world laid end to end
    (n, V, 2), padded as the worlds pad their ``padded_vertices`` (by repeating each polygon's
    first vertex, as ``ShelfWorld`` and :func:`pad_polygon` do; the renderer relies on it), each
    polygon's list entry a view of its row."""
    counts = [w.num_objects for w in worlds]
    fractions = [np.asarray(f) for f in fractions]
    if [len(f) for f in fractions] != counts:
        raise ValueError(f"fractions must hold one value per object of each world ({counts}), got {[len(f) for f in fractions]}")
    out: list[tuple[list[np.ndarray], list[bool]]] = [([], []) for _ in worlds]
    d = detect(np.concatenate(fractions)) if worlds else np.zeros(0, bool)
    if not d.any():
        return out, np.empty((0, MAX_POLY_VERTICES, 2))
    poses = [w.object_poses() for w in worlds] if poses is None else poses
    # the detected objects' stored values (float32), back in float64 as detected_world_polygons reads them
    vertices = np.concatenate([w.padded_vertices for w in worlds])[d].astype(np.float32).astype(np.float64)
    pose = np.concatenate([np.asarray(p).reshape(-1, 3) for p in poses])[d].astype(np.float32).astype(np.float64)
    polygons = transform_polygons(vertices, pose)
    # the target flag as the observation gives it: the slot's type id equals the target's type (0: no target)
    target_types = np.array([w.type_ids[w.target_index] if w.target_index >= 0 else 0 for w in worlds], np.int64)
    types = np.concatenate([w.type_ids for w in worlds])[d]
    rows = np.repeat(np.arange(len(worlds)), counts)[d]
    is_target = (types == target_types[rows]).tolist()
    num_vertices = np.concatenate([w.num_vertices for w in worlds])[d].tolist()
    for j, (b, n, target) in enumerate(zip(rows.tolist(), num_vertices, is_target)):
        out[b][0].append(polygons[j, :n])
        out[b][1].append(target)
    return out, polygons


def render_shelf_labels(
    gripper_poses: np.ndarray,
    openings: np.ndarray,
    detections: Sequence[tuple[list[np.ndarray], list[bool]]],
    canvas: Canvas = DEFAULT_CANVAS,
    fov: float = C.CAMERA_FOV,
) -> np.ndarray:
    """(B, H, W) uint8 shelf-frame label maps of the detected objects
    (:func:`detected_world_polygons`) seen from float32 gripper poses (B, 3) and openings (B,).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.observation import render_shelf_labels
        >>> render_shelf_labels(np.array([[0.0, -0.1, 0.0]], np.float32), np.array([0.085], np.float32), [([], [])]).shape
        (1, 244, 250)
    """
    return render_labels_batch(gripper_poses, openings, detections, canvas, fov)


def crop_to_pixels(
    labels: np.ndarray,
    gripper_poses: np.ndarray,
    window: float = DEFAULT_WINDOW,
    size: int = DEFAULT_SIZE,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
    canvas: Canvas = DEFAULT_CANVAS,
) -> torch.Tensor:
    """(B, H, W) shelf-frame labels -> (B, 3, size, size) robot-centric colours in [0, 1].

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.observation import crop_to_pixels, render_shelf_labels
        >>> poses, openings = np.array([[0.0, -0.1, 0.0]], np.float32), np.array([0.085], np.float32)
        >>> crop_to_pixels(render_shelf_labels(poses, openings, [([], [])]), poses).shape
        torch.Size([1, 3, 64, 64])
    """
    points = robot_centric_points(np.asarray(gripper_poses).astype(np.float64), window, size, forward_offset)
    return labels_to_pixels(canvas.lookup(labels, points))


def world_pixels(worlds: Sequence, size: int = DEFAULT_SIZE) -> torch.Tensor:
    """The network input each 2D world's gripper camera gives, (B, 3, size, size) in [0, 1]: the
    env's observation pipeline (the default 0.8 m window, ``size`` pixels a side) applied to the
    worlds, without an env.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.envs.observation import world_pixels
        >>> env = make_env(batch_size=2, stage=2, seed=0, heatmap_target=False)
        >>> td = env.reset()
        >>> bool((world_pixels(env.base_env.worlds) == td["pixels"]).all())
        True
    """
    poses = [w.object_poses() for w in worlds]  # read once for visibility and detections
    polygons, padded = _detections(worlds, worlds_visible_fractions(worlds, poses), poses)
    # the gripper as the observation stores it (float32, as detection_arrays writes it)
    gripper_poses = np.array([w.gripper_pose() for w in worlds], np.float32).reshape(-1, 3)
    openings = np.array([w.opening for w in worlds], np.float32).reshape(-1, 1)
    # render_shelf_labels + crop_to_pixels, bit for bit, drawing only the part of the shelf the window shows
    pixels = DEFAULT_CANVAS.pixel_indices_xy(*robot_centric_xy(gripper_poses.astype(np.float64), size=size), overwrite=True)
    return labels_to_pixels(render_labels_at_pixels(gripper_poses, openings, polygons, *pixels, padded=padded))
