"""What a MuJoCo world's tags tell a detector: the scene's tag catalogue, the wrist camera's
calibration, and the detections of the current frame (:class:`TagObserver`).

The detector is :class:`occrl.perception.TagDetector`, the one a real robot runs: it reads only
the rendered image, the camera's calibration, the gripper's pose and the catalogue, never the
simulator's state.
"""

from __future__ import annotations

import math

import numpy as np

from occrl.envs.mujoco3d.wrist_camera import WristCamera, WristCameraSettings
from occrl.perception import CameraModel, TagCatalogue, TagDetector, TagEntry

__all__ = ["tag_catalogue", "camera_model", "TagObserver"]


def tag_catalogue(world) -> TagCatalogue:
    """The catalogue of a tagged :class:`~occrl.envs.mujoco3d.world.MujocoWorld`: every tag of its
    objects with the object's type, footprint and height (what a lab writes for its own objects).

    Raises ``ValueError`` when the world carries no tags (built with ``tags=False``)."""
    if not world.tags:
        raise ValueError("this world carries no tags: build it with tags=True (make_env(world='mujoco', perception='tags'))")
    entries = []
    for p in world.tags:
        o = world.scene.objects[p.object_index]
        entries.append(
            TagEntry(
                p.tag_id, p.type_id, [tuple(v) for v in o.vertices], float(world.heights[p.object_index]), p.face, (p.along, p.up), p.size
            )
        )
    return TagCatalogue(entries)


def camera_model(settings: WristCameraSettings, hand_camera: np.ndarray) -> CameraModel:
    """The calibration of the simulated wrist camera (ideal pinhole, no distortion)."""
    return CameraModel.from_fov(settings.width, settings.height, math.degrees(settings.fov), hand_camera=hand_camera)


class TagObserver:
    """The wrist camera of one tagged world and the detector reading its frames.

    Args:
        world: a :class:`~occrl.envs.mujoco3d.world.MujocoWorld` built with ``tags=True``.
        settings: the camera's image size, field of view, lighting and image noise.
        rng: the stream of the lighting and image noise (not the world's physics stream).
    """

    def __init__(self, world, settings: WristCameraSettings = WristCameraSettings(), rng: np.random.Generator | None = None) -> None:
        self.world = world
        self.camera = WristCamera(world, settings, rng)
        self.catalogue = tag_catalogue(world)
        self.calibration = camera_model(settings, self.camera.hand_camera())
        self.detector = TagDetector(self.calibration, self.catalogue)

    def image(self) -> np.ndarray:
        """The wrist camera's frame now, (H, W, 3) uint8 RGB."""
        return self.camera.rgb()

    def detections(self, image: np.ndarray | None = None) -> list[dict]:
        """The objects the detector decodes in ``image`` (a new frame when None), in the format
        of :func:`~occrl.envs.perception.observation_from_detections`."""
        frame = self.image() if image is None else image
        return self.detector.detect(frame, self.world.gripper_transform())

    def close(self) -> None:
        self.camera.close()
