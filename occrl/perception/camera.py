"""The wrist camera: a pinhole model with lens distortion and where it sits on the gripper.

Conventions (OpenCV's):

* pixel coordinates: x to the right, y down, the centre of the top-left pixel at (0, 0);
* the camera frame: x right, y down, z forward (along the optical axis), metres;
* ``distortion``: the 5 coefficients (k1, k2, p1, p2, k3) of OpenCV's model;
* ``hand_camera``: the 4x4 transform from the camera frame to the gripper frame, i.e. the camera's
  pose in the gripper frame (``p_gripper = hand_camera @ p_camera``): what OpenCV's
  ``calibrateHandEye`` returns as ``R_cam2gripper``, ``t_cam2gripper``.

The gripper frame is occrl's (:mod:`occrl.envs.world_constants`): origin at the palm's front centre,
+y along the approach direction, +x to the gripper's right, +z up.

A camera file is JSON (``.json``) or YAML (``.yaml`` / ``.yml``, with PyYAML installed) holding the
keys ``width``, ``height``, ``fx``, ``fy``, ``cx``, ``cy``, ``hand_camera`` (4 rows of 4 numbers) and
optionally ``distortion`` (5 numbers, zero by default)::

    {"width": 640, "height": 480, "fx": 457.0, "fy": 457.0, "cx": 319.5, "cy": 239.5,
     "distortion": [0.0, 0.0, 0.0, 0.0, 0.0],
     "hand_camera": [[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0.025], [0, 0, 0, 1]]}
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from occrl.perception.checks import check_keys, finite_array, positive_number, rigid_transform, strict_int

__all__ = ["CameraModel", "load_camera", "save_camera", "forward_looking_hand_camera", "CAMERA_KEYS"]

CAMERA_KEYS = ("width", "height", "fx", "fy", "cx", "cy", "distortion", "hand_camera")
REQUIRED_KEYS = ("width", "height", "fx", "fy", "cx", "cy", "hand_camera")
MIN_IMAGE_SIDE = 8
MAX_IMAGE_SIDE = 100_000
MAX_ASPECT = 2.0  # fx / fy beyond this (or below its inverse) is a calibration error, not a camera


def forward_looking_hand_camera(offset: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """The ``hand_camera`` of a camera that looks along the gripper's approach axis (+y) with the
    image's up along the gripper's +z, its centre at ``offset`` (gripper frame, metres).

    Examples:
        >>> from occrl.perception.camera import forward_looking_hand_camera
        >>> t = forward_looking_hand_camera((0.0, 0.0, 0.025))
        >>> t[:3, 2].tolist(), t[:3, 1].tolist(), t[:3, 3].tolist()  # optical axis, image down, centre
        ([0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, 0.025])
    """
    t = np.eye(4)
    t[:3, :3] = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]
    t[:3, 3] = finite_array("offset", offset, (3,), "(x, y, z) in the gripper frame (m)")
    return t


@dataclass(frozen=True, eq=False)
class CameraModel:
    """A calibrated pinhole camera on the gripper (conventions in :mod:`occrl.perception.camera`).

    Every field is checked when the model is made: ``ValueError`` (``TypeError`` for a wrong kind
    of value) naming the field, the value and what is allowed.

    Examples:
        >>> from occrl.perception import CameraModel
        >>> camera = CameraModel.from_fov(640, 480, 70.0)
        >>> round(camera.fx, 1), camera.cx, camera.cy
        (457.0, 319.5, 239.5)
        >>> CameraModel(640, 480, 457.0, 457.0, 700.0, 239.5)
        Traceback (most recent call last):
        ...
        ValueError: cx must lie in the image, [0, 640) pixels, got 700.0 (the principal point of a 640 x 480 image)
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)
    hand_camera: np.ndarray = field(default_factory=forward_looking_hand_camera)

    def __post_init__(self) -> None:
        width = strict_int("width", self.width, MIN_IMAGE_SIDE, MAX_IMAGE_SIDE)
        height = strict_int("height", self.height, MIN_IMAGE_SIDE, MAX_IMAGE_SIDE)
        fx = positive_number("fx", self.fx, "focal length in pixels")
        fy = positive_number("fy", self.fy, "focal length in pixels")
        if not 1 / MAX_ASPECT <= fx / fy <= MAX_ASPECT:
            raise ValueError(
                f"fx / fy = {fx / fy:.3g} is not a camera's pixel aspect (allowed {1 / MAX_ASPECT}-{MAX_ASPECT}); check the calibration"
            )
        cx = float(finite_array("cx", self.cx, (), "a number (pixels)"))
        cy = float(finite_array("cy", self.cy, (), "a number (pixels)"))
        for name, value, side in (("cx", cx, width), ("cy", cy, height)):
            if not 0 <= value < side:
                raise ValueError(
                    f"{name} must lie in the image, [0, {side}) pixels, got {value} (the principal point of a {width} x {height} image)"
                )
        dist = finite_array("distortion", self.distortion, (5,), "5 numbers (k1, k2, p1, p2, k3), OpenCV's order")
        hand = rigid_transform("hand_camera", self.hand_camera).copy()
        hand.flags.writeable = False
        for name, value in (("width", width), ("height", height), ("fx", fx), ("fy", fy), ("cx", cx), ("cy", cy)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "distortion", tuple(float(d) for d in dist))
        object.__setattr__(self, "hand_camera", hand)

    @classmethod
    def from_fov(
        cls,
        width: int,
        height: int,
        horizontal_fov_deg: float,
        hand_camera: np.ndarray | None = None,
        distortion: Sequence[float] = (0.0,) * 5,
    ) -> "CameraModel":
        """An ideal camera of ``horizontal_fov_deg`` across (square pixels, the principal point at
        the image centre), e.g. a simulated one. ``hand_camera`` defaults to
        :func:`forward_looking_hand_camera`."""
        fov = float(finite_array("horizontal_fov_deg", horizontal_fov_deg, (), "a number of degrees"))
        if not 0 < fov < 180:
            raise ValueError(f"horizontal_fov_deg must be in (0, 180) degrees, got {fov}")
        w = strict_int("width", width, MIN_IMAGE_SIDE, MAX_IMAGE_SIDE)
        h = strict_int("height", height, MIN_IMAGE_SIDE, MAX_IMAGE_SIDE)
        f = w / 2 / math.tan(math.radians(fov) / 2)
        hand = forward_looking_hand_camera() if hand_camera is None else hand_camera
        return cls(w, h, f, f, (w - 1) / 2, (h - 1) / 2, tuple(distortion), hand)

    @property
    def intrinsic_matrix(self) -> np.ndarray:
        """The 3x3 camera matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion_array(self) -> np.ndarray:
        """The 5 distortion coefficients as an array."""
        return np.array(self.distortion)

    @property
    def horizontal_fov_deg(self) -> float:
        """The horizontal field of view of the undistorted model (degrees)."""
        return math.degrees(2 * math.atan(self.width / 2 / self.fx))

    def to_dict(self) -> dict[str, Any]:
        """The camera file's content (JSON-ready)."""
        return {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "distortion": list(self.distortion),
            "hand_camera": self.hand_camera.tolist(),
        }

    @classmethod
    def from_dict(cls, data: Any, source: str = "camera") -> "CameraModel":
        """The camera of a camera file's content; ``ValueError`` naming a missing or unknown key."""
        if not isinstance(data, dict):
            raise ValueError(f"{source} must hold a mapping with the keys {list(CAMERA_KEYS)}, got {type(data).__name__}")
        check_keys(source, data, REQUIRED_KEYS, ("distortion",))
        kwargs = {k: data[k] for k in CAMERA_KEYS if k in data}
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as err:  # a file's bad value is bad input
            raise ValueError(f"{source}: {err}") from None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CameraModel):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(json.dumps(self.to_dict()))


