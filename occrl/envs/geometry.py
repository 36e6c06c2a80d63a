"""Planar convex-polygon geometry shared by scene sampling, physics, visibility and rendering.

Polygons are ``(n, 2)`` float arrays of vertices in counter-clockwise order. Poses are
``(x, y, theta)`` with ``theta`` in radians, counter-clockwise from the shelf x axis.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = [
    "convex_hull",
    "next_vertices",
    "polygon_area",
    "polygon_centroid",
    "is_convex_ccw",
    "min_width",
    "transform_points",
    "transform_polygons",
    "polygons_overlap",
    "edge_normals",
    "separated_along",
    "point_in_convex_polygon",
    "clip_to_band",
    "ragged_positions",
    "pad_polygons",
    "pack_polygon_lists",
]


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull (Andrew's monotone chain) without collinear points.

    Examples:
        >>> from occrl.envs.geometry import convex_hull
        >>> convex_hull([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]]).tolist()  # interior point dropped
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    """
    pts = sorted(set(map(tuple, np.asarray(points, dtype=float).tolist())))
    if len(pts) <= 2:
        return np.asarray(pts, dtype=float).reshape(-1, 2)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.asarray(lower[:-1] + upper[:-1], dtype=float)


def next_vertices(vertices: np.ndarray) -> np.ndarray:
    """Each vertex's successor along its polygon, for polygons (..., V, 2): ``np.roll(vertices, -1,
    axis=-2)`` (the same array) without ``np.roll``'s overhead, which dominates for small polygons.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import next_vertices
        >>> next_vertices(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])).tolist()
        [[1.0, 0.0], [1.0, 1.0], [0.0, 0.0]]
    """
    return np.concatenate([vertices[..., 1:, :], vertices[..., :1, :]], axis=-2)


def polygon_area(vertices: np.ndarray) -> float:
    """Signed area (positive for counter-clockwise order).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import polygon_area
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> polygon_area(square), polygon_area(square[::-1])
        (1.0, -1.0)
    """
    x, y = vertices[:, 0], vertices[:, 1]
    xn, yn = np.concatenate((x[1:], x[:1])), np.concatenate((y[1:], y[:1]))  # np.roll(., -1): the same arrays
    return 0.5 * float(np.dot(x, yn) - np.dot(xn, y))


def polygon_centroid(vertices: np.ndarray) -> np.ndarray:
    """Area centroid of a simple polygon.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import polygon_centroid
        >>> polygon_centroid(np.array([[0, 0], [2, 0], [2, 1], [0, 1]], dtype=float)).tolist()
        [1.0, 0.5]
    """
    x, y = vertices[:, 0], vertices[:, 1]
    nxt = next_vertices(vertices)
    xn, yn = nxt[:, 0], nxt[:, 1]
    c = x * yn - xn * y
    area = 0.5 * c.sum()
    return np.array([((x + xn) * c).sum(), ((y + yn) * c).sum()]) / (6.0 * area)


