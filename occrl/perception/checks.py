"""Input checks shared by the perception modules: each raises ``ValueError`` (``TypeError`` for a
wrong kind of value) naming the field, the value and what is allowed."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

__all__ = [
    "check_keys",
    "finite_array",
    "positive_number",
    "strict_int",
    "rigid_transform",
    "convex_footprint",
    "MIN_VERTICES",
    "MAX_VERTICES",
]

# the footprint polygons observation_from_detections accepts (occrl.envs.world_constants)
MIN_VERTICES = 3
MAX_VERTICES = 8


def check_keys(where: str, data: dict, required: Sequence[str], optional: Sequence[str] = ()) -> None:
    """``ValueError`` when the mapping ``data`` (a file's entry) lacks one of ``required`` or holds
    a key outside ``required`` and ``optional``.

    Examples:
        >>> from occrl.perception.checks import check_keys
        >>> check_keys("tag", {"tag_id": 3, "size": 0.03}, ("tag_id", "size"))
        >>> check_keys("tag", {"tag_id": 3}, ("tag_id", "size"))
        Traceback (most recent call last):
        ...
        ValueError: tag is missing ['size']; required: ['tag_id', 'size']
    """
    missing = [k for k in required if k not in data]
    if missing:
        raise ValueError(
            f"{where} is missing {missing}; required: {list(required)}" + (f", optional: {list(optional)}" if optional else "")
        )
    unknown = sorted(set(data) - set(required) - set(optional))
    if unknown:
        raise ValueError(f"{where} has unknown keys {unknown}; allowed: {[*required, *optional]}")


def finite_array(name: str, value: Any, shape: tuple[int, ...], allowed: str) -> np.ndarray:
    """``value`` as a float array of ``shape`` with finite entries.

    Examples:
        >>> from occrl.perception.checks import finite_array
        >>> finite_array("offset", [0.0, 0.05], (2,), "(along, up) in metres").tolist()
        [0.0, 0.05]
        >>> finite_array("offset", [0.0], (2,), "(along, up) in metres")
        Traceback (most recent call last):
        ...
        ValueError: offset must be (along, up) in metres, got [0.0]
    """
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {allowed}, got {value!r}") from None
    if array.shape != shape:
        raise ValueError(f"{name} must be {allowed}, got {value!r}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {value!r}")
    return array


def positive_number(name: str, value: Any, unit: str) -> float:
    """``value`` as a finite float above zero."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number ({unit}), got {value!r}")
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number above 0 ({unit}), got {value!r}")
    return float(value)


def strict_int(name: str, value: Any, low: int, high: int) -> int:
    """``value`` as an int in ``[low, high)``; a bool or a float is refused."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {value!r}")
    if not low <= int(value) < high:
        raise ValueError(f"{name} must be in [{low}, {high}), got {value}")
    return int(value)


def rigid_transform(name: str, value: Any, tolerance: float = 1e-4) -> np.ndarray:
    """``value`` as a 4x4 rigid transform: a rotation (orthonormal, determinant +1, to
    ``tolerance``), a translation and the last row (0, 0, 0, 1).

    Examples:
        >>> import numpy as np
        >>> from occrl.perception.checks import rigid_transform
        >>> rigid_transform("gripper_pose", np.eye(4)).shape
        (4, 4)
        >>> rigid_transform("gripper_pose", np.diag([2.0, 2.0, 2.0, 1.0]))
        Traceback (most recent call last):
        ...
        ValueError: gripper_pose must be a rigid transform: its 3x3 rotation is not orthonormal (R^T R differs from I by 3)
    """
    t = finite_array(name, value, (4, 4), "a 4x4 homogeneous transform (rotation, translation in metres, last row 0 0 0 1)")
    if not np.allclose(t[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise ValueError(f"{name} must have the last row (0, 0, 0, 1), got {t[3].tolist()}")
    r = t[:3, :3]
    off = float(np.abs(r.T @ r - np.eye(3)).max())
    if off > tolerance:
        raise ValueError(f"{name} must be a rigid transform: its 3x3 rotation is not orthonormal (R^T R differs from I by {off:.3g})")
    if np.linalg.det(r) < 0:
        raise ValueError(f"{name} must be a rigid transform: its rotation has determinant -1 (a reflection)")
    return t


def convex_footprint(name: str, value: Any) -> np.ndarray:
    """``value`` as an (n, 2) counter-clockwise strictly convex polygon of 3 to 8 finite vertices
    (clockwise input is reversed), as ``occrl.envs.perception.observation_from_detections`` accepts.

    Examples:
        >>> from occrl.perception.checks import convex_footprint
        >>> convex_footprint("footprint", [[0, 0], [0, 0.04], [0.04, 0.04], [0.04, 0]]).tolist()  # clockwise in
        [[0.04, 0.0], [0.04, 0.04], [0.0, 0.04], [0.0, 0.0]]
    """
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a list of [x, y] pairs of numbers (m), got {value!r}") from None
    if v.ndim != 2 or v.shape[1] != 2:
        raise ValueError(f"{name} must be a list of [x, y] pairs (m), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {v.tolist()}")
    if not MIN_VERTICES <= len(v) <= MAX_VERTICES:
        raise ValueError(f"{name}: a polygon needs {MIN_VERTICES} to {MAX_VERTICES} vertices, got {len(v)}")
    x, y = v[:, 0], v[:, 1]
    area = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    if area < 0:
        v, area = v[::-1].copy(), -area
    if area < 1e-6:
        raise ValueError(f"{name}: degenerate polygon (area {area:.2e} m^2, minimum 1e-06)")
    edges = np.roll(v, -1, axis=0) - v
    turns = edges[:, 0] * np.roll(edges[:, 1], -1) - edges[:, 1] * np.roll(edges[:, 0], -1)
    if np.any(turns <= 0):
        raise ValueError(f"{name}: polygon is not strictly convex (or repeats a vertex); vertices {v.tolist()}")
    return v
