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

__all__ = ["refine_corners_on_edges", "MAX_SHIFT_PX"]

MAX_SHIFT_PX = 2.0  # a corner the fit moves further than this keeps its first estimate
SAMPLES_PER_EDGE = 24
STEP_PX = 0.25


def refine_corners_on_edges(grey: np.ndarray, corners: np.ndarray, cells: int = 8) -> np.ndarray:
    """``corners`` (4, 2) of one tag, moved onto the lines fitted to its square's sides in ``grey``
    (uint8). ``cells``: the square's side in cells (the profile along each normal stays within the
    black border cell and the white margin cell)."""
    cv2 = require_opencv()
    c = np.asarray(corners, dtype=np.float64).reshape(4, 2)
    a, b = c, np.roll(c, -1, axis=0)
    length = np.linalg.norm(b - a, axis=1)
    if np.any(length < 4 * cells / 2):
        return c
    d = (b - a) / length[:, None]
    n = np.stack([-d[:, 1], d[:, 0]], axis=1)
    reach = np.clip(0.45 * length / cells, 1.0, 4.0)  # px either side of the edge
    t = np.linspace(0.12, 0.88, SAMPLES_PER_EDGE)
    s = np.arange(-4.0, 4.0 + 1e-9, STEP_PX)
    # (4 edges, samples, offsets, 2) sample points
    base = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
    points = base[:, :, None, :] + s[None, None, :, None] * n[:, None, None, :]
    xy = points.reshape(1, -1, 2).astype(np.float32)
    profile = cv2.remap(grey.astype(np.float32), xy[..., 0], xy[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    profile = profile.reshape(4, SAMPLES_PER_EDGE, len(s))
    gradient = np.abs(np.gradient(profile, STEP_PX, axis=2))
    inside = np.abs(s)[None, None, :] <= reach[:, None, None]
    gradient = np.where(inside, gradient, 0.0)
    peak = gradient.max(axis=2, keepdims=True)
    weight = np.where(gradient >= 0.3 * peak, gradient, 0.0)
    total = weight.sum(axis=2)
    ok = (peak[..., 0] > 10.0) & (total > 0)
    offset = (weight * s[None, None, :]).sum(axis=2) / np.where(total > 0, total, 1.0)
    edge_points = base + offset[..., None] * n[:, None, :]
    lines = []
    for k in range(4):
        pts = edge_points[k][ok[k]]
        if len(pts) < SAMPLES_PER_EDGE // 2:
            return c
        centre = pts.mean(axis=0)
        _, _, vt = np.linalg.svd(pts - centre)
        normal = vt[1]
        lines.append((normal, float(normal @ centre)))
    refined = np.empty_like(c)
    for k in range(4):  # corner k joins edge k - 1 and edge k
        (n1, d1), (n2, d2) = lines[k - 1], lines[k]
        m = np.array([n1, n2])
        if abs(np.linalg.det(m)) < 1e-6:
            return c
        refined[k] = np.linalg.solve(m, [d1, d2])
    if np.abs(refined - c).max() > MAX_SHIFT_PX:
        return c
    return refined
