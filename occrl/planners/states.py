"""generateStates (paper Alg. 1, line 2): root states for RHP from the heat-map.

If the target is detected there is one root, the recreated state, with weight 1. Otherwise the
heat-map's peaks on the shelf (greedy non-maximum suppression) each give a root with the target
placed at the peak, until ``max_roots`` roots; a placement that collides is moved to the nearest
free spot within a few centimetres (trying several orientations), or dropped (the next peak is
tried). A root's weight is the heat-map mass
around its peak relative to the other roots'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.robot_frame import DEFAULT_FORWARD_OFFSET, DEFAULT_WINDOW, robot_centric_xy
from occrl.planners.recreate import RecreatedState, first_fitting_pose, with_target

__all__ = ["Root", "generate_states", "heatmap_peaks"]

_ORIENTATIONS = np.radians([0.0, 45.0, 90.0, 135.0])
_RINGS = [0.0, 0.01, 0.02, 0.03, 0.04]


@dataclass
class Root:
    """A root state for RHP, weighted by the heat-map mass around its peak.

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, generate_states, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> seen = with_target(RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, 1, box), (0.0, 0.2, 0.0))
        >>> root, = generate_states(np.zeros((64, 64)), seen)  # the target is seen: one root, weight 1
        >>> root.weight, root.peak_pixel, root.state is seen
        (1.0, None, True)
    """

    state: RecreatedState
    weight: float
    peak_pixel: tuple[int, int] | None = None  # (row, col) in the heat-map, None when the target is seen
    target_pose: tuple[float, float, float] | None = None


def heatmap_peaks(heat: np.ndarray, max_peaks: int = 3, radius: int = 6, rel_threshold: float = 0.2) -> list[tuple[int, int, float]]:
    """Greedy non-maximum suppression: (row, col, mass) of up to ``max_peaks`` peaks whose height
    is at least ``rel_threshold`` of the highest; mass is the heat inside ``radius`` pixels.

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import heatmap_peaks
        >>> heat = np.zeros((16, 16))
        >>> heat[3, 4], heat[10, 12], heat[12, 2] = 1.0, 0.5, 0.1  # the last is below 0.2 x the top
        >>> heatmap_peaks(heat, max_peaks=3, radius=2)
        [(3, 4, 1.0), (10, 12, 0.5)]
    """
    h = np.asarray(heat, dtype=float).copy()
    top = h.max()
    if not np.isfinite(top) or top <= 1e-6:
        return []
    disk = _disk(radius)
    half = disk.shape[0] // 2  # the disk's reach in whole pixels
    rows, cols = h.shape
    peaks = []
    for _ in range(max_peaks):
        r, c = divmod(int(h.argmax()), cols)
        if h[r, c] < rel_threshold * top:
            break
        # the pixels within radius of (r, c): the disk's window clipped to the map (its pixels in
        # the map's row-major order, so the mass sums the same values in the same order)
        r0, r1, c0, c1 = max(r - half, 0), min(r + half + 1, rows), max(c - half, 0), min(c + half + 1, cols)
        window = h[r0:r1, c0:c1]
        inside = disk[r0 - r + half : r1 - r + half, c0 - c + half : c1 - c + half]
        peaks.append((r, c, float(window[inside].sum())))
        window[inside] = 0.0
    return peaks


@lru_cache(maxsize=8)
def _disk(radius: float) -> np.ndarray:
    """(2 R + 1, 2 R + 1) read-only mask of the pixels within ``radius`` of the centre pixel (R:
    ``|radius|`` rounded down: the mask compares squared distances with ``radius ** 2``)."""
    reach = math.floor(abs(radius))
    offsets = np.arange(-reach, reach + 1)
    disk = offsets[:, None] ** 2 + offsets[None, :] ** 2 <= radius**2
    disk.flags.writeable = False
    return disk


def generate_states(
    heatmap: np.ndarray,
    state: RecreatedState,
    max_roots: int = 3,
    window: float = DEFAULT_WINDOW,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
) -> list[Root]:
    """Weighted root states from the heat-map (robot-centric, (S, S)) and the recreated state.

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, generate_states
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> heat = np.zeros((64, 64))
        >>> heat[20, 32] = 1.0  # one peak, about 0.29 m ahead of the gripper
        >>> root, = generate_states(heat, state)
        >>> root.peak_pixel, root.weight, np.round(root.target_pose, 3).tolist(), root.state.target_detected
        ((20, 32), 1.0, [0.006, 0.194, 0.0], True)
    """
    if state.target_detected:
        return [Root(state, 1.0)]
    size = heatmap.shape[-1]
    x, y = robot_centric_xy(np.asarray(state.gripper_pose, float), window, size, forward_offset)
    # the target is on the shelf (a task prior): ignore heat outside it
    on_shelf = (np.abs(x) < C.SHELF_HALF_WIDTH) & (y > 0.0) & (y < C.SHELF_DEPTH)
    roots = []
    for r, c, mass in heatmap_peaks(np.where(on_shelf, heatmap, 0.0), 3 * max_roots):
        pose = _free_pose(state, (x[r, c], y[r, c]))
        if pose is not None:
            roots.append(Root(with_target(state, pose), mass, (r, c), pose))
        if len(roots) == max_roots:
            break
    if not roots:  # nowhere plausible: plan in the known state only
        return [Root(state, 1.0)]
    total = sum(rt.weight for rt in roots)
    for rt in roots:
        rt.weight = rt.weight / total if total > 0 else 1.0 / len(roots)
    return roots


def _free_pose(state: RecreatedState, xy: tuple[float, float]) -> tuple[float, float, float] | None:
    """The first place that fits the target: at ``xy``, then on rings of 1 to 4 cm around it (8
    spots each, from +x anticlockwise), each spot in every orientation of :data:`_ORIENTATIONS`;
    None if none fits. (Ring by ring: most peaks' own spot fits.)"""
    for ring in _RINGS:
        n = 1 if ring == 0 else 8
        poses = []
        for k in range(n):
            ang = 2 * math.pi * k / n
            x, y = float(xy[0] + ring * math.cos(ang)), float(xy[1] + ring * math.sin(ang))
            poses += [(x, y, th) for th in _ORIENTATIONS.tolist()]
        k = first_fitting_pose(state, poses)
        if k is not None:
            return poses[k]
    return None
