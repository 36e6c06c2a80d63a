"""Where a hidden target may still be: the hiding region of the hierarchical baseline."""

from __future__ import annotations

import math

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import point_in_convex_polygon, polygons_overlap, transform_points
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons
from occrl.envs.visibility import visible_fractions

__all__ = ["HidingRegion", "probe_points"]


class HidingRegion:
    """Where the unlocated target could be hidden, given what the camera saw.

    The target's shape is a task prior and the detector reports an object once more than half of
    it is visible. So the target can only be where a copy of it, placed there (not overlapping a
    known object, inside the shelf), is at most half visible from *every* view of the episode
    (known objects and the walls occluding; exact :func:`~occrl.envs.visibility.visible_fractions`).
    Each view is paired with the polygons of the objects known when it was taken (an object
    that has moved since hid what was behind it then). Candidate placements: a ``step`` grid of
    positions, ``orientations`` headings. The region is the union of those footprints, shrunk
    by ``shrink``, rasterised on a 5 mm grid.

    While the target is unlocated, Rearrange's queries treat this region as forbidden for the
    gripper (points along the outline of every part) and for every object (they would push the
    hidden target), and the free spot avoids it.

    Examples:
        >>> import numpy as np
        >>> from occrl.baselines.hiding import HidingRegion
        >>> box = lambda x, y, r: np.array([[x-r, y-r], [x+r, y-r], [x+r, y+r], [x-r, y+r]])
        >>> known = [box(0.0, 0.1, 0.05)]  # a 10 cm box straight ahead of the camera
        >>> region = HidingRegion(box(0.0, 0.0, 0.02), views=[(np.array([0.0, -0.1, 0.0]), known)], known=known, step=0.04)
        >>> region([[0.0, 0.25], [0.0, 0.02], [0.0, 0.1]]).tolist()  # behind the box; in view; in the box
        [True, False, False]
    """

    CELL = 0.005

    def __init__(
        self,
        target_vertices: np.ndarray,
        views: list[tuple[np.ndarray, list[np.ndarray]]],
        known: list[np.ndarray],
        step: float = 0.02,
        orientations=(0.0, math.pi / 4),
        shrink: float = 0.002,
    ) -> None:
        xs = np.arange(-C.SHELF_HALF_WIDTH, C.SHELF_HALF_WIDTH + 1e-9, self.CELL)
        ys = np.arange(0.0, C.SHELF_DEPTH + 1e-9, self.CELL)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        cells = np.stack([gx.ravel(), gy.ravel()], 1)
        self.shape = gx.shape
        mask = np.zeros(len(cells), bool)
        tv = np.asarray(target_vertices, float)
        tv = tv - tv.mean(axis=0)
        r = float(np.linalg.norm(tv, axis=1).max())
        small = tv * max(0.0, 1.0 - shrink / max(r, 1e-6))
        views = [(np.asarray(v, float), list(occ) + list(SHELF_WALLS)) for v, occ in views]
        self.placements = 0
        for x in np.arange(-C.SHELF_HALF_WIDTH + 0.01, C.SHELF_HALF_WIDTH, step):
            for y in np.arange(0.01, C.SHELF_DEPTH, step):
                for a in orientations:
                    poly = transform_points(tv, (x, y, a))
                    lo, hi = poly.min(axis=0), poly.max(axis=0)
                    if lo[0] < -C.SHELF_HALF_WIDTH or hi[0] > C.SHELF_HALF_WIDTH or lo[1] < 0.0 or hi[1] > C.SHELF_DEPTH:
                        continue
                    if any(polygons_overlap(poly, k) for k in known):
                        continue
                    self.placements += 1
                    if any(visible_fractions([poly], v, occ)[0] > C.DETECTION_THRESHOLD for v, occ in views):
                        continue
                    mask |= point_in_convex_polygon(cells, transform_points(small, (x, y, a)))
        self.mask = mask.reshape(self.shape)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Which points lie in the region (points outside the shelf never do)."""
        p = np.asarray(points, float).reshape(-1, 2)
        i = np.round((p[:, 0] + C.SHELF_HALF_WIDTH) / self.CELL).astype(int)
        j = np.round(p[:, 1] / self.CELL).astype(int)
        inside = (i >= 0) & (i < self.shape[0]) & (j >= 0) & (j < self.shape[1])
        out = np.zeros(len(p), bool)
        out[inside] = self.mask[i[inside], j[inside]]
        return out

    @property
    def empty(self) -> bool:
        return not self.mask.any()


def probe_points(opening: float, spacing: float = 0.01) -> np.ndarray:
    """Points every ``spacing`` along the outline of every gripper part (gripper frame)."""
    pts = []
    for poly in gripper_polygons(opening):
        for a, b in zip(poly, np.roll(poly, -1, axis=0)):
            n = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing)))
            pts.append(a + (b - a) * np.arange(n)[:, None] / n)
    return np.concatenate(pts)
