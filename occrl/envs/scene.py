"""Shelf scenes: the objects on the shelf and the gripper's start pose.

A :class:`Scene` is what a task is made of. It is either sampled for a curriculum stage from a seed
or built from an explicit list of objects, which is also what a real robot's detections produce.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons
from occrl.envs.geometry import (
    convex_hull,
    is_convex_ccw,
    min_width,
    point_in_convex_polygon,
    polygon_area,
    polygon_centroid,
    polygons_overlap,
    transform_points,
)

__all__ = ["SceneObject", "Scene", "STAGES", "random_convex_polygon", "validate_pose", "validate_vertices", "canonical_polygon"]

# Curriculum stages (paper Sec. V): number of objects and where the target may be placed.
STAGES: dict[int, dict[str, Any]] = {
    1: {"num_objects": (1, 4), "target_y": (0.0, C.SHELF_DEPTH)},
    2: {"num_objects": (5, 10), "target_y": (0.0, C.SHELF_DEPTH)},
    3: {"num_objects": (7, 10), "target_y": (C.SHELF_DEPTH / 2, C.SHELF_DEPTH)},
}
PLACEMENT_CLEARANCE = 0.005  # gap kept between sampled objects
# Sampled objects keep this gap to the side and back walls: a finger (12 mm) fits beside them, so
# every object is graspable from some side (paper Sec. III-C). Explicit scenes may go closer.
WALL_CLEARANCE = 0.025
# The target's centroid keeps this distance to the side walls, so that the open gripper (fingers
# 5.45 cm either side of its axis) can straddle it straight on.
TARGET_SIDE_CLEARANCE = 0.06
# Likewise clutter is sampled at least this far from the target, so that the target starts
# graspable (a finger fits between it and its neighbours). Pushing may bring them together later.
TARGET_CLEARANCE = 0.015
GRASP_MARGIN = 0.01  # a sampled object leaves at least this much of the stroke free
DEFAULT_GRIPPER_POSE = (0.0, -0.10, 0.0)
_MAX_PLACEMENT_TRIES = 400


@dataclass(frozen=True)
class SceneObject:
    """One object: vertices (CCW, centred on the centroid) in its own frame and its pose.

    ``pose`` is the pose of the centroid frame in the shelf frame. ``type_id`` (>= 1) names the
    shape: detections report it and the planner recreates the shape from it (a task prior).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs import SceneObject
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> obj = SceneObject(type_id=1, vertices=box, pose=(0.1, 0.2, 0.0), is_target=True)
        >>> obj.world_vertices()[0].round(3).tolist()
        [0.08, 0.18]
    """

    type_id: int
    vertices: np.ndarray
    pose: tuple[float, float, float]
    is_target: bool = False

    def world_vertices(self) -> np.ndarray:
        return transform_points(self.vertices, self.pose)


@dataclass(frozen=True)
class Scene:
    """A shelf task: objects (exactly one target) and the gripper's start pose (x, y, theta).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs import Scene, SceneObject
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> scene = Scene(objects=(SceneObject(1, box, (0.1, 0.2, 0.0), is_target=True),))
        >>> len(scene), scene.target_index, scene.gripper_pose
        (1, 0, (0.0, -0.1, 0.0))
        >>> Scene(objects=(SceneObject(1, box, (0.1, 0.2, 0.0)),))
        Traceback (most recent call last):
            ...
        ValueError: a scene needs exactly one target (is_target=True), got 0
    """

    objects: tuple[SceneObject, ...]
    gripper_pose: tuple[float, float, float] = DEFAULT_GRIPPER_POSE
    stage: int | None = None
    seed: int | None = None
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        validate_objects(self.objects)
        validate_pose("gripper_pose", self.gripper_pose)
        _validate_gripper(self.gripper_pose, self.objects)

    @property
    def target_index(self) -> int:
        return next(i for i, o in enumerate(self.objects) if o.is_target)

    @property
    def target(self) -> SceneObject:
        return self.objects[self.target_index]

    def __len__(self) -> int:
        return len(self.objects)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def unchecked(cls, objects, gripper_pose, meta: dict | None = None) -> "Scene":
        """Build without validation: for states *recreated* from noisy detections, where objects
        may touch or slightly overlap and the target may be absent. Tasks use the checked
        constructors."""
        scene = object.__new__(cls)
        object.__setattr__(scene, "objects", tuple(objects))
        object.__setattr__(scene, "gripper_pose", tuple(float(v) for v in gripper_pose))
        object.__setattr__(scene, "stage", None)
        object.__setattr__(scene, "seed", None)
        object.__setattr__(scene, "meta", dict(meta or {}))
        return scene

    @classmethod
    def from_objects(
        cls,
        objects: Iterable[dict],
        gripper_pose: Sequence[float] = DEFAULT_GRIPPER_POSE,
    ) -> "Scene":
        """Build a scene from an explicit list, e.g. a real robot's detections.

        Each item is a dict with ``"vertices"`` (convex polygon in the object frame, any
        orientation), ``"pose"`` (x, y, theta of the object frame in the shelf frame),
        ``"is_target"`` (bool) and optionally ``"type_id"`` (defaults to the item's position + 1).
        The polygon is re-expressed about its centroid, so the stored pose is the centroid's.

        Raises:
            ValueError: naming the problem: not exactly one target, a non-convex or degenerate
                polygon, an object outside the shelf, overlapping objects, or an object that no
                side of fits the gripper's 85 mm stroke.

        Examples:
            >>> from occrl.envs import Scene
            >>> scene = Scene.from_objects(
            ...     [{"vertices": [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]],
            ...       "pose": (0.0, 0.2, 0.0), "is_target": True}],
            ...     gripper_pose=(0.0, -0.1, 0.0))
            >>> len(scene)
            1
        """
        if isinstance(objects, (str, bytes, dict)) or not hasattr(objects, "__iter__"):
            raise TypeError(f"objects must be a list of dicts, got {type(objects).__name__}")
        items = list(objects)
        built = []
        for i, item in enumerate(items):
            if not isinstance(item, dict):
                raise ValueError(f"object {i}: expected a dict with 'vertices', 'pose', 'is_target', got {type(item).__name__}")
            missing = {"vertices", "pose"} - set(item)
            if missing:
                raise ValueError(f"object {i}: missing key(s) {sorted(missing)}; required: 'vertices', 'pose'")
            verts = validate_vertices(f"object {i}: vertices", item["vertices"])
            validate_pose(f"object {i} pose", item["pose"])
            type_id = item.get("type_id", i + 1)
            if isinstance(type_id, (bool, np.bool_)) or not isinstance(type_id, (int, np.integer)):
                raise TypeError(f"object {i}: type_id must be an int, got {type_id!r}")
            if not isinstance(item.get("is_target", False), (bool, np.bool_)):
                raise TypeError(f"object {i}: is_target must be a bool, got {item['is_target']!r}")
            verts = canonical_polygon(verts, f"object {i}")
            centroid = polygon_centroid(verts)
            x, y, th = (float(v) for v in item["pose"])
            cx, cy = transform_points(centroid[None], (x, y, th))[0]
            built.append(
                SceneObject(
                    type_id=int(type_id),
                    vertices=verts - centroid,
                    pose=(float(cx), float(cy), th),
                    is_target=bool(item.get("is_target", False)),
                )
            )
        return cls(objects=tuple(built), gripper_pose=tuple(float(v) for v in gripper_pose))

    @classmethod
    def sample(cls, stage: int = 1, seed: int | np.random.Generator | None = None, num_objects: int | None = None) -> "Scene":
        """Sample a random scene of a curriculum stage (paper Sec. V).

        Stage 1: 1-4 objects with uniform poses; stage 2: 5-10 objects; stage 3: 7-10 objects with
        the target in the back half. ``num_objects`` overrides the stage's range (used by the
        clutter-density sweep). Every object is a fresh random convex polygon.

        Examples:
            >>> from occrl.envs import Scene
            >>> a, b = Scene.sample(stage=2, seed=7), Scene.sample(stage=2, seed=7)
            >>> [o.pose for o in a.objects] == [o.pose for o in b.objects]
            True
        """
        if stage not in STAGES:
            raise ValueError(f"stage must be one of {sorted(STAGES)}, got {stage!r}")
        int_seed = seed if isinstance(seed, (int, np.integer)) else None
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        spec = STAGES[stage]
        if num_objects is None:
            lo, hi = spec["num_objects"]
            num_objects = int(rng.integers(lo, hi + 1))
        if not 1 <= num_objects <= C.MAX_OBJECTS:
            raise ValueError(f"num_objects must be in [1, {C.MAX_OBJECTS}], got {num_objects}")
        for _ in range(100):
            objects = _place_objects(rng, num_objects, spec["target_y"])
            if objects is not None:
                gx = float(rng.uniform(-0.1, 0.1))
                return cls(
                    objects=tuple(objects),
                    gripper_pose=(gx, DEFAULT_GRIPPER_POSE[1], 0.0),
                    stage=stage,
                    seed=None if int_seed is None else int(int_seed),
                )
        raise RuntimeError(f"could not place {num_objects} objects without overlap")  # pragma: no cover

    def to_objects(self) -> list[dict]:
        """The inverse of :meth:`from_objects` (centroid frames)."""
        return [
            {"vertices": o.vertices.tolist(), "pose": tuple(o.pose), "is_target": o.is_target, "type_id": o.type_id} for o in self.objects
        ]


# ---------------------------------------------------------------------- validation
def validate_pose(name: str, pose: Any) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``pose`` is 3 finite numbers (x, y, theta)."""
    try:
        p = np.asarray(pose, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be (x, y, theta), got {pose!r}") from None
    if p.shape != (3,):
        raise ValueError(f"{name} must be (x, y, theta), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} contains NaN or inf: {pose!r}")


def validate_vertices(name: str, value: Any) -> np.ndarray:
    """``value`` as an (n, 2) float array; ``ValueError`` naming ``name`` unless it is a list of
    finite [x, y] pairs."""
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a list of [x, y] pairs of numbers, got {value!r}") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{name} must be a list of [x, y] pairs, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {v.tolist()}")
    return v


