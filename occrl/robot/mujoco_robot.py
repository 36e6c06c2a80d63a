"""A robot made of the MuJoCo shelf: the :class:`~occrl.robot.protocol.Robot` methods backed by a
tagged :class:`~occrl.envs.mujoco3d.world.MujocoWorld` and its wrist camera.

Built from a task (a scene and its seed) it is the world ``make_env(world="mujoco",
perception="tags")`` builds for that task, with the same physics noise and the same camera images,
so :func:`~occrl.robot.loop.run_on_robot` on it decides as the env's tag path does: the test of the
robot loop, and a rehearsal before a real robot.
"""

from __future__ import annotations

import numpy as np

from occrl.envs.mujoco3d.tag_perception import TagObserver
from occrl.envs.mujoco3d.world import MujocoWorld
from occrl.envs.mujoco3d.wrist_camera import WristCameraSettings
from occrl.envs.scene import Scene
from occrl.perception import TagDetector

__all__ = ["MujocoRobot"]


class MujocoRobot:
    """The MuJoCo shelf as a robot.

    Args:
        scene: the task's shelf (e.g. :func:`occrl.envs.episodes.task_scenes`).
        seed: the task seed: it seeds the physics noise, and a stream spawned from it the camera's
            lighting and image noise, as ``make_env(..., seed=[seed])`` does.
        noise: execution noise on density and friction (as the envs' ``noise``).
        wrist_camera: the camera's image size, field of view, lighting and image noise.

    Examples:
        >>> from occrl.envs.episodes import task_scenes  # doctest: +SKIP
        >>> from occrl.robot import MujocoRobot, run_on_robot  # doctest: +SKIP
        >>> robot = MujocoRobot(task_scenes(1, [3])[0], seed=3)  # doctest: +SKIP
        >>> robot.camera_image().shape, robot.task_status()  # doctest: +SKIP
        ((480, 640, 3), 'running')
    """

    def __init__(self, scene: Scene, seed: int = 0, noise: float = 0.0, wrist_camera: WristCameraSettings = WristCameraSettings()) -> None:
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be an occrl.envs.Scene, got {type(scene).__name__}")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be an int >= 0, got {seed!r}")
        if not isinstance(wrist_camera, WristCameraSettings):
            raise TypeError(f"wrist_camera must be a WristCameraSettings, got {type(wrist_camera).__name__}")
        rng = np.random.default_rng(int(seed))
        self.scene = scene
        self.world = MujocoWorld(scene, visibility="rays", noise=noise, rng=rng, tags=True)
        self.observer = TagObserver(self.world, wrist_camera, rng.spawn(1)[0])
        self._status = "running"

    # ------------------------------------------------------------------ the task and calibration
    @property
    def target_type(self) -> int:
        return int(self.scene.target.type_id)

    @property
    def target_vertices(self) -> np.ndarray:
        return np.asarray(self.scene.target.vertices, dtype=float)

    def detector(self) -> TagDetector:
        """A tag detector with this robot's camera calibration and tag catalogue."""
        return TagDetector(self.observer.calibration, self.observer.catalogue)

    # ------------------------------------------------------------------ the Robot protocol
    def camera_image(self) -> np.ndarray:
        return self.observer.image()

    def gripper_pose(self) -> np.ndarray:
        return self.world.gripper_pose()

    def gripper_transform(self) -> np.ndarray:
        return self.world.gripper_transform()

    def gripper_opening(self) -> float:
        return self.world.opening

    def gripper_closed(self) -> bool:
        return bool(self.world.closed)

    def execute(self, action: np.ndarray) -> None:
        outcome = self.world.step(action)
        self._status = "retrieved" if outcome.retrieved else "dropped" if outcome.dropped else "running"

    def task_status(self) -> str:
        return self._status

    def close(self) -> None:
        """Free the renderers."""
        self.observer.close()
        self.world.close()
