"""MujocoShelfEnv: the shelf task executed in 3D MuJoCo (DESIGN section 10, paper Sec. VII).

The realistic execution env. It has ShelfEnv's action semantics, observation keys and specs, so
every policy and planner runs on it unchanged; the planners keep planning in the pymunk world
recreated from the detections this env reports. mujoco and dm_control are an optional extra
(``pip install -e ".[mujoco]"``); nothing here imports them until an env is built.
"""

from __future__ import annotations

import logging
import math
from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Bounded

from occrl.envs import world_constants as C
from occrl.envs.mujoco3d.camera import CameraConfig, gl_available, require_mujoco
from occrl.envs.mujoco3d.model import OBJECT_HEIGHT_RANGE, SHELF_HEIGHT, check_shelf_height
from occrl.envs.mujoco3d.tags import DEFAULT_TAG_LAYOUT, TagLayout, as_tag_layout
from occrl.envs.mujoco3d.world import MujocoWorld
from occrl.envs.mujoco3d.wrist_camera import WristCameraSettings
from occrl.envs.scene import Scene
from occrl.envs.shelf_env import ShelfEnv

__all__ = ["MujocoShelfEnv", "VISIBILITY_BACKENDS", "PERCEPTION_MODES"]

logger = logging.getLogger(__name__)