def is_convex_ccw(vertices: np.ndarray, tol: float = 1e-12) -> bool:
    """True when the vertices form a strictly convex polygon in counter-clockwise order.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import is_convex_ccw
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> is_convex_ccw(square), is_convex_ccw(square[::-1])  # clockwise order is rejected
        (True, False)
    """
    v = np.asarray(vertices, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3:
        return False
    e = next_vertices(v) - v
    en = next_vertices(e)
    cross = e[:, 0] * en[:, 1] - e[:, 1] * en[:, 0]
    return bool(np.all(cross > tol))


def min_width(vertices: np.ndarray) -> float:
    """Smallest distance between two parallel lines enclosing a convex polygon.

    For a convex polygon the minimum is attained with one line through an edge, so it is the
    smallest over edges of the largest vertex distance to that edge's line. This is the narrowest
    opening a parallel gripper needs to hold it.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import min_width
        >>> min_width(np.array([[0, 0], [0.06, 0], [0.06, 0.02], [0, 0.02]]))  # a 6 x 2 cm box
        0.02
    """
    v = np.asarray(vertices, dtype=float)
    e = next_vertices(v) - v
    n = np.stack([-e[:, 1], e[:, 0]], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    proj = v @ n.T  # (verts, edges)
    return float((proj.max(axis=0) - proj.min(axis=0)).min())


def transform_points(points: np.ndarray, pose) -> np.ndarray:
    """Points from a local frame to the frame in which ``pose`` = (x, y, theta) is given.

    Examples:
        >>> import math
        >>> from occrl.envs.geometry import transform_points
        >>> transform_points([[1.0, 0.0]], (0.5, 0.0, math.pi / 2)).round(3).tolist()
        [[0.5, 1.0]]
    """
    x, y, th = float(pose[0]), float(pose[1]), float(pose[2])
    c, s = math.cos(th), math.sin(th)
    p = np.asarray(points, dtype=float)
    out = np.empty_like(p)
    out[..., 0] = c * p[..., 0] - s * p[..., 1] + x
    out[..., 1] = s * p[..., 0] + c * p[..., 1] + y
    return out


def transform_polygons(vertices: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Batched :func:`transform_points`: vertices (..., V, 2) in their objects' frames, poses
    (..., 3) -> (..., V, 2) in the frame the poses are given in.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import transform_polygons
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> out = transform_polygons(np.stack([square, square]), np.array([[0, 0, 0], [2, 0, 0]]))
        >>> out.shape, out[1, 0].tolist()
        ((2, 4, 2), [2.0, 0.0])
    """
    poses = np.asarray(poses, dtype=float)
    c, s = np.cos(poses[..., 2])[..., None], np.sin(poses[..., 2])[..., None]
    vx, vy = vertices[..., 0], vertices[..., 1]
    # (c x - s y + px, s x + c y + py), each coordinate computed in place in the output: the
    # same operations in the same order as the expressions
    out = np.empty((*np.broadcast_shapes(c.shape, vx.shape), 2), dtype=np.result_type(c, vx))
    x, y = out[..., 0], out[..., 1]
    np.multiply(c, vx, out=x)
    x -= s * vy
    x += poses[..., 0, None]
    np.multiply(s, vx, out=y)
    y += c * vy
    y += poses[..., 1, None]
    return out


def edge_normals(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A convex CCW polygon's (V, 2) unit outward edge normals and (V,) offsets: each edge's
    offset is the polygon's maximum along its normal. What the separating-axis test
    (:func:`separated_along`, :func:`polygons_overlap`) reads of a polygon; computed once, a
    polygon can be tested against many. Polygons (..., V, 2) give (..., V, 2) and (..., V), each
    polygon's bit for bit its own.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import edge_normals
        >>> normals, offsets = edge_normals(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float))
        >>> normals.tolist() == [[0, -1], [1, 0], [0, 1], [-1, 0]], offsets.tolist()  # below, right, above, left
        (True, [0.0, 1.0, 1.0, 0.0])
    """
    e = next_vertices(polygon) - polygon
    n = np.stack([e[..., 1], -e[..., 0]], axis=-1)  # outward normals of a CCW polygon
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return n, np.einsum("...ij,...ij->...i", n, polygon)  # each edge's own offset is the max of the polygon along its normal


def separated_along(normals: np.ndarray, offsets: np.ndarray, points: np.ndarray, gap: float = 0.0) -> bool:
    """Whether ``points`` (N, 2) all lie at least ``gap`` beyond one edge of the polygon whose
    :func:`edge_normals` these are (one half of the separating-axis test).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import edge_normals, separated_along
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> separated_along(*edge_normals(square), square + [1.5, 0]), separated_along(*edge_normals(square), square + [0.5, 0])
        (True, False)
    """
    b_min = (points @ normals.T).min(axis=0)
    return bool(np.any(b_min - offsets >= gap))


def polygons_overlap(a: np.ndarray, b: np.ndarray, clearance: float = 0.0) -> bool:
    """Separating-axis test for two convex CCW polygons.

    Returns True when the polygons intersect or come closer than ``clearance`` along every
    edge normal (a conservative clearance test).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import polygons_overlap
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> polygons_overlap(square, square + [0.5, 0]), polygons_overlap(square, square + [1.1, 0])
        (True, False)
        >>> polygons_overlap(square, square + [1.1, 0], clearance=0.2)  # closer than 0.2
        True
    """
    return not (separated_along(*edge_normals(a), b, clearance) or separated_along(*edge_normals(b), a, clearance))


def point_in_convex_polygon(points: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """Boolean mask of which ``points`` (..., 2) lie inside the convex CCW polygon.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import point_in_convex_polygon
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> point_in_convex_polygon([[0.5, 0.5], [2.0, 2.0]], square).tolist()
        [True, False]
    """
    v = np.asarray(vertices, dtype=float)
    e = next_vertices(v) - v
    p = np.asarray(points, dtype=float)[..., None, :] - v  # (..., n, 2)
    cross = e[:, 0] * p[..., 1] - e[:, 1] * p[..., 0]
    return np.all(cross >= 0.0, axis=-1)


def clip_to_band(vertices: np.ndarray, y0: float, y1: float) -> np.ndarray:
    """The part of a convex polygon with ``y0 <= y <= y1`` (Sutherland-Hodgman on two lines);
    an empty ``(0, 2)`` array when they do not meet.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import clip_to_band
        >>> square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
        >>> sorted(clip_to_band(square, 0.25, 0.5).tolist())
        [[0.0, 0.25], [0.0, 0.5], [1.0, 0.25], [1.0, 0.5]]
        >>> clip_to_band(square, 2.0, 3.0).shape
        (0, 2)
    """
    pts = [tuple(p) for p in np.asarray(vertices, dtype=float)]
    for sign, bound in ((1.0, y0), (-1.0, -y1)):  # keep sign * y >= bound
        out = []
        n = len(pts)
        for k in range(n):
            p, q = pts[k], pts[(k + 1) % n]
            dp, dq = sign * p[1] - bound, sign * q[1] - bound
            if dp >= 0.0:
                out.append(p)
            if (dp >= 0.0) != (dq >= 0.0):
                t = dp / (dp - dq)
                out.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
        pts = out
        if not pts:
            break
    return np.array(pts, dtype=float).reshape(-1, 2)


def ragged_positions(counts) -> tuple[np.ndarray, np.ndarray]:
    """Where each item of several lists laid end to end goes in a padded (lists, slots) array:
    list ``counts[b]`` items long b's k-th item to row b, slot k (for filling padded per-world
    arrays in one assignment).

    Examples:
        >>> from occrl.envs.geometry import ragged_positions
        >>> [r.tolist() for r in ragged_positions([2, 0, 3])]
        [[0, 0, 2, 2, 2], [0, 1, 0, 1, 2]]
    """
    counts = np.asarray(counts, dtype=np.int64).reshape(-1)
    if len(counts) and counts.min() < 0:
        raise ValueError(f"counts must be >= 0, got {counts.tolist()}")
    # the slots each list fills, in C order (row by row, slot by slot): their indices in one call
    rows, slots = np.nonzero(np.arange(counts.max() if len(counts) else 0) < counts[:, None])
    return rows, slots


def pad_polygons(polygons: Sequence[np.ndarray], size: int | None = None) -> np.ndarray:
    """(P, V, 2) float64 with each polygon padded by repeating its first vertex (zero-length
    edges); V is ``size``, or the most vertices of any polygon.

    Raises:
        ValueError: if a polygon has no vertex or more than ``size``.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import pad_polygons
        >>> pad_polygons([np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])], 4)[0].tolist()
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]
    """
    counts = [len(p) for p in polygons]
    vmax = size if size is not None else max(counts)
    if not counts:
        return np.empty((0, vmax, 2))
    if min(counts) < 1 or max(counts) > vmax:
        raise ValueError(f"polygons must have 1 to {vmax} vertices to pad to {vmax}, got {sorted(set(counts))}")
    # every polygon's vertices in one array, then one gather: vertex j of polygon k, or its first
    try:  # (n_k, 2) arrays or nested lists: joined as they are
        vertices = np.concatenate(polygons, dtype=float)
    except ValueError:
        vertices = None
    if vertices is None or vertices.shape != (sum(counts), 2):  # anything else: each polygon as (-1, 2)
        vertices = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for p in polygons])
    lengths = np.array(counts, dtype=np.int64)
    slots = np.arange(vmax)
    return vertices.take((np.cumsum(lengths) - lengths)[:, None] + np.where(slots < lengths[:, None], slots, 0), axis=0)


def pack_polygon_lists(polygons: np.ndarray, counts: Sequence[int], occluders: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Several lists of padded polygons (list b's ``counts[b]`` laid end to end in ``polygons``,
    (sum(counts), V, 2)) and occluders every list shares ((W, V, 2)) in one (B, most + W, V, 2)
    array: list b's polygons in slots 0 to counts[b] - 1 in order, the occluders in the last W
    slots, the slots between filled with copies of the first occluder (zeros without occluders);
    and the (B, most) mask of each list's own slots. (Each world's objects and the shelf walls,
    for vectorised visibility and shadows.)

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import pack_polygon_lists
        >>> polygons = np.arange(3.0).reshape(3, 1, 1) * np.ones((3, 1, 2))  # polygons 0, 1, 2 of one vertex
        >>> packed, own = pack_polygon_lists(polygons, [1, 2], np.full((1, 1, 2), 9.0))
        >>> packed[..., 0, 0].tolist(), own.tolist()
        ([[0.0, 9.0, 9.0], [1.0, 2.0, 9.0]], [[True, False], [True, True]])
    """
    counts = np.asarray(counts, dtype=np.int64).reshape(-1)
    most = int(counts.max()) if len(counts) else 0
    own = np.arange(most) < counts[:, None]  # (C order: list b's slots in order, as the polygons are laid)
    packed = np.empty((len(counts), most + occluders.shape[0], *polygons.shape[1:]))
    packed[:, most:] = occluders
    packed[:, :most][~own] = occluders[0] if len(occluders) else 0.0
    if most:
        packed[:, :most][own] = polygons
    return packed, own
