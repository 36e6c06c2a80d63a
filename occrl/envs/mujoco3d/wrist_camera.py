"""The wrist camera's RGB image of a MuJoCo world: a 640 x 480 colour camera with a 70 degree
horizontal field of view on the gripper (the model's ``"wrist"`` camera), tags drawn, with seeded
lighting and image noise.

Its calibration in OpenCV's convention (x right, y down, z along the optical axis; pixel ``(0, 0)``
the centre of the top-left pixel): focal length ``(width / 2) / tan(fov / 2)`` pixels in both
directions, principal point at the image centre ``((width - 1) / 2, (height - 1) / 2)``, no
distortion; :meth:`WristCamera.hand_camera` is the camera's pose in the gripper frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.mujoco3d.camera import RendererOwner, new_renderer, require_mujoco
from occrl.envs.mujoco3d.tags import TAG_GROUP

__all__ = ["WristCameraSettings", "WristCamera", "OPENCV_FROM_MUJOCO"]

# MuJoCo cameras look along -z with y up; OpenCV's along +z with y down
OPENCV_FROM_MUJOCO = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class WristCameraSettings:
    """Image size, horizontal field of view and the randomisation of the wrist camera's images.

    ``lighting``: each episode scales the lights' intensities by factors drawn uniformly in
    [1 - lighting, 1 + lighting] and tilts the overhead light by up to ``lighting`` x 45 degrees.
    ``image_noise``: standard deviation of Gaussian pixel noise (grey levels, 0-255), drawn anew
    for every frame (from the episode's stream and the frame's simulated time: the same world state
    always shows the same noise). Both 0 by default (the nominal, noise-free image).

    Examples:
        >>> from occrl.envs.mujoco3d.wrist_camera import WristCameraSettings
        >>> s = WristCameraSettings()
        >>> s.width, s.height, round(s.focal_length, 1), s.principal_point
        (640, 480, 457.0, (319.5, 239.5))
    """

    width: int = 640
    height: int = 480
    fov: float = C.CAMERA_FOV
    lighting: float = 0.0
    image_noise: float = 0.0

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 16 <= value <= 4096:
                raise ValueError(f"{name} must be an int in [16, 4096] pixels, got {value!r}")
        if not isinstance(self.fov, (int, float)) or not 0.0 < self.fov < math.pi:
            raise ValueError(f"fov must be a horizontal field of view in (0, pi) radians, got {self.fov!r}")
        if not isinstance(self.lighting, (int, float)) or not 0.0 <= self.lighting <= 0.9:
            raise ValueError(f"lighting must be in [0, 0.9] (relative change of the light intensities), got {self.lighting!r}")
        if not isinstance(self.image_noise, (int, float)) or not 0.0 <= self.image_noise <= 50.0:
            raise ValueError(f"image_noise must be in [0, 50] grey levels (standard deviation), got {self.image_noise!r}")

    @property
    def focal_length(self) -> float:
        """Pixels, the same in x and y (square pixels)."""
        return (self.width / 2) / math.tan(self.fov / 2)

    @property
    def principal_point(self) -> tuple[float, float]:
        return ((self.width - 1) / 2, (self.height - 1) / 2)

    @property
    def fovy_degrees(self) -> float:
        return math.degrees(2 * math.atan(math.tan(self.fov / 2) * self.height / self.width))

    def camera_matrix(self) -> np.ndarray:
        """OpenCV's 3 x 3 intrinsic matrix."""
        f = self.focal_length
        cx, cy = self.principal_point
        return np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])


class WristCamera(RendererOwner):
    """RGB frames of a :class:`~occrl.envs.mujoco3d.world.MujocoWorld`'s wrist camera, tags drawn.

    The world's ``"wrist"`` camera must have this camera's vertical field of view (the env builds
    both from the same 70 degrees across and a 4:3 image). ``rng`` draws the episode's lighting and
    the seed of its image noise once, here (a stream of its own: the world's physics noise is not
    touched); a frame's noise is drawn from that seed and the world's simulated time, so rendering
    a frame again, or more often, changes no other frame.
    """

    def __init__(self, world, settings: WristCameraSettings = WristCameraSettings(), rng: np.random.Generator | None = None) -> None:
        mujoco, _ = require_mujoco()
        self.world = world
        self.settings = settings
        self.rng = rng if rng is not None else np.random.default_rng(0)
        m = world.model
        fovy = float(m.cam_fovy[world.camera_id])
        if abs(fovy - settings.fovy_degrees) > 1e-6:
            raise ValueError(
                f"the world's wrist camera has a {fovy:.3f} degree vertical field of view, these settings {settings.fovy_degrees:.3f}"
            )
        self._option = mujoco.MjvOption()
        self._option.geomgroup[TAG_GROUP] = 1
        if settings.lighting > 0.0:
            self._randomise_lighting(m)
        self._noise_seed = int(self.rng.integers(2**63)) if settings.image_noise > 0.0 else 0
        self.renderer = new_renderer(m, settings.height, settings.width)

    def _randomise_lighting(self, m) -> None:
        lvl, rng = self.settings.lighting, self.rng
        m.vis.headlight.ambient[:] = np.asarray(m.vis.headlight.ambient) * rng.uniform(1 - lvl, 1 + lvl)
        m.vis.headlight.diffuse[:] = np.asarray(m.vis.headlight.diffuse) * rng.uniform(1 - lvl, 1 + lvl)
        m.light_diffuse[:] = m.light_diffuse * rng.uniform(1 - lvl, 1 + lvl, size=(m.nlight, 1))
        tilt, azimuth = rng.uniform(0.0, lvl * math.pi / 4), rng.uniform(-math.pi, math.pi)
        m.light_dir[:] = (math.sin(tilt) * math.cos(azimuth), math.sin(tilt) * math.sin(azimuth), -math.cos(tilt))

    def rgb(self) -> np.ndarray:
        """(height, width, 3) uint8 image of the camera now (fingers and tags drawn)."""
        r = self.renderer
        r.update_scene(self.world.data, camera=self.world.camera_id, scene_option=self._option)
        image = r.render()
        if self.settings.image_noise > 0.0:
            frame = np.random.default_rng([self._noise_seed, round(self.world.data.time * 1e6)])  # microseconds of simulated time
            noisy = image + frame.normal(0.0, self.settings.image_noise, size=image.shape)
            image = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
        return image.copy()

    def hand_camera(self) -> np.ndarray:
        """4 x 4 pose of the camera (OpenCV axes) in the gripper frame
        (:meth:`~occrl.envs.mujoco3d.world.MujocoWorld.gripper_transform`), from the model."""
        mujoco, _ = require_mujoco()
        m, cam = self.world.model, self.world.camera_id
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, m.cam_quat[cam])
        camera = np.eye(4)
        camera[:3, :3] = rot.reshape(3, 3) @ OPENCV_FROM_MUJOCO
        camera[:3, 3] = m.cam_pos[cam]
        return camera
