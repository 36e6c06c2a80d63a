"""Small catalogues and cameras for the perception tests."""

from __future__ import annotations

from occrl.perception import CameraModel, TagCatalogue, forward_looking_hand_camera

HAND_Z = 0.045  # the MuJoCo hand's gripper-frame height above the floor
CAMERA_OFFSET = (0.0, 0.0, 0.025)  # the wrist camera 7 cm above the floor


def box(half: float) -> list[list[float]]:
    return [[-half, -half], [half, -half], [half, half], [-half, half]]


def camera() -> CameraModel:
    return CameraModel.from_fov(640, 480, 70.0, hand_camera=forward_looking_hand_camera(CAMERA_OFFSET))


def catalogue(objects: list[dict] | None = None) -> TagCatalogue:
    """Two boxes by default: type 3 with a tag on each side face (ids 0-3), type 5 with one (id 10)."""
    if objects is None:
        objects = [
            {
                "type_id": 3,
                "height": 0.12,
                "footprint": box(0.025),
                "tags": [{"tag_id": k, "face": k, "offset": [0.0, 0.07], "size": 0.03} for k in range(4)],
            },
            {
                "type_id": 5,
                "height": 0.10,
                "footprint": box(0.02),
                "tags": [{"tag_id": 10, "face": 0, "offset": [0.0, 0.05], "size": 0.03}],
            },
        ]
    return TagCatalogue.from_dict({"objects": objects})