def _require_yaml(path: Path):
    try:
        import yaml
    except ImportError:
        raise ImportError(f"reading or writing the YAML file {path} needs PyYAML: pip install pyyaml (or use a .json file)") from None
    return yaml


def _format(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix == ".json":
        return "json"
    if suffix in (".yaml", ".yml"):
        return "yaml"
    raise ValueError(f"camera file {path}: the suffix must be .json, .yaml or .yml, got {suffix!r}")


def load_camera(path: str | Path) -> CameraModel:
    """Read a camera file (format in :mod:`occrl.perception.camera`).

    Raises ``FileNotFoundError`` for a missing file and ``ValueError`` naming the file and the
    problem for anything unreadable, missing or inconsistent.
    """
    path = Path(path)
    kind = _format(path)
    if not path.is_file():
        raise FileNotFoundError(f"camera file {path} does not exist")
    text = path.read_text()
    if kind == "json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as err:
            raise ValueError(f"camera file {path} is not valid JSON: {err}") from None
    else:
        yaml = _require_yaml(path)
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as err:
            raise ValueError(f"camera file {path} is not valid YAML: {err}") from None
    return CameraModel.from_dict(data, source=f"camera file {path}")


def save_camera(model: CameraModel, path: str | Path) -> None:
    """Write ``model`` to a camera file, JSON or YAML by the suffix."""
    if not isinstance(model, CameraModel):
        raise TypeError(f"model must be a CameraModel, got {type(model).__name__}")
    path = Path(path)
    kind = _format(path)
    if kind == "json":
        text = json.dumps(model.to_dict(), indent=2) + "\n"
    else:
        text = _require_yaml(path).safe_dump(model.to_dict(), sort_keys=False)
    path.write_text(text)
