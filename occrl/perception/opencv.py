"""OpenCV, the optional extra behind the detector and the tag sheet, and the tag dictionaries.

OpenCV is imported only when a detector or a sheet is made; without it, :func:`require_opencv`
raises ``ImportError`` naming ``pip install "occrl[camera]"``.
"""

from __future__ import annotations

from types import ModuleType
from typing import NamedTuple

__all__ = ["require_opencv", "aruco_dictionary", "check_dictionary", "TagDictionary", "DICTIONARIES", "DEFAULT_DICTIONARY"]


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