def canonical_polygon(verts: np.ndarray, name: str) -> np.ndarray:
    """``verts`` in counter-clockwise order; ``ValueError`` naming ``name`` for a wrong vertex
    count and for degenerate or non-convex input (instead of silently taking a hull)."""
    if len(verts) < C.MIN_VERTICES or len(verts) > C.MAX_VERTICES:
        raise ValueError(f"{name}: a polygon needs {C.MIN_VERTICES} to {C.MAX_VERTICES} vertices, got {len(verts)}")
    if polygon_area(verts) < 0:
        verts = verts[::-1].copy()
    area = polygon_area(verts)
    if area < 1e-6:
        raise ValueError(f"{name}: degenerate polygon (area {area:.2e} m^2, minimum 1e-06)")
    if not is_convex_ccw(verts):
        raise ValueError(f"{name}: polygon is not strictly convex (or repeats a vertex); vertices {verts.tolist()}")
    return verts


def validate_objects(objects: Sequence[SceneObject]) -> None:
    """Check a full scene; raises ``ValueError`` naming the first problem."""
    if len(objects) == 0:
        raise ValueError("a scene needs at least one object (the target)")
    if len(objects) > C.MAX_OBJECTS:
        raise ValueError(f"at most {C.MAX_OBJECTS} objects are supported, got {len(objects)}")
    n_targets = sum(bool(o.is_target) for o in objects)
    if n_targets != 1:
        raise ValueError(f"a scene needs exactly one target (is_target=True), got {n_targets}")
    type_ids = [o.type_id for o in objects]
    if any(t < 1 for t in type_ids):
        raise ValueError(f"type ids must be >= 1 (0 means 'no object'), got {type_ids}")
    if len(set(type_ids)) != len(type_ids):
        raise ValueError(f"type ids must be unique within a scene, got {type_ids}")
    world = []
    for i, o in enumerate(objects):
        validate_pose(f"object {i} pose", o.pose)
        if not is_convex_ccw(o.vertices):
            raise ValueError(f"object {i}: polygon is not strictly convex and counter-clockwise")
        if polygon_area(o.vertices) < 1e-6:
            raise ValueError(f"object {i}: degenerate polygon")
        width = min_width(o.vertices)
        if width > C.GRIPPER_STROKE:
            raise ValueError(
                f"object {i}: no side fits the gripper's {C.GRIPPER_STROKE * 1000:.0f} mm stroke (narrowest width {width * 1000:.1f} mm)"
            )
        wv = o.world_vertices()
        lo, hi = wv.min(axis=0), wv.max(axis=0)
        if lo[0] < -C.SHELF_HALF_WIDTH or hi[0] > C.SHELF_HALF_WIDTH or lo[1] < 0.0 or hi[1] > C.SHELF_DEPTH:
            raise ValueError(
                f"object {i} lies outside the shelf (x in [{-C.SHELF_HALF_WIDTH}, {C.SHELF_HALF_WIDTH}], "
                f"y in [0, {C.SHELF_DEPTH}]): its bounds are x [{lo[0]:.3f}, {hi[0]:.3f}], y [{lo[1]:.3f}, {hi[1]:.3f}]"
            )
        world.append(wv)
    for i in range(len(world)):
        for j in range(i + 1, len(world)):
            if polygons_overlap(world[i], world[j], clearance=-1e-9):
                raise ValueError(f"objects {i} and {j} overlap")


