"""Visibility from the gripper camera in 2D and the > 50 % detection rule (DESIGN section 4).

Seen from the camera, each convex object covers an interval of bearings (its angular extent).
An object's visible fraction is the share of that extent that lies inside the field of view and
where the object is the first thing a ray from the camera hits. Objects (and the shelf walls) are
taller than the camera's line of sight, so anything nearer hides what is behind it.

The computation is exact up to floating point: the in-view bearing range is cut at every object's
silhouette edges into elementary intervals; within one interval the set of objects covering it
does not change and, because disjoint convex sets cannot swap depth order, neither does the
nearest one. One ray per interval (Cyrus-Beck clipping against every polygon) decides its owner.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import next_vertices, pack_polygon_lists, pad_polygons  # pad_polygons: also importable from here, as before

__all__ = [
    "visible_fractions",
    "visible_fractions_batch",
    "detect",
    "camera_pose",
    "angular_extents",
    "silhouette_vertices",
    "in_field_of_view",
]


def camera_pose(gripper_pose: np.ndarray) -> np.ndarray:
    """The camera sits at the gripper frame's origin looking along its +y axis.

    Examples:
        >>> from occrl.envs.visibility import camera_pose
        >>> camera_pose([0.0, -0.1, 0.0]).tolist()
        [0.0, -0.1, 0.0]
    """
    return np.asarray(gripper_pose, dtype=float)


def in_field_of_view(points: np.ndarray, gripper_poses: np.ndarray, fov: float = C.CAMERA_FOV) -> np.ndarray:
    """Whether each point lies within the camera's horizontal field of view, occlusion aside
    (analysis: e.g. whether a target's centre was ever in view). ``points`` (..., 2) and
    ``gripper_poses`` (..., 3) broadcast together.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.visibility import in_field_of_view
        >>> in_field_of_view(np.array([[0.0, 0.2], [0.2, 0.0]]), np.zeros(3)).tolist()  # ahead; beside
        [True, False]
    """
    points, cam = np.asarray(points, dtype=float), camera_pose(gripper_poses)
    bearing = np.arctan2(points[..., 1] - cam[..., 1], points[..., 0] - cam[..., 0]) - (cam[..., 2] + np.pi / 2)
    return np.abs((bearing + np.pi) % (2 * np.pi) - np.pi) <= fov / 2


def angular_extents(polys: np.ndarray, cam: np.ndarray, with_tangents: bool = False):
    """Bearing interval ``[lo, hi]`` of each padded polygon seen from ``cam`` = (x, y, heading),
    in radians relative to the camera axis, and whether the camera is inside the polygon.
    With ``with_tangents`` also the indices of the vertices at ``lo`` and ``hi`` (the
    silhouette vertices, where shadows start). Many cameras at once: ``polys`` (B, P, V, 2) and
    ``cam`` (B, 3) give (B, P) results, each camera's bit for bit its own.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.visibility import angular_extents
        >>> sq = lambda x, y, r: np.array([[x-r, y-r], [x+r, y-r], [x+r, y+r], [x-r, y+r]])
        >>> lo, hi, inside = angular_extents(np.stack([sq(0, 0.2, 0.05), sq(0, 0, 0.5)]), np.zeros(3))
        >>> np.degrees([lo[0], hi[0]]).round(1).tolist(), inside.tolist()
        ([-18.4, 18.4], [False, True])
    """
    cam = np.asarray(cam, dtype=float)
    mx, my, rel, inside = _bearings(polys, cam)
    centre = np.arctan2(my[..., 0], mx[..., 0]) - (cam[..., 2, None] + math.pi / 2)  # relative to the camera axis (+y)
    centre = (centre + math.pi) % (2 * math.pi) - math.pi
    lo = centre + np.minimum.reduce(rel, -1)
    hi = centre + np.maximum.reduce(rel, -1)
    if with_tangents:
        return lo, hi, inside, rel.argmin(-1), rel.argmax(-1)
    return lo, hi, inside


def silhouette_vertices(polys: np.ndarray, cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whether the camera is inside each padded polygon and the indices of its silhouette
    vertices (those at the low and high end of its bearings): :func:`angular_extents`' last three
    results with ``with_tangents``, the same values, without the extents themselves (the shadows
    of the rendered observation start at these vertices). ``polys`` (B, P, V, 2), ``cam`` (B, 3).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.visibility import silhouette_vertices
        >>> square = np.array([[[[-0.05, 0.15], [0.05, 0.15], [0.05, 0.25], [-0.05, 0.25]]]])
        >>> [a.tolist() for a in silhouette_vertices(square, np.zeros((1, 3)))]  # right lower, left lower corner
        [[[False]], [[1]], [[0]]]
    """
    _, _, rel, inside = _bearings(polys, np.asarray(cam, dtype=float))
    return inside, rel.argmin(-1), rel.argmax(-1)


def _bearings(polys: np.ndarray, cam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Seen from each camera (x, y, heading): the direction towards each polygon's centre (mx,
    my; (..., P, 1) each), each vertex's bearing relative to it (..., P, V) and whether the camera
    is inside the polygon (..., P)."""
    cx, cy = cam[..., 0, None, None], cam[..., 1, None, None]
    dx, dy = polys[..., 0] - cx, polys[..., 1] - cy
    # towards the polygon's centre (np.mean's own arithmetic, a sum divided by the count, without
    # its Python wrapper: the same values)
    count = polys.shape[-2]
    mx, my = np.add.reduce(dx, -1, keepdims=True) / count, np.add.reduce(dy, -1, keepdims=True) / count
    # bearings relative to that direction: one arctan2 of (cross, dot), no wrapping needed
    rel = np.arctan2(mx * dy - my * dx, mx * dx + my * dy)
    # camera inside a convex polygon <=> the camera is on the inner side of every edge
    # (ey * dx - ex * dy is ex * -dy - ey * -dx exactly: negation is exact, and -p + q is q - p)
    nxt = next_vertices(polys)
    ex, ey = nxt[..., 0] - polys[..., 0], nxt[..., 1] - polys[..., 1]
    inside = np.logical_and.reduce(ey * dx - ex * dy >= 0, axis=-1)
    return mx, my, rel, inside


def visible_fractions(
    object_polygons: Sequence[np.ndarray],
    gripper_pose: np.ndarray,
    occluder_polygons: Sequence[np.ndarray] = (),
    fov: float = C.CAMERA_FOV,
) -> np.ndarray:
    """Fraction of each object's angular extent that the camera sees (0 to 1).

    Args:
        object_polygons: shelf-frame CCW polygons of the objects (a list, or an already padded
            (n, V, 2) array, in which case ``occluder_polygons`` must be padded to V too).
        gripper_pose: (x, y, theta); the camera is at its origin looking along its +y axis.
        occluder_polygons: extra polygons that hide but are not reported (shelf walls).
        fov: horizontal field of view in radians.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.visibility import visible_fractions
        >>> sq = lambda x, y, r: np.array([[x-r, y-r], [x+r, y-r], [x+r, y+r], [x-r, y+r]])
        >>> front, back = sq(0, 0.1, 0.03), sq(0, 0.3, 0.02)  # back is wholly behind front
        >>> visible_fractions([front, back], np.array([0.0, -0.1, 0.0])).round(3).tolist()
        [1.0, 0.0]
    """
    n = len(object_polygons)
    if n == 0:
        return np.zeros(0)
    if isinstance(object_polygons, np.ndarray) and isinstance(occluder_polygons, np.ndarray):
        objects, occluders = object_polygons, occluder_polygons  # already padded alike
    else:
        polys = pad_polygons(list(object_polygons) + list(occluder_polygons))
        objects, occluders = polys[:n], polys[n:]
    return visible_fractions_batch([objects], camera_pose(gripper_pose)[None], occluders, fov)[0]


def visible_fractions_batch(
    object_polygons: Sequence[np.ndarray],
    gripper_poses: np.ndarray,
    occluder_polygons: np.ndarray,
    fov: float = C.CAMERA_FOV,
    hidden: Sequence[int | None] | None = None,
) -> list[np.ndarray]:
    """:func:`visible_fractions` of many cameras at once, each over its own objects: bit for bit
    the per-camera results (tested), with the angular extents and the rays of all cameras in one
    vectorised computation (the planner's roll-out worlds of a depth step).

    Args:
        object_polygons: per camera, an (n_i, V, 2) padded array of its objects' polygons.
        gripper_poses: (B, 3) camera poses.
        occluder_polygons: (W, V, 2) padded polygons that hide but are not reported (shelf walls),
            shared by every camera.
        hidden: per camera, an object index the camera neither sees nor is hidden by (reads 0),
            or None.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.geometry import pad_polygons
        >>> from occrl.envs.visibility import visible_fractions, visible_fractions_batch
        >>> sq = lambda x, y, r: np.array([[x-r, y-r], [x+r, y-r], [x+r, y+r], [x-r, y+r]])
        >>> objects = [pad_polygons([sq(0, 0.1, 0.03), sq(0, 0.3, 0.02)]), pad_polygons([sq(0.1, 0.2, 0.03)])]
        >>> poses = np.array([[0.0, -0.1, 0.0], [0.0, -0.1, 0.3]])
        >>> batch = visible_fractions_batch(objects, poses, np.zeros((0, 4, 2)))
        >>> [f.round(3).tolist() for f in batch]
        [[1.0, 0.0], [0.425]]
        >>> all(np.array_equal(b, visible_fractions(o, p, np.zeros((0, 4, 2)))) for b, o, p in zip(batch, objects, poses))
        True
    """
    B = len(object_polygons)
    counts = [len(p) for p in object_polygons]
    hidden = list(hidden) if hidden is not None else []
    W, V = occluder_polygons.shape[0], occluder_polygons.shape[1]
    most = max(counts, default=0)
    P = most + W
    # every camera's objects in slots 0 to n_b - 1, the occluders in the last W slots, and the
    # slots between padded with inert copies of the first occluder (marked 'inside' below: they
    # neither cut the field of view nor own a ray). Objects before occluders, as camera by camera:
    # a ray's owner is the first of equally near polygons, and only the objects' widths are read.
    objects = np.concatenate([np.asarray(o, dtype=float).reshape(-1, V, 2) for o in object_polygons]) if most else np.empty((0, V, 2))
    polys, own = pack_polygon_lists(objects, counts, occluder_polygons)  # own: (B, most), camera b's objects
    inert = np.zeros((B, P), bool)
    inert[:, :most] = ~own
    for b, k in enumerate(hidden):
        if k is not None:
            inert[b, k] = True
    cams = np.asarray(gripper_poses, dtype=float).reshape(B, 3)
    lo, hi, inside = angular_extents(polys, cams)
    inside |= inert
    half = fov / 2
    clo, chi = np.maximum(lo, -half), np.minimum(hi, half)
    in_view = chi > clo
    in_view &= ~inside
    # each camera's elementary intervals: the field of view's edges and the in-view bearings where
    # an object's extent starts or ends (all within the field of view), sorted per camera with
    # repeats and out-of-view entries as +inf at the end
    cuts = np.empty((B, 2 + 2 * P))
    cuts.fill(np.inf)
    cuts[:, 0], cuts[:, 1] = -half, half
    np.copyto(cuts[:, 2 : 2 + P], clo, where=in_view)
    np.copyto(cuts[:, 2 + P :], chi, where=in_view)
    cuts.sort(axis=1)
    cuts[:, 1:][cuts[:, 1:] == cuts[:, :-1]] = np.inf  # repeats (compared before any is replaced)
    cuts.sort(axis=1)  # each camera's distinct cuts first, in order
    intervals = np.add.reduce(cuts <= half, 1) - 1  # per camera
    K = int(intervals.max()) if B else 0
    used = np.arange(K) < intervals[:, None]  # (B, K): the camera's own intervals; the rest are padding
    with np.errstate(invalid="ignore"):  # padding: inf - inf
        mids = np.where(used, 0.5 * (cuts[:, :K] + cuts[:, 1 : K + 1]), 0.0)
        widths = np.where(used, cuts[:, 1 : K + 1] - cuts[:, :K], 0.0)
    # one ray per interval against every polygon (Cyrus-Beck clipping, broadcast over cameras)
    cx, cy, th = cams[:, 0, None], cams[:, 1, None], cams[:, 2, None]  # (B, 1)
    phi = mids + th + math.pi / 2
    rdx, rdy = np.cos(phi), np.sin(phi)  # (B, K)
    # (vertex-major, (V, B, ...): the reductions over a polygon's edges run across V whole arrays,
    # many times faster than along a short last axis; max, min and any do not depend on the order)
    # (contiguous: numpy lays a result out as its inputs are, so the inputs set the layout)
    vx, vy = np.ascontiguousarray(polys.transpose(3, 2, 0, 1))  # (V, B, P) each
    # the edges' normals (ey, -ex): each vertex's successor minus the vertex, as next_vertices
    nx, ny = np.empty_like(vx), np.empty_like(vx)
    np.subtract(vy[1:], vy[:-1], out=nx[:-1])
    np.subtract(vy[:1], vy[-1:], out=nx[-1:])
    np.subtract(vx[1:], vx[:-1], out=ny[:-1])
    np.subtract(vx[:1], vx[-1:], out=ny[-1:])
    np.negative(ny, out=ny)
    h = nx * vx + ny * vy
    nc = nx * cx + ny * cy
    nd = nx[:, :, None] * rdx[None, :, :, None] + ny[:, :, None] * rdy[None, :, :, None]  # (V, B, K, P)
    num = (h - nc)[:, :, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / nd
    # entering and leaving parameters (the masked max / min as np.where + max / min: the same
    # values, without the masked reduction's slower loop)
    lower = np.maximum.reduce(np.where(nd < 0, t, -np.inf), 0)
    upper = np.minimum.reduce(np.where(nd > 0, t, np.inf), 0)
    parallel_out = np.logical_or.reduce((nd == 0) & (num < 0), 0)
    hit = (lower <= upper) & (upper > 0) & ~parallel_out
    hit &= ~inside[:, None, :]
    dist = np.where(hit, np.maximum(lower, 0.0), np.inf)  # (B, K, P)
    # each interval's owner is the nearest polygon its ray hits; an object sees the widths it owns
    owner = dist.argmin(-1)
    owned = used & (np.minimum.reduce(dist, -1) < np.inf)
    # (bincount adds each bin's weights in array order: each camera's intervals in order, as one camera alone)
    visible = np.bincount((owner + P * np.arange(B)[:, None])[owned], weights=widths[owned], minlength=B * P).reshape(B, P)
    extent = hi - lo
    frac = np.minimum(np.maximum(np.where(extent > 0, visible / np.maximum(extent, 1e-12), 0.0), 0.0), 1.0)
    # each camera's objects' fractions (all 0 where none of them is in view), the hidden object's 0
    seen = np.logical_or.reduce(in_view[:, :most] & own, 1)
    frac[~seen] = 0.0
    for b, k in enumerate(hidden):
        if k is not None:
            frac[b, k] = 0.0
    return [frac[b, :count] for b, count in enumerate(counts)]


def detect(fractions: np.ndarray, threshold: float = C.DETECTION_THRESHOLD) -> np.ndarray:
    """Detected means strictly more than ``threshold`` of the object is visible.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.visibility import detect
        >>> detect(np.array([0.3, 0.5, 0.51])).tolist()  # strictly more than half
        [False, False, True]
    """
    return fractions > threshold
