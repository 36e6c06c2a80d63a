"""The abstract observation image (paper Sec. IV-A), rendered from what the robot knows.

The shelf-frame image is a label map: one class per pixel, turned into colours by a palette only
at the end. Only *detected* objects are drawn and only they cast shadows: this is rendered from
the state recreated from detections, never from ground truth.

Classes and colours (paper): observable space grey, occluded space white (outside the field of
view or in the shadow of a detected object or a wall, cast from the camera), walls brown, the
open front edge black, clutter red, the target green, the gripper blue (:mod:`occrl.envs.palette`;
its names are also importable from here).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from PIL import Image

from occrl.envs import world_constants as C
from occrl.envs.geometry import pack_polygon_lists, pad_polygons
from occrl.envs.palette import LABELS, PALETTE, labels_to_pixels, labels_to_rgb
from occrl.envs.visibility import silhouette_vertices
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons_batch

__all__ = [
    "Canvas",
    "LABELS",
    "PALETTE",
    "render_labels",
    "render_labels_batch",
    "render_labels_at",
    "render_labels_at_pixels",
    "render_true_scene",
    "labels_to_rgb",
    "labels_to_pixels",
    "DEFAULT_CANVAS",
    "SHELF_VIEW",
]

_FAR = 10.0  # m, length of shadow and field-of-view rays (well beyond any canvas)


@dataclass(frozen=True)
class Canvas:
    """A shelf-frame raster: ``resolution`` metres per pixel over ``[x0, x1] x [y0, y1]``.
    Row 0 is the far side (largest y); columns run along +x.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.render import Canvas
        >>> canvas = Canvas(x0=0.0, x1=1.0, y0=0.0, y1=0.5, resolution=0.1)
        >>> canvas.shape  # (rows, columns)
        (5, 10)
        >>> canvas.to_pixels(np.array([0.15, 0.25])).round(6).tolist()  # (col, row) of a pixel centre
        [1.0, 2.0]
    """

    x0: float = -1.0
    x1: float = 1.0
    y0: float = -0.95
    y1: float = 1.0
    resolution: float = 0.008

    @property
    def shape(self) -> tuple[int, int]:
        return (
            int(math.ceil((self.y1 - self.y0) / self.resolution)),
            int(math.ceil((self.x1 - self.x0) / self.resolution)),
        )

    def to_pixels(self, points: np.ndarray, overwrite: bool = False) -> np.ndarray:
        """Continuous (col, row) pixel coordinates of shelf-frame points (..., 2); integer values
        are pixel centres. ``overwrite``: ``points`` (a float64 array of the caller's own) holds
        the result, computed in place (the same values)."""
        p = np.asarray(points, dtype=float)
        out = p if overwrite else np.empty((*p.shape[:-1], 2))
        x, y = out[..., 0], out[..., 1]
        # ((x - x0) / resolution - 0.5, (y1 - y) / resolution - 0.5), step by step in the output
        np.subtract(p[..., 0], self.x0, out=x)
        x /= self.resolution
        x -= 0.5
        np.subtract(self.y1, p[..., 1], out=y)
        y /= self.resolution
        y -= 0.5
        return out

    def pixel_indices(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row, col, inside) of the pixel holding each shelf-frame point (..., 2): int64 indices
        and whether they lie on the canvas."""
        return self.pixel_indices_xy(points[..., 0], points[..., 1])

    def pixel_indices_xy(self, x: np.ndarray, y: np.ndarray, overwrite: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`pixel_indices` of the points given as their x and y arrays (e.g.
        :func:`~occrl.envs.robot_frame.robot_centric_xy`): the same indices, without stacking.
        ``overwrite``: x and y (float64 arrays of the caller's own) may serve as scratch space."""
        h, w = self.shape
        # (in place: the same arithmetic as one expression, fewer arrays)
        col = np.subtract(x, self.x0, out=x if overwrite else None)
        col /= self.resolution
        row = np.subtract(self.y1, y, out=y if overwrite else None)
        row /= self.resolution
        col, row = _floor_to_int(col), _floor_to_int(row)
        # (as unsigned, a negative index is larger than any canvas size: one comparison per bound)
        return row, col, (col.view(np.uint64) < w) & (row.view(np.uint64) < h)

    def lookup(self, labels: np.ndarray, points: np.ndarray, outside: int = LABELS["occluded"]) -> np.ndarray:
        """Nearest-pixel values of ``labels`` (..., H, W) at shelf-frame ``points`` (..., S, S, 2)."""
        h, w = labels.shape[-2:]
        if (h, w) != self.shape:
            raise ValueError(f"labels of shape (..., {h}, {w}) do not match the canvas's {self.shape}")
        row, col, valid = self.pixel_indices(points)
        flat = labels.reshape(*labels.shape[:-2], h * w)
        idx = np.where(valid, row * w + col, 0).reshape(*labels.shape[:-2], -1)
        out = np.take_along_axis(flat, idx, axis=-1).reshape(valid.shape)
        return np.where(valid, out, outside).astype(labels.dtype)


DEFAULT_CANVAS = Canvas()
# A tight canvas around the shelf and the space in front of it, for pictures of the true scene.
SHELF_VIEW = Canvas(x0=-0.32, x1=0.32, y0=-0.32, y1=0.40, resolution=0.0025)


def _floor_to_int(values: np.ndarray) -> np.ndarray:
    """``np.floor(values).astype(np.int64)`` (``values`` may be overwritten): where no value is
    negative the conversion's truncation is the floor already, and the floor pass is skipped."""
    if values.size and values.min() >= 0.0:  # (False for NaN: the floor then, as always)
        return values.astype(np.int64)
    return np.floor(values, out=values).astype(np.int64)


def _pillow_pixels(pixels: np.ndarray, row0: np.ndarray | None = None) -> np.ndarray:
    """Continuous (col, row) pixel coordinates as the integers Pillow draws with (it truncates
    each coordinate towards zero, a C cast); with ``row0`` (one canvas row per leading index) in
    an image whose row 0 is that canvas row. Pillow's polygon fill works on these integers alone,
    so an image of the canvas's rows ``row0`` onwards holds exactly those rows of the whole
    canvas's image."""
    ints = pixels.astype(np.int64)  # (numpy's cast truncates towards zero too: np.trunc's values)
    if row0 is not None:
        ints[..., 1] -= np.asarray(row0, dtype=np.int64).reshape(-1, *[1] * (ints.ndim - 2))
    return ints


def _xy_lists(pillow_ints: np.ndarray) -> list:
    """(..., V, 2) integer coordinates as Pillow's flat lists (x0, y0, x1, y1, ...), one list per
    polygon, in one conversion."""
    return pillow_ints.reshape(*pillow_ints.shape[:-2], pillow_ints.shape[-2] * 2).tolist()


def render_labels(
    gripper_pose: np.ndarray,
    opening: float,
    object_polygons: Sequence[np.ndarray],
    is_target: Sequence[bool],
    canvas: Canvas = DEFAULT_CANVAS,
    fov: float = C.CAMERA_FOV,
) -> np.ndarray:
    """Render the abstract observation as a shelf-frame label map (H, W) uint8.

    Args:
        gripper_pose: (x, y, theta) of the gripper; the camera is at its origin.
        opening: finger opening in metres.
        object_polygons: shelf-frame polygons of the *detected* objects.
        is_target: which of them is the target.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.render import render_labels, labels_to_rgb
        >>> labels = render_labels(np.array([0.0, -0.1, 0.0]), 0.085, [], [])
        >>> labels_to_rgb(labels).shape[-1]
        3
    """
    pose = np.asarray(gripper_pose, dtype=float).reshape(1, 3)
    return render_labels_batch(pose, np.array([float(opening)]), [(list(object_polygons), list(is_target))], canvas, fov)[0]


def render_labels_batch(
    gripper_poses: np.ndarray,
    openings: np.ndarray,
    detections: Sequence[tuple[Sequence[np.ndarray], Sequence[bool]]],
    canvas: Canvas = DEFAULT_CANVAS,
    fov: float = C.CAMERA_FOV,
) -> np.ndarray:
    """:func:`render_labels` of several worlds, (B, H, W) uint8: gripper poses (B, 3), openings
    (B,) (any float dtype; computed in float64) and per world its detected polygons and target flags. The shadows of every world are
    computed in one vectorised call (each world's bit for bit its own); only the raster is per world.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.render import render_labels, render_labels_batch
        >>> box = np.array([[-0.02, 0.18], [0.02, 0.18], [0.02, 0.22], [-0.02, 0.22]])
        >>> poses = np.array([[0.0, -0.1, 0.0], [0.05, -0.1, 0.3]])
        >>> both = render_labels_batch(poses, np.array([0.085, 0.085]), [([box], [True]), ([], [])])
        >>> bool((both[0] == render_labels(poses[0], 0.085, [box], [True])).all()), both.shape
        (True, (2, 244, 250))
    """
    h, w = canvas.shape
    full = [(0, h, w)] * len(np.asarray(gripper_poses).reshape(-1, 3))
    # (a bytearray: the label maps come out writable, as arrays of their own)
    labels = bytearray().join(_render_regions(gripper_poses, openings, detections, canvas, fov, full))
    return np.frombuffer(labels, dtype=np.uint8).reshape(-1, h, w)


def render_labels_at(
    gripper_poses: np.ndarray,
    openings: np.ndarray,
    detections: Sequence[tuple[Sequence[np.ndarray], Sequence[bool]]],
    points: np.ndarray,
    canvas: Canvas = DEFAULT_CANVAS,
    fov: float = C.CAMERA_FOV,
    outside: int = LABELS["occluded"],
) -> np.ndarray:
    """The labels of :func:`render_labels_batch` at shelf-frame ``points`` (B, ..., 2) of each
    world (nearest pixel, ``outside`` off the canvas), as :meth:`Canvas.lookup` reads them from
    the whole maps, bit for bit; only the canvas rows and columns the points reach are drawn
    (e.g. a robot-centric window: :func:`occrl.envs.observation.world_pixels`).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.render import DEFAULT_CANVAS, render_labels_at, render_labels_batch
        >>> from occrl.envs.robot_frame import robot_centric_points
        >>> box = np.array([[-0.02, 0.18], [0.02, 0.18], [0.02, 0.22], [-0.02, 0.22]])
        >>> poses, openings = np.array([[0.0, -0.1, 0.3]]), np.array([0.085])
        >>> points = robot_centric_points(poses)
        >>> window = render_labels_at(poses, openings, [([box], [True])], points)
        >>> whole = render_labels_batch(poses, openings, [([box], [True])])
        >>> window.shape, bool((window == DEFAULT_CANVAS.lookup(whole, points)).all())
        ((1, 64, 64), True)
    """
    points = np.asarray(points, dtype=float)
    row, col, valid = canvas.pixel_indices(points)
    return render_labels_at_pixels(gripper_poses, openings, detections, row, col, valid, canvas, fov, outside)


def render_labels_at_pixels(
    gripper_poses: np.ndarray,
    openings: np.ndarray,
    detections: Sequence[tuple[Sequence[np.ndarray], Sequence[bool]]],
    row: np.ndarray,
    col: np.ndarray,
    valid: np.ndarray,
    canvas: Canvas = DEFAULT_CANVAS,
    fov: float = C.CAMERA_FOV,
    outside: int = LABELS["occluded"],
    padded: np.ndarray | None = None,
) -> np.ndarray:
    """:func:`render_labels_at` of points given by their pixels: ``row``, ``col``, ``valid``
    (B, ...) as :meth:`Canvas.pixel_indices` returns them (used as scratch space: pass arrays of
    your own). The labels (B, ...), bit for bit :func:`render_labels_at`'s. ``padded``: the
    detections' polygons laid end to end, world by world, each padded to ``MAX_VERTICES`` by
    repeating its first vertex, as :func:`~occrl.envs.geometry.pad_polygons` pads them, when the
    caller has them so (:func:`occrl.envs.observation.world_pixels`): not padded again.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.render import DEFAULT_CANVAS, render_labels_at, render_labels_at_pixels
        >>> from occrl.envs.robot_frame import robot_centric_points
        >>> poses, openings = np.array([[0.0, -0.1, 0.3]]), np.array([0.085])
        >>> points = robot_centric_points(poses)
        >>> labels = render_labels_at_pixels(poses, openings, [([], [])], *DEFAULT_CANVAS.pixel_indices(points))
        >>> bool((labels == render_labels_at(poses, openings, [([], [])], points)).all())
        True
    """
    shape = valid.shape
    B = shape[0]
    row, col, valid = row.reshape(B, -1), col.reshape(B, -1), valid.reshape(B, -1)
    # each world's region: the rows and columns its points reach on the canvas (a 1 x 1 corner when none)
    everywhere = bool(valid.all())  # the common case, every point on the canvas: no masking
    if everywhere:
        row0, row1, col1 = row.min(axis=1), row.max(axis=1) + 1, col.max(axis=1) + 1
    else:
        seen = valid.any(axis=1)
        row0 = np.where(seen, np.where(valid, row, canvas.shape[0]).min(axis=1), 0)
        row1 = np.where(seen, np.where(valid, row, -1).max(axis=1) + 1, 1)
        col1 = np.where(seen, np.where(valid, col, -1).max(axis=1) + 1, 1)
    regions = list(zip(row0.tolist(), row1.tolist(), col1.tolist()))
    # every world's region laid end to end, row by row: one gather for the points of all worlds
    # (points off the canvas read the first pixel and are replaced by ``outside``)
    flat = np.frombuffer(b"".join(_render_regions(gripper_poses, openings, detections, canvas, fov, regions, padded)), dtype=np.uint8)
    start = np.concatenate(([0], np.cumsum((row1 - row0) * col1)[:-1]))
    row -= row0[:, None]  # (the arrays are pixel_indices' own: changed in place)
    row *= col1[:, None]
    row += col
    row += start[:, None]
    if everywhere:
        return flat[row].reshape(shape)
    out = np.where(valid, flat[np.where(valid, row, 0)], np.uint8(outside))
    return out.reshape(shape)


def _render_regions(gripper_poses, openings, detections, canvas: Canvas, fov: float, regions, detections_padded: np.ndarray | None = None):
    """Each world's label map over its region (row0, row1, col1) of the canvas: rows row0 to
    row1 - 1, columns 0 to col1 - 1, as raw uint8 bytes (row1 - row0 rows of col1).
    ``detections_padded``: :func:`render_labels_at_pixels`' ``padded``."""
    poses = np.asarray(gripper_poses, dtype=float).reshape(-1, 3)
    openings = np.asarray(openings, dtype=float).reshape(-1)
    B = len(poses)
    walls_padded = _static_pixels(canvas)[2]
    counts = [len(polys) for polys, _ in detections]
    most = max(counts, default=0)
    # every world's objects in slots 0 to n_b - 1 (spare slots up to the most: a wall, cast and
    # never drawn), then the walls
    if detections_padded is not None:
        detected = detections_padded
    else:
        detected = pad_polygons([p for polys, _ in detections for p in polys], C.MAX_VERTICES)
    padded, _ = pack_polygon_lists(detected, counts, walls_padded)
    P, V = padded.shape[1], padded.shape[2]
    arc = _FOV_ARC[fov] if fov in _FOV_ARC else _fov_arc(fov)
    # every point any world draws, in one (B, N, 2) array: the field of view's outline, the
    # shadows, the objects and the gripper's parts (each a view), for one conversion to pixels
    sizes = (1 + len(arc), 4 * P, V * most, 4 * _GRIPPER_PARTS)
    ends = list(itertools.accumulate(sizes))
    points = np.empty((B, ends[-1], 2))
    fov_out, shadows, objects, gripper = (points[:, e - n : e] for n, e in zip(sizes, ends))
    # shadows of detected objects and walls: from the two silhouette vertices away from the camera
    inside, i_lo, i_hi = silhouette_vertices(padded, poses)
    worlds, slots = np.arange(B)[:, None], np.arange(P)[None, :]
    v_lo, v_hi = padded[worlds, slots, i_lo], padded[worlds, slots, i_hi]
    cams = poses[:, None, :2]
    d_lo, d_hi = v_lo - cams, v_hi - cams
    shadows = shadows.reshape(B, P, 4, 2)  # (a view: the points' slots as (v_lo, v_hi, far hi, far lo))
    shadows[:, :, 0], shadows[:, :, 1] = v_lo, v_hi
    # (the lengths as np.linalg.norm computes them, a square root of the summed squares, without its wrapper)
    np.add(v_hi, _FAR * d_hi / np.maximum(np.sqrt(np.add.reduce(d_hi * d_hi, -1, keepdims=True)), 1e-9), out=shadows[:, :, 2])
    np.add(v_lo, _FAR * d_lo / np.maximum(np.sqrt(np.add.reduce(d_lo * d_lo, -1, keepdims=True)), 1e-9), out=shadows[:, :, 3])
    # outside the field of view: the camera, then an arc around the back
    # (each world's rotation from math.cos / math.sin and one stacked matmul: the values of world by world)
    axes = [th + math.pi / 2 for th in poses[:, 2].tolist()]
    rotations = np.array([[[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]] for a in axes]).reshape(-1, 2, 2)
    fov_out[:, 0] = poses[:, :2]
    fov_out[:, 1:] = poses[:, None, :2] + _FAR * np.matmul(arc, rotations)
    objects.reshape(B, most, V, 2)[...] = padded[:, :most]
    _gripper_world_polygons(poses, openings, out=gripper.reshape(B, _GRIPPER_PARTS, 4, 2))
    # Pillow's integer coordinates of every world's points in one conversion (canvas.to_pixels'
    # arithmetic in place), each world's rows from its region's first row (elementwise: the same
    # values as world by world)
    ints = _pillow_pixels(canvas.to_pixels(points, overwrite=True), [region[0] for region in regions])
    # every world's coordinates as Python lists in one conversion each (Pillow takes lists)
    fov_xy, shadow_xy, object_xy, gripper_xy = (
        _xy_lists(ints[:, e - n : e].reshape(B, -1, k, 2)) for n, e, k in zip(sizes, ends, (sizes[0], 4, V, 4))
    )
    casts = (~inside).tolist()
    static_rows = _STATIC_LISTS.setdefault(canvas, {})  # the walls' and edge's lists by region row
    for b, (polys, is_target) in enumerate(detections):
        row0, row1, col1 = regions[b]
        walls_xy, edge_xy = static_rows[row0] if row0 in static_rows else _static_lists(canvas, row0)
        # Pillow's core image and drawing objects, as Image.new and ImageDraw.Draw make them,
        # without their Python wrappers (the same pixels)
        size = (col1, row1 - row0)
        image = Image.core.fill("L", size, LABELS["observable"])
        draw = Image.core.draw(image, 0)
        draw.draw_polygon(fov_xy[b][0], LABELS["occluded"], 1)
        for k in [*range(counts[b]), *range(most, P)]:  # this world's objects, then the walls
            if casts[b][k]:
                draw.draw_polygon(shadow_xy[b][k], LABELS["occluded"], 1)
        objects_b = [xy[: 2 * len(p)] for xy, p in zip(object_xy[b], polys)]
        _draw_shelf_and_bodies(draw, walls_xy, edge_xy, objects_b, is_target, gripper_xy[b])
        yield _image_bytes(image, size)


def _image_bytes(image, size: tuple[int, int]) -> bytes:
    """The raw bytes of a core "L" image, row by row: what ``Image.tobytes()`` returns (its raw
    encoder, called directly)."""
    encoder = Image.core.raw_encoder("L", "L")
    encoder.setimage(image, (0, 0, *size))
    chunks = []
    try:
        while True:
            _, status, data = encoder.encode(max(65536, size[0] * size[1]))
            chunks.append(data)
            if status:
                break
    finally:
        encoder.cleanup()
    if status < 0:  # pragma: no cover - Pillow's own failure
        raise RuntimeError(f"Pillow's raw encoder failed with status {status}")
    return chunks[0] if len(chunks) == 1 else b"".join(chunks)


def _gripper_world_polygons(poses: np.ndarray, openings: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """(B, parts, 4, 2) shelf-frame gripper outlines (:func:`gripper_polygons`) at poses (B, 3)
    with openings (B,), into ``out`` if given; :func:`~occrl.envs.geometry.transform_points`
    world by world, the same values."""
    key = openings.tobytes()
    parts = _GRIPPER_PARTS_CACHE.get(key)
    if parts is None:  # (read only below: kept for the next call with these openings)
        if len(_GRIPPER_PARTS_CACHE) >= 1024:
            _GRIPPER_PARTS_CACHE.clear()
        parts = _GRIPPER_PARTS_CACHE[key] = gripper_polygons_batch(openings)
    cos_sin = np.array([(math.cos(th), math.sin(th)) for th in poses[:, 2].tolist()]).reshape(-1, 2, 1, 1)
    c, s = cos_sin[:, 0], cos_sin[:, 1]
    x, y = poses[:, 0, None, None], poses[:, 1, None, None]
    out = np.empty_like(parts) if out is None else out
    out[..., 0] = c * parts[..., 0] - s * parts[..., 1] + x
    out[..., 1] = s * parts[..., 0] + c * parts[..., 1] + y
    return out


def _draw_shelf_and_bodies(draw, walls: list, edge: list, objects: list, is_target, gripper: list) -> None:
    """Walls, front edge, objects and the gripper's parts, in that order, each a flat list of
    Pillow's integer coordinates (x0, y0, x1, y1, ...): what both the abstract observation and the
    true top-down view draw last. ``draw``: Pillow's core drawing object of an "L" image
    (``Image.core.draw``); ``draw_polygon(xy, label, 1)`` and ``draw_lines(xy, label, width)``
    are what ``ImageDraw.polygon(xy, fill=label)`` and ``ImageDraw.line(xy, fill=label, width)``
    call on it, without their ink lookup."""
    fill = draw.draw_polygon
    for xy in walls:
        fill(xy, LABELS["wall"], 1)
    draw.draw_lines(edge, LABELS["edge"], 2)
    for xy, tgt in zip(objects, is_target):
        fill(xy, LABELS["target"] if tgt else LABELS["clutter"], 1)
    for xy in gripper:
        fill(xy, LABELS["gripper"], 1)


def _fov_arc(fov: float) -> np.ndarray:
    """Unit vectors around the back of the camera, relative to its axis (x = along the axis)."""
    half = fov / 2
    arc = np.linspace(half, 2 * math.pi - half, 9)
    _FOV_ARC[fov] = np.stack([np.cos(arc), np.sin(arc)], 1)
    return _FOV_ARC[fov]


_FOV_ARC: dict[float, np.ndarray] = {}


_STATIC_CACHE: dict[Canvas, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
_STATIC_LISTS: dict[Canvas, dict[int, tuple[list, list]]] = {}
_GRIPPER_PARTS = gripper_polygons_batch(np.zeros(1)).shape[1]  # the gripper outline's parts
_GRIPPER_PARTS_CACHE: dict[bytes, np.ndarray] = {}  # gripper_polygons_batch by the openings' bytes


def _static_pixels(canvas: Canvas) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Walls and front edge in pixel coordinates, and the walls padded for shadow casting
    (they never move)."""
    if canvas not in _STATIC_CACHE:
        walls = canvas.to_pixels(np.stack(SHELF_WALLS))
        edge = canvas.to_pixels(np.array([[-C.SHELF_HALF_WIDTH, 0.0], [C.SHELF_HALF_WIDTH, 0.0]]))
        _STATIC_CACHE[canvas] = (walls, edge, pad_polygons(SHELF_WALLS, C.MAX_VERTICES))
    return _STATIC_CACHE[canvas]


def _static_lists(canvas: Canvas, row0: int) -> tuple[list, list]:
    """The walls' and the front edge's Pillow coordinates (flat lists) in an image whose row 0 is
    canvas row ``row0``; made once per canvas and row (read only: Pillow does not change them)."""
    rows = _STATIC_LISTS.setdefault(canvas, {})
    if row0 not in rows:
        walls, edge, _ = _static_pixels(canvas)
        rows[row0] = (_xy_lists(_pillow_pixels(walls, [row0])), _xy_lists(_pillow_pixels(edge, [row0])))
    return rows[row0]


def render_true_scene(
    gripper_pose: np.ndarray,
    opening: float,
    object_polygons: Sequence[np.ndarray],
    is_target: Sequence[bool],
    canvas: Canvas = DEFAULT_CANVAS,
) -> np.ndarray:
    """The ground-truth top-down view (every object, no occlusion) as a label map, for people.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.render import LABELS, SHELF_VIEW, render_true_scene
        >>> box = np.array([[-0.02, 0.18], [0.02, 0.18], [0.02, 0.22], [-0.02, 0.22]])
        >>> labels = render_true_scene(np.array([0.0, -0.1, 0.0]), 0.085, [box], [True], canvas=SHELF_VIEW)
        >>> labels.shape, bool((labels == LABELS["target"]).any()), bool((labels == LABELS["clutter"]).any())
        ((288, 256), True, False)
    """
    img = Image.new("L", (canvas.shape[1], canvas.shape[0]), LABELS["observable"])
    padded = pad_polygons(object_polygons, C.MAX_VERTICES) if len(object_polygons) else np.zeros((0, C.MAX_VERTICES, 2))
    walls, edge, _ = _static_pixels(canvas)
    gripper = _gripper_world_polygons(np.asarray(gripper_pose, dtype=float).reshape(1, 3), np.array([float(opening)]))[0]
    walls_xy, edge_xy, object_xy, gripper_xy = (
        _xy_lists(_pillow_pixels(px)) for px in (walls, edge[None], canvas.to_pixels(padded), canvas.to_pixels(gripper))
    )
    objects = [xy[: 2 * len(p)] for xy, p in zip(object_xy, object_polygons)]
    _draw_shelf_and_bodies(Image.core.draw(img.im, 0), walls_xy, edge_xy[0], objects, is_target, gripper_xy)
    return np.asarray(img, dtype=np.uint8)