def _validate_gripper(gripper_pose, objects: Sequence[SceneObject]) -> None:

    parts = [transform_points(p, gripper_pose) for p in gripper_polygons(C.GRIPPER_STROKE)]
    for part in parts:
        for w in SHELF_WALLS:
            if polygons_overlap(part, w, clearance=-1e-9):
                raise ValueError(f"the open gripper at {tuple(gripper_pose)} overlaps a shelf wall")
        for i, o in enumerate(objects):
            if polygons_overlap(part, o.world_vertices(), clearance=-1e-9):
                raise ValueError(f"the open gripper at {tuple(gripper_pose)} overlaps object {i}")


# ---------------------------------------------------------------------- sampling
def random_convex_polygon(rng: np.random.Generator) -> np.ndarray:
    """A random convex polygon of 3-8 vertices, 3-9 cm across, graspable from some side,
    centred on its centroid.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import is_convex_ccw, polygon_centroid
        >>> from occrl.envs.scene import random_convex_polygon
        >>> poly = random_convex_polygon(np.random.default_rng(0))
        >>> is_convex_ccw(poly), 3 <= len(poly) <= 8, bool(np.allclose(polygon_centroid(poly), 0.0))
        (True, True, True)
    """
    while True:
        n = int(rng.integers(C.MIN_VERTICES, C.MAX_VERTICES + 1))
        radius = rng.uniform(C.MIN_OBJECT_RADIUS, C.MAX_OBJECT_RADIUS)
        angles = np.sort(rng.uniform(0.0, 2 * math.pi, n))
        radii = radius * rng.uniform(0.7, 1.0, n)
        pts = np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)
        hull = convex_hull(pts)
        if len(hull) < C.MIN_VERTICES or not is_convex_ccw(hull, tol=1e-7):
            continue
        if polygon_area(hull) < C.MIN_OBJECT_AREA:
            continue
        if min_width(hull) > C.GRIPPER_STROKE - GRASP_MARGIN:
            continue
        return hull - polygon_centroid(hull)


