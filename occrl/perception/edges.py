"""Corner refinement by edge fitting: each side of a tag's black square is located along its
normal at many points, a line is fitted through them, and the corners are the lines' intersections.

OpenCV's ``cornerSubPix`` looks for a saddle point, which an L-shaped corner (the black square's
outer corner against its white margin) does not have: it pulls the corners a fraction of a pixel
inwards, so a small tag looks farther than it is. Edges have no such bias: the intensity gradient
across a blurred step peaks at the step.
"""

from __future__ import annotations

import numpy as np

from occrl.perception.opencv import require_opencv

__all__ = ["refine_corners_on_edges", "refine_tags_on_edges", "MAX_SHIFT_PX"]

MAX_SHIFT_PX = 2.0  # a corner the fit moves further than this keeps its first estimate
SAMPLES_PER_EDGE = 24
STEP_PX = 0.25


def refine_corners_on_edges(grey: np.ndarray, corners: np.ndarray, cells: int = 8) -> np.ndarray:
    """``corners`` (4, 2) of one tag, moved onto the lines fitted to its square's sides in ``grey``
    (uint8). ``cells``: the square's side in cells (the profile along each normal stays within the
    black border cell and the white margin cell)."""
    return refine_tags_on_edges(grey, [corners], cells)[0]


def refine_tags_on_edges(grey: np.ndarray, tags: list[np.ndarray], cells: int = 8) -> list[np.ndarray]:
    """:func:`refine_corners_on_edges` for each tag's (4, 2) corners in ``tags``, all sampled in one
    pass over the image. A tag keeps its corners as given when a side is shorter than two pixels
    a cell, fewer than half of a side's samples cross an edge, two sides are parallel, or a corner
    would move more than :data:`MAX_SHIFT_PX`."""
    cv2 = require_opencv()
    out = [np.asarray(c, dtype=np.float64).reshape(4, 2) for c in tags]
    if not out:
        return out
    c = np.stack(out)  # (tags, 4 corners, 2)
    a, b = c, np.roll(c, -1, axis=1)
    length = np.linalg.norm(b - a, axis=2)  # (tags, 4 sides)
    long_enough = ~np.any(length < 4 * cells / 2, axis=1)
    if not long_enough.any():
        return out
    which = np.flatnonzero(long_enough)
    c, a, b, length = c[which], a[which], b[which], length[which]
    d = (b - a) / length[..., None]
    n = np.stack([-d[..., 1], d[..., 0]], axis=-1)
    reach = np.clip(0.45 * length / cells, 1.0, 4.0)  # px either side of the edge
    t = np.linspace(0.12, 0.88, SAMPLES_PER_EDGE)
    s = np.arange(-4.0, 4.0 + 1e-9, STEP_PX)
    # (tags, 4 sides, samples, offsets, 2) sample points
    base = a[:, :, None, :] + t[None, None, :, None] * (b - a)[:, :, None, :]
    points = base[:, :, :, None, :] + s[None, None, None, :, None] * n[:, :, None, None, :]
    xy = points.reshape(len(which) * 4, -1, 2).astype(np.float32)  # one row per side (remap maps stay under 32767 a side)
    profile = cv2.remap(grey.astype(np.float32), xy[..., 0], xy[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    profile = profile.reshape(len(which), 4, SAMPLES_PER_EDGE, len(s))
    gradient = np.abs(np.gradient(profile, STEP_PX, axis=3))
    inside = np.abs(s)[None, None, None, :] <= reach[:, :, None, None]
    gradient = np.where(inside, gradient, 0.0)
    peak = gradient.max(axis=3, keepdims=True)
    weight = np.where(gradient >= 0.3 * peak, gradient, 0.0)
    total = weight.sum(axis=3)
    ok = (peak[..., 0] > 10.0) & (total > 0)  # (tags, 4 sides, samples)
    offset = (weight * s).sum(axis=3) / np.where(total > 0, total, 1.0)
    edge_points = base + offset[..., None] * n[:, :, None, :]
    count = ok.sum(axis=2)  # (tags, 4 sides)
    enough = np.all(count >= SAMPLES_PER_EDGE // 2, axis=1)
    # each side's line through its points (total least squares: the centroid and the principal
    # axis of the points' 2 x 2 covariance, in closed form), then each corner as two lines' meeting
    w = ok.astype(np.float64)
    centre = (edge_points * w[..., None]).sum(axis=2) / np.maximum(count, 1)[..., None]
    r = (edge_points - centre[:, :, None, :]) * w[..., None]
    sxx, syy, sxy = (r[..., 0] ** 2).sum(axis=2), (r[..., 1] ** 2).sum(axis=2), (r[..., 0] * r[..., 1]).sum(axis=2)
    phi = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # each line's direction
    normal = np.stack([-np.sin(phi), np.cos(phi)], axis=-1)
    along_normal = (normal * centre).sum(axis=-1)
    n1, d1 = np.roll(normal, 1, axis=1), np.roll(along_normal, 1, axis=1)  # corner k joins side k - 1 and side k
    n2, d2 = normal, along_normal
    det = n1[..., 0] * n2[..., 1] - n1[..., 1] * n2[..., 0]
    crossing = np.all(np.abs(det) >= 1e-6, axis=1)
    safe = np.where(np.abs(det) >= 1e-6, det, 1.0)
    refined = np.stack([(d1 * n2[..., 1] - n1[..., 1] * d2) / safe, (n1[..., 0] * d2 - d1 * n2[..., 0]) / safe], axis=-1)
    close = np.abs(refined - c).max(axis=(1, 2)) <= MAX_SHIFT_PX
    for k, i in enumerate(which):
        if enough[k] and crossing[k] and close[k]:
            out[i] = refined[k]
    return out
