"""What the shelf world's bodies weigh and how its shapes are laid out: the gripper's moment of
inertia, an object's mass and moment, the objects' padded polygons and radii, the fingers'
vertices at an opening. Each is computed once per input and remembered (a planner's recreated
objects and scenes recur at every decision); the values are those of the plain computation.
"""

from __future__ import annotations

import numpy as np
import pymunk

from occrl.envs import world_constants as C
from occrl.envs.geometry import pad_polygons, polygon_area
from occrl.envs.shelf_geometry import gripper_polygons

__all__ = ["gripper_moment", "mass_and_moment", "padded_and_radii", "finger_vertices", "CACHE_SIZE"]

CACHE_SIZE = 4096  # entries each cache remembers before it starts afresh

_GRIPPER_MOMENTS: dict[float, float] = {}
_MASS_CACHE: dict[tuple, tuple[float, float]] = {}
_PADDED_CACHE: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
_FINGER_VERTICES: dict[tuple[float, float], tuple[list, list]] = {}  # the fingers' vertex lists by opening (read only)


def gripper_moment(mass: float) -> float:
    """The gripper's moment of inertia at this mass (its parts' polygons, mass spread by area);
    the same for every world, so computed once per mass.

    Examples:
        >>> from occrl.envs.pymunk2d.body_properties import gripper_moment
        >>> gripper_moment(2.0) == 2 * gripper_moment(1.0) and gripper_moment(1.0) > 0
        True
    """
    if mass not in _GRIPPER_MOMENTS:
        polys = gripper_polygons(C.GRIPPER_STROKE)
        total_area = sum(polygon_area(p) for p in polys)
        _GRIPPER_MOMENTS[mass] = sum(pymunk.moment_for_poly(mass * polygon_area(p) / total_area, p.tolist()) for p in polys)
    return _GRIPPER_MOMENTS[mass]


def mass_and_moment(vertices: np.ndarray, density: float) -> tuple[float, float]:
    """A polygon's mass (``density`` x area) and its moment about its origin, as
    ``pymunk.moment_for_poly`` gives it; each polygon's computed once and remembered (the same
    values: the key holds the vertices' bytes and layout, on which the arithmetic depends).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.body_properties import mass_and_moment
        >>> square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
        >>> mass, moment = mass_and_moment(square, 2.0)
        >>> mass, round(moment, 6)  # a unit square of density 2: m (a^2 + b^2) / 12
        (2.0, 0.333333)
    """
    key = (vertices.tobytes(), vertices.shape, vertices.strides, vertices.dtype.str, density)
    found = _MASS_CACHE.get(key)
    if found is None:
        if len(_MASS_CACHE) >= CACHE_SIZE:  # (noisy execution worlds make new polygons every action)
            _MASS_CACHE.clear()
        mass = density * polygon_area(vertices)
        found = _MASS_CACHE[key] = (mass, pymunk.moment_for_poly(mass, vertices.tolist()))
    return found


def padded_and_radii(vertices: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The objects' polygons padded to MAX_VERTICES by repeating the first vertex, (n, V, 2), and
    each one's largest vertex distance from its centroid, (n,) (np.linalg.norm's sqrt(x * x +
    y * y) over the padded vertices: the repeated first vertex changes no maximum); both read
    only, remembered per object set (the key holds each polygon's shape and bytes).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.body_properties import padded_and_radii
        >>> padded, radius = padded_and_radii([np.array([[0.03, 0.0], [0.0, 0.04], [0.0, -0.04]])])
        >>> padded.shape[0], float(radius[0]), padded.flags.writeable
        (1, 0.04, False)
    """
    key = tuple((v.shape, v.tobytes()) for v in vertices)
    found = _PADDED_CACHE.get(key)
    if found is None:
        if len(_PADDED_CACHE) >= CACHE_SIZE:
            _PADDED_CACHE.clear()
        pv = pad_polygons(vertices, C.MAX_VERTICES)
        radius = np.sqrt(pv[..., 0] * pv[..., 0] + pv[..., 1] * pv[..., 1]).max(-1, initial=0.0)
        pv.flags.writeable = radius.flags.writeable = False
        found = _PADDED_CACHE[key] = (pv, radius)
    return found


def finger_vertices(key: tuple[float, float]) -> tuple[list, list]:
    """The two fingers' vertex lists at the opening ``key[0]`` (``key``: the opening and its sign,
    ``math.copysign(1.0, opening)``: -0.0 gives fingers of other zero signs than 0.0), as
    :func:`~occrl.envs.shelf_geometry.gripper_polygons` places them; read only.

    Examples:
        >>> from occrl.envs.pymunk2d.body_properties import finger_vertices
        >>> left, right = finger_vertices((0.05, 1.0))
        >>> len(left), len(right)
        (4, 4)
    """
    fingers = _FINGER_VERTICES.get(key)
    if fingers is None:
        if len(_FINGER_VERTICES) >= CACHE_SIZE:
            _FINGER_VERTICES.clear()
        polys = gripper_polygons(key[0])
        fingers = _FINGER_VERTICES[key] = (polys[1].tolist(), polys[2].tolist())
    return fingers