def _place_objects(rng: np.random.Generator, n: int, target_y: tuple[float, float]) -> list[SceneObject] | None:
    placed: list[SceneObject] = []
    placed_world: list[np.ndarray] = []
    for i in range(n):
        is_target = i == 0
        verts = random_convex_polygon(rng)
        r = float(np.linalg.norm(verts, axis=1).max())
        m = r + PLACEMENT_CLEARANCE
        mw = r + WALL_CLEARANCE
        ylo, yhi = target_y if is_target else (0.0, C.SHELF_DEPTH)
        ylo, yhi = max(ylo, m), min(yhi, C.SHELF_DEPTH - mw)
        xmax = C.SHELF_HALF_WIDTH - (max(mw, TARGET_SIDE_CLEARANCE) if is_target else mw)
        for _ in range(_MAX_PLACEMENT_TRIES):
            pose = (
                float(rng.uniform(-xmax, xmax)),
                float(rng.uniform(ylo, yhi)),
                float(rng.uniform(-math.pi, math.pi)),
            )
            wv = transform_points(verts, pose)
            gaps = [TARGET_CLEARANCE if (is_target or k == 0) else PLACEMENT_CLEARANCE for k in range(len(placed_world))]
            if all(not polygons_overlap(wv, other, gap) for other, gap in zip(placed_world, gaps)):
                placed.append(SceneObject(type_id=i + 1, vertices=verts, pose=pose, is_target=is_target))
                placed_world.append(wv)
                break
        else:
            return None
    # Shuffle so that the target is not always the first object (slot order carries no meaning).
    order = rng.permutation(n)
    return [placed[k] for k in order]


def objects_at_points(scene: Scene, points: np.ndarray) -> np.ndarray:
    """Index of the object covering each point, -1 where none (used by tests and pictures)."""
    out = np.full(len(points), -1)
    for i, o in enumerate(scene.objects):
        out[point_in_convex_polygon(points, o.world_vertices())] = i
    return out
