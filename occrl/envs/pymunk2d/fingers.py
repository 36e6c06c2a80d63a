"""The fingers' geometry: which object closing fingers grasp, and where moving fingers stop.

Pure functions of poses and polygons (shelf frame), shared by :class:`~occrl.envs.pymunk2d.world.ShelfWorld`
(which applies them to its simulated shapes) and the planners and teachers that predict a grasp
from what they see (:mod:`occrl.baselines.observed_clearing`).
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import clip_to_band, polygons_overlap, transform_points
from occrl.envs.shelf_geometry import inverse_pose

__all__ = ["grasp_candidate", "reaches_circle", "opening_until_contact", "closing_stop"]


def grasp_candidate(gripper_pose, opening: float, polygons: list[np.ndarray]) -> tuple[int | None, dict[int, np.ndarray]]:
    """The grasp rule. Closing fingers of the given ``opening`` hold an object when it is the only
    one between them, lies across the gripper axis, has its centre within the finger length and
    is no wider than the opening. Returns its index (or None) and, for every object that reaches
    between the fingers, its polygon in the gripper frame.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.fingers import grasp_candidate
        >>> box = np.array([[-0.02, 0.005], [0.02, 0.005], [0.02, 0.045], [-0.02, 0.045]])
        >>> grasp_candidate((0.0, 0.0, 0.0), 0.085, [box])[0]  # between the fingers
        0
        >>> grasp_candidate((0.0, 0.0, 0.0), 0.085, [box + [0.3, 0.0]])  # out of reach
        (None, {})
    """
    if opening <= 1e-6:
        return None, {}  # closed fingers hold nothing between them
    h = opening / 2.0
    band = transform_points(np.array([[-h, 0.0], [h, 0.0], [h, C.FINGER_LENGTH], [-h, C.FINGER_LENGTH]]), gripper_pose)
    inv = inverse_pose(gripper_pose)
    near = reaches_circle(polygons, band.mean(axis=0), math.hypot(h, C.FINGER_LENGTH / 2.0))
    touching = {i: transform_points(p, inv) for i, p in enumerate(polygons) if near[i] and polygons_overlap(p, band)}
    if len(touching) == 1:
        ((i, local),) = touching.items()
        xmin, xmax = local[:, 0].min(), local[:, 0].max()
        cy = local[:, 1].mean()
        if xmin < 0.0 < xmax and 0.0 <= cy <= C.FINGER_LENGTH and xmax - xmin <= opening:
            return i, touching
    return None, touching


def reaches_circle(polygons: Sequence[np.ndarray], centre: np.ndarray, radius: float) -> list[bool]:
    """Whether each polygon's bounding circle reaches the circle (``centre``, ``radius``): a cheap
    exact pre-test before the separating-axis test.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.fingers import reaches_circle
        >>> box = np.array([[0.0, 0.0], [0.02, 0.0], [0.02, 0.02], [0.0, 0.02]])
        >>> reaches_circle([box, box + [1.0, 0.0]], np.array([0.05, 0.01]), 0.04)
        [True, False]
    """
    out = []
    for p in polygons:
        c = p.sum(axis=0) / len(p)  # p.mean(axis=0), the same values, without mean's overhead
        r = math.sqrt(float(((p - c) ** 2).sum(axis=1).max()))
        out.append(math.hypot(c[0] - centre[0], c[1] - centre[1]) <= r + radius)
    return out


def opening_until_contact(gripper_pose, opening: float, shapes: Sequence[np.ndarray], stroke: float = C.GRIPPER_STROKE) -> float:
    """The opening that fingers now ``opening`` apart reach when they open symmetrically towards
    ``stroke``: they stop where one of them first touches one of ``shapes`` (shelf-frame polygons,
    objects and walls). Shapes between or behind the fingers' outer faces are not in the way.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.fingers import opening_until_contact
        >>> post = np.array([[0.045, 0.0], [0.06, 0.0], [0.06, 0.04], [0.045, 0.04]])  # beside the right finger
        >>> round(float(opening_until_contact((0.0, 0.0, 0.0), 0.04, [post])), 3), opening_until_contact((0.0, 0.0, 0.0), 0.04, [])
        (0.066, 0.085)
    """
    inv = inverse_pose(gripper_pose)
    outer = opening / 2.0 + C.FINGER_WIDTH  # outer face of each finger, gripper frame
    half = stroke / 2.0  # half the opening the fingers reach
    sweep_centre = transform_points(np.array([[0.0, C.FINGER_LENGTH / 2.0]]), gripper_pose)[0]
    near = reaches_circle(shapes, sweep_centre, math.hypot(half + C.FINGER_WIDTH, C.FINGER_LENGTH / 2.0))
    for local in (transform_points(p, inv) for p, n in zip(shapes, near) if n):
        part = clip_to_band(local, 0.0, C.FINGER_LENGTH)
        if len(part) == 0:
            continue
        for x in (part[:, 0], -part[:, 0]):  # right finger, then the left one mirrored
            if x.max() <= outer:
                continue  # between or behind the fingers' outer faces: not in the way
            half = min(half, max(x.min(), outer) - C.FINGER_WIDTH)
    return 2.0 * half


def closing_stop(opening: float, touching: Mapping[int, np.ndarray]) -> float:
    """The opening at which closing fingers stop when they grasp nothing: at the first contact
    with an object reaching between them (gripper-frame polygons, as :func:`grasp_candidate`
    returns them), or fully closed on nothing.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.pymunk2d.fingers import closing_stop
        >>> wide = np.array([[-0.03, 0.01], [0.02, 0.01], [0.02, 0.03], [-0.03, 0.03]])
        >>> float(closing_stop(0.085, {0: wide})), closing_stop(0.085, {})
        (0.06, 0.0)
    """
    reach = max([max(-loc[:, 0].min(), loc[:, 0].max(), 0.0) for loc in touching.values()], default=0.0)
    return min(2.0 * reach, opening)
