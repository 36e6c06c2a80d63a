"""MujocoShelfEnv: the shelf task executed in 3D MuJoCo (DESIGN section 10, paper Sec. VII).

The realistic execution env. It has ShelfEnv's action semantics, observation keys and specs, so
every policy and planner runs on it unchanged; the planners keep planning in the pymunk world
recreated from the detections this env reports. mujoco and dm_control are an optional extra
(``pip install -e ".[mujoco]"``); nothing here imports them until an env is built.
"""

from __future__ import annotations

import logging
from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Bounded

from occrl.envs import world_constants as C
from occrl.envs.mujoco3d.camera import CameraConfig, gl_available, require_mujoco
from occrl.envs.mujoco3d.model import OBJECT_HEIGHT_RANGE
from occrl.envs.mujoco3d.world import MujocoWorld
from occrl.envs.scene import Scene
from occrl.envs.shelf_env import ShelfEnv

__all__ = ["MujocoShelfEnv", "VISIBILITY_BACKENDS"]

logger = logging.getLogger(__name__)

VISIBILITY_BACKENDS = ("auto", "render", "rays")


class MujocoShelfEnv(ShelfEnv):
    """Retrieve a target object from a cluttered 3D shelf simulated in MuJoCo; a batch of worlds.

    The same task, actions, observation keys, specs, rewards and episode ends as
    :class:`~occrl.envs.ShelfEnv`, executed in a 3D model built with dm_control ``mjcf``: a
    W 0.50 x D 0.35 x H 0.30 m shelf, the scene's polygons extruded to 10-18 cm tall prisms with
    mass and friction, and a planar Robotiq 2F-85 (position-servoed hand on slide x, slide y and
    hinge z joints, two coupled force-limited fingers with an 85 mm stroke) that grasps by contact
    and friction alone. See :mod:`occrl.envs.mujoco3d.world` for the model.

    Perception: only objects more than 50 % visible in the gripper camera (70 degree horizontal
    field of view) are reported, with type id, planar pose and the type's polygon. The visible
    fraction is (pixels where the object is the first thing hit) / (pixels it would cover alone),
    the numerator from a segmentation render or from ``mujoco.mj_multiRay`` through the same pixel
    centres. Ground truth (poses, fractions, contact grasp) is under ``"privileged"``.

    Action Space:
        ``Bounded(-1, 1, (4,))``: forward, lateral, rotation in the gripper frame (5 cm, 5 cm,
        15 degrees) and the gripper command (> 0 close, <= 0 open). A changed command first
        closes or opens the fingers (0.4 s), then the hand moves at constant velocity for 0.5 s
        and holds still 0.2 s. Out-of-range values are clipped; NaN or inf raise ``ValueError``
        and leave every world unchanged.

    Rewards:
        -1 per action; -50 more when an object other than the held target leaves the shelf
        (centroid past the front edge, 5 cm beyond the side or back walls, or fallen).

    Episode Termination:
        ``success`` when the target is held between the fingers (both touch it, gripper closed)
        and its centroid is past y = -0.05; ``dropped`` as above; truncated after ``max_steps``.

    Args:
        batch_size, stage, noise, seed, scenes, num_objects, max_steps, device: as in
            :class:`~occrl.envs.ShelfEnv` (the same seed gives the same scenes). ``noise``
            perturbs density and friction before each action; shapes stay nominal.
        visibility: ``"render"`` (segmentation render, needs an OpenGL backend: a display, or
            EGL/OSMesa headless, found automatically), ``"rays"`` (``mj_multiRay``, no GL) or
            ``"auto"`` (render when a GL backend works, else rays; the choice is logged).
        record_camera: also return ``"camera_rgb"``, the gripper camera image (3 x H x W uint8).
            Needs an OpenGL backend.
        camera_size: (height, width) of the camera image, used for visibility and recording.
        object_height: object height in m, or a (low, high) range from which each type id gets
            a fixed height.

    Raises:
        ImportError: mujoco or dm_control are missing (the message names the extra to install).

    Examples:
        >>> from occrl.envs import MujocoShelfEnv  # doctest: +SKIP
        >>> env = MujocoShelfEnv(batch_size=2, stage=1, seed=0, visibility="rays")  # doctest: +SKIP
        >>> env.rollout(3)["next", "reward"].shape  # doctest: +SKIP
        torch.Size([2, 3, 1])
    """

    batch_locked = True

    def __init__(
        self,
        batch_size: int | Sequence[int] = 1,
        stage: int = 1,
        noise: float = 0.0,
        seed: int | Sequence[int] | None = None,
        scenes: Sequence[Scene] | None = None,
        num_objects: int | None = None,
        max_steps: int = C.MAX_EPISODE_STEPS,
        device: str | torch.device = "cpu",
        visibility: str = "auto",
        record_camera: bool = False,
        camera_size: tuple[int, int] = (120, 160),
        object_height: float | tuple[float, float] = OBJECT_HEIGHT_RANGE,
    ) -> None:
        require_mujoco()
        if visibility not in VISIBILITY_BACKENDS:
            raise ValueError(f"visibility must be one of {VISIBILITY_BACKENDS}, got {visibility!r}")
        h, w = (int(v) for v in camera_size)
        if h < 8 or w < 8:
            raise ValueError(f"camera_size must be (height, width) of at least 8 pixels, got {camera_size}")
        # set before ShelfEnv.__init__, which builds the specs (camera entry) and validates the rest
        self.camera = CameraConfig(height=h, width=w)
        self.object_height = object_height
        self.record_camera = bool(record_camera)
        self.visibility = self._pick_visibility(visibility)
        super().__init__(
            batch_size=batch_size,
            stage=stage,
            noise=noise,
            seed=seed,
            scenes=scenes,
            num_objects=num_objects,
            max_steps=max_steps,
            device=device,
        )

    def _pick_visibility(self, requested: str) -> str:
        if requested == "rays" and not self.record_camera:
            logger.info("MujocoShelfEnv visibility: ray casting (mujoco.mj_multiRay), as requested")
            return "rays"
        ok, why = gl_available()
        if requested == "rays":
            if not ok:
                raise RuntimeError(f"record_camera=True needs an OpenGL backend for MuJoCo, none works: {why}")
            logger.info("MujocoShelfEnv visibility: ray casting (mujoco.mj_multiRay), as requested")
            return "rays"
        if ok:
            logger.info("MujocoShelfEnv visibility: segmentation render, OpenGL backend %s", why)
            return "render"
        if requested == "render" or self.record_camera:
            raise RuntimeError(
                f"visibility='render' / record_camera=True need an OpenGL backend for MuJoCo, none works: {why}. "
                "Use visibility='rays' (no GL needed) or install EGL/OSMesa."
            )
        logger.warning("MujocoShelfEnv visibility: no OpenGL backend (%s); falling back to ray casting (mujoco.mj_multiRay)", why)
        return "rays"

    # ------------------------------------------------------------------ specs
    def _make_specs(self) -> None:
        super()._make_specs()  # the same specs as the 2D env, so everything downstream runs unchanged
        if self.record_camera:
            h, w = self.camera.height, self.camera.width
            self.observation_spec["camera_rgb"] = Bounded(0, 255, shape=(*self.batch_size, 3, h, w), dtype=torch.uint8)

    # ------------------------------------------------------------------ lifecycle
    def close(self, *, raise_if_closed: bool = True) -> None:
        """Free the worlds' OpenGL contexts."""
        for w in self.worlds:
            if w is not None:
                w.close()
        super().close(raise_if_closed=raise_if_closed)

    # ------------------------------------------------------------------ ShelfEnv's world hooks
    def _new_world(self, i: int) -> MujocoWorld:
        return MujocoWorld(
            self._next_scene(i),
            camera=self.camera,
            visibility=self.visibility,
            record_camera=self.record_camera,
            noise=self.noise,
            rng=self._rngs[i],
            object_height=self.object_height,
        )

    def _release_world(self, world: MujocoWorld) -> None:
        world.close()

    def _visible_fractions(self, world: MujocoWorld, poses: np.ndarray) -> np.ndarray:
        return world.visible_fractions()  # pixels or rays of the gripper camera

    def _extend_observation(self, out: TensorDictBase) -> TensorDictBase:
        if self.record_camera:
            out.set("camera_rgb", torch.from_numpy(np.stack([w.rgb().transpose(2, 0, 1) for w in self.worlds])))
        return out
