"""OpenCV, the optional extra behind the detector and the tag sheet, and the tag dictionaries.

OpenCV is imported only when a detector or a sheet is made; without it, :func:`require_opencv`
raises ``ImportError`` naming ``pip install "occrl[camera]"``.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "require_opencv",
    "as_grey_image",
    "aruco_dictionary",
    "check_dictionary",
    "TagDictionary",
    "DICTIONARIES",
    "DEFAULT_DICTIONARY",
]


class TagDictionary(NamedTuple):
    """A family of tags: OpenCV's name for it, how many ids it has, its data bits per side."""

    opencv_name: str
    size: int
    bits: int


# the AprilTag families OpenCV's ArUco module decodes (same codes as the AprilTag library)
DICTIONARIES = {
    "apriltag_16h5": TagDictionary("DICT_APRILTAG_16h5", 30, 4),
    "apriltag_25h9": TagDictionary("DICT_APRILTAG_25h9", 35, 5),
    "apriltag_36h10": TagDictionary("DICT_APRILTAG_36h10", 2320, 6),
    "apriltag_36h11": TagDictionary("DICT_APRILTAG_36h11", 587, 6),
}
DEFAULT_DICTIONARY = "apriltag_36h11"


def require_opencv() -> ModuleType:
    """The ``cv2`` module with its ArUco part; ``ImportError`` naming the pip command otherwise."""
    try:
        import cv2
    except ImportError as err:
        raise ImportError(f'the tag detector and the tag sheet need OpenCV: pip install "occrl[camera]" ({err})') from None
    if not hasattr(cv2, "aruco") or not hasattr(cv2.aruco, "ArucoDetector"):
        raise ImportError(f'OpenCV {cv2.__version__} has no ArUco detector (4.7 or newer needed): pip install "occrl[camera]"')
    return cv2


def as_grey_image(name: str, image: Any) -> np.ndarray:
    """``image`` as a 2D uint8 array: a grey ``(H, W)`` or an RGB ``(H, W, 3)`` uint8 image (a
    ``(H, W, 4)`` one drops its alpha); ``ValueError`` naming the shape or type otherwise."""
    if not isinstance(image, np.ndarray):
        raise TypeError(f"{name} must be a numpy array (an image), got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise ValueError(f"{name} must be uint8 (0-255), got dtype {image.dtype}")
    if image.ndim == 3 and image.shape[2] in (3, 4):
        cv2 = require_opencv()
        image = cv2.cvtColor(np.ascontiguousarray(image[..., :3]), cv2.COLOR_RGB2GRAY)
    if image.ndim != 2 or min(image.shape) < 8:
        raise ValueError(f"{name} must be a grey (H, W) or RGB (H, W, 3) image of at least 8 x 8 pixels, got shape {image.shape}")
    return np.ascontiguousarray(image)


def check_dictionary(name: str) -> TagDictionary:
    """The dictionary called ``name``; ``ValueError`` listing the names allowed."""
    if name not in DICTIONARIES:
        raise ValueError(f"unknown tag dictionary {name!r}; allowed: {sorted(DICTIONARIES)}")
    return DICTIONARIES[name]


def aruco_dictionary(name: str):
    """OpenCV's ``cv2.aruco.Dictionary`` for ``name`` (a key of :data:`DICTIONARIES`)."""
    entry = check_dictionary(name)
    cv2 = require_opencv()
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, entry.opencv_name))