VISIBILITY_BACKENDS = ("auto", "render", "rays")
PERCEPTION_MODES = ("geometric", "tags")  # what the planner is told it sees (the perception argument)


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
    With ``perception="tags"`` the objects wear fiducial tags instead
    (:mod:`~occrl.envs.mujoco3d.tags`) and the detections are what
    :class:`occrl.perception.TagDetector` decodes in the wrist camera's 640 x 480 RGB frame: an
    object none of whose tags is decoded is not seen, and a seen object's pose is the detector's
    estimate. Each type keeps the slot it was first seen in (:class:`~occrl.envs.detection_slots.DetectionSlots`).

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
        shelf_height: the shelf's inside height in m (0.30 by default; 0.40 is the papers' real
            shelf, :data:`~occrl.envs.mujoco3d.model.PAPERS_SHELF_HEIGHT`): only the top board
            moves (above every object and the gripper), so what changes is the light in the
            camera's images.
        perception: ``"geometric"`` (the default: the objects more than 50 % visible, at their true
            poses) or ``"tags"`` (what the tag detector decodes; needs OpenCV,
            ``pip install -e ".[camera]"``, and an OpenGL backend).
        wrist_camera: with ``perception="tags"``, the RGB camera's image size, field of view,
            lighting and image noise (:class:`~occrl.envs.mujoco3d.wrist_camera.WristCameraSettings`;
            640 x 480, 70 degrees across, nominal light, no noise by default). The lighting and
            noise draw from a stream spawned from each world's seed, a frame's noise from that
            stream's seed and the frame's simulated time: a seed fixes the images, in any batch.
        tag_layout: with ``perception="tags"``, the objects' tags: a
            :class:`~occrl.envs.mujoco3d.tags.TagLayout` or a name in
            :data:`~occrl.envs.mujoco3d.tags.TAG_LAYOUTS` (``"pairs"``, the default: each tag as
            wide as its face allows, 8 mm to 6 cm, and two side by side on faces of 3.95 cm and
            more; ``"fitted"``: one per face; ``"at-most-3cm"``: one per face, 1 to 3 cm).

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
        perception: str = "geometric",
        wrist_camera: WristCameraSettings | None = None,
        shelf_height: float = SHELF_HEIGHT,
        tag_layout: str | TagLayout = DEFAULT_TAG_LAYOUT,
    ) -> None:
        require_mujoco()
        self.shelf_height = check_shelf_height(shelf_height)
        if visibility not in VISIBILITY_BACKENDS:
            raise ValueError(f"visibility must be one of {VISIBILITY_BACKENDS}, got {visibility!r}")
        if perception not in PERCEPTION_MODES:
            raise ValueError(f"perception must be one of {PERCEPTION_MODES}, got {perception!r}")
        if wrist_camera is not None and perception != "tags":
            raise ValueError("wrist_camera sets the tag detector's camera: give it with perception='tags'")
        self.tag_layout = as_tag_layout(tag_layout)
        if self.tag_layout != as_tag_layout(DEFAULT_TAG_LAYOUT) and perception != "tags":
            raise ValueError("tag_layout sizes the tags the detector reads: give it with perception='tags'")
        if wrist_camera is not None and not isinstance(wrist_camera, WristCameraSettings):
            raise TypeError(f"wrist_camera must be a WristCameraSettings, got {type(wrist_camera).__name__}")
        self.perception = perception
        self.wrist_camera = wrist_camera if wrist_camera is not None else WristCameraSettings()
        self._observers: list = []
        self._slots: list = []
        if perception == "tags":
            from occrl.perception.opencv import require_opencv

            require_opencv()  # fail here, naming the extra, rather than at the first reset
            ok, why = gl_available()
            if not ok:
                raise RuntimeError(f"perception='tags' renders the wrist camera and needs an OpenGL backend for MuJoCo, none works: {why}")
        h, w = (int(v) for v in camera_size)
        if h < 8 or w < 8:
            raise ValueError(f"camera_size must be (height, width) of at least 8 pixels, got {camera_size}")
        # set before ShelfEnv.__init__, which builds the specs (camera entry) and validates the rest
        self.camera = CameraConfig(height=h, width=w)
        if perception == "tags" and abs(self.camera.fovy_degrees - self.wrist_camera.fovy_degrees) > 1e-9:
            raise ValueError(
                f"the wrist camera ({self.wrist_camera.width} x {self.wrist_camera.height}, {math.degrees(self.wrist_camera.fov):g} degrees across) "
                f"and camera_size {camera_size} must share one vertical field of view: give them one aspect ratio and field of view"
            )
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
        for o in self._observers:
            if o is not None:
                o.close()
        for w in self.worlds:
            if w is not None:
                w.close()
        super().close(raise_if_closed=raise_if_closed)

    # ------------------------------------------------------------------ ShelfEnv's world hooks
    def _new_world(self, i: int) -> MujocoWorld:
        tags = self.tag_layout if self.perception == "tags" else False
        world = MujocoWorld(
            self._next_scene(i),
            camera=self.camera,
            visibility=self.visibility,
            record_camera=self.record_camera,
            noise=self.noise,
            rng=self._rngs[i],
            object_height=self.object_height,
            tags=tags,
            shelf_height=self.shelf_height,
        )
        if tags is not False:
            from occrl.envs.detection_slots import DetectionSlots
            from occrl.envs.mujoco3d.tag_perception import TagObserver

            if not self._observers:
                self._observers, self._slots = [None] * self.num_worlds, [None] * self.num_worlds
            if self._observers[i] is not None:
                self._observers[i].close()
            # the images' lighting and noise: a stream spawned from the world's (which it leaves as it is)
            self._observers[i] = TagObserver(world, self.wrist_camera, self._rngs[i].spawn(1)[0])
            self._slots[i] = DetectionSlots()
        return world

    def _release_world(self, world: MujocoWorld) -> None:
        world.close()

    @property
    def tag_observers(self) -> list:
        """With ``perception="tags"``: each world's wrist camera and detector
        (:class:`~occrl.envs.mujoco3d.tag_perception.TagObserver`), built at its reset; else empty."""
        return list(self._observers)

    def _observe(self, success: np.ndarray, dropped: np.ndarray) -> TensorDictBase:
        out = super()._observe(success, dropped)
        if self.perception != "tags":
            return out
        # the objects the detector decodes replace the geometric detections, slot by slot
        objects = out.get("objects")
        for i, (world, observer, slots) in enumerate(zip(self.worlds, self._observers, self._slots)):
            t = world.target_index
            td = slots.observation(
                world.gripper_pose(),
                world.opening,
                observer.detections(),
                int(world.type_ids[t]),
                world.padded_vertices[t, : world.num_vertices[t]],
                bool(world.closed),
            )
            objects[i] = td.get("objects")[0]
        return out

    def _visible_fractions(self, world: MujocoWorld, poses: np.ndarray) -> np.ndarray:
        return world.visible_fractions()  # pixels or rays of the gripper camera

    def _extend_observation(self, out: TensorDictBase) -> TensorDictBase:
        if self.record_camera:
            out.set("camera_rgb", torch.from_numpy(np.stack([w.rgb().transpose(2, 0, 1) for w in self.worlds])))
        return out
