"""Camera perception: from a wrist-camera image to the detections occrl's planners take.

A calibrated :class:`CameraModel` on the gripper, a :class:`TagCatalogue` saying which fiducial
tag sits where on which object, and a :class:`TagDetector` (OpenCV's ArUco module decoding AprilTag
36h11 tags) whose :meth:`~TagDetector.detect` returns the list
``occrl.envs.perception.observation_from_detections`` takes. This package needs neither torch nor
the simulators; the detector needs OpenCV: ``pip install "occrl[camera]"``.
"""

from occrl.perception.camera import CameraModel, forward_looking_hand_camera, load_camera, save_camera
from occrl.perception.catalogue import TagCatalogue, TagEntry
from occrl.perception.detector import TagDetector
from occrl.perception.frames import gripper_pose_matrix

__all__ = [
    "CameraModel",
    "load_camera",
    "save_camera",
    "forward_looking_hand_camera",
    "TagEntry",
    "TagCatalogue",
    "TagDetector",
    "gripper_pose_matrix",
]
