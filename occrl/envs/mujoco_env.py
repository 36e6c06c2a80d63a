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
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded
from torchrl.envs import EnvBase

from occrl.envs import world_constants as C
from occrl.envs.mujoco_camera import CameraConfig, gl_available, require_mujoco
from occrl.envs.mujoco_model import OBJECT_HEIGHT_RANGE
from occrl.envs.mujoco_world import MujocoWorld
from occrl.envs.scene import STAGES, Scene
from occrl.envs.shelf_env import MAX_POLY_VERTICES, MAX_SLOTS, ShelfEnv
from occrl.envs.visibility import detect

__all__ = ["MujocoShelfEnv", "VISIBILITY_BACKENDS"]

logger = logging.getLogger(__name__)

VISIBILITY_BACKENDS = ("auto", "render", "rays")


class MujocoShelfEnv(EnvBase):
    """Retrieve a target object from a cluttered 3D shelf simulated in MuJoCo; a batch of worlds.

    The same task, actions, observation keys, specs, rewards and episode ends as
    :class:`~occrl.envs.ShelfEnv`, executed in a 3D model built with dm_control ``mjcf``: a
    W 0.50 x D 0.35 x H 0.30 m shelf, the scene's polygons extruded to 10-18 cm tall prisms with
    mass and friction, and a planar Robotiq 2F-85 (position-servoed hand on slide x, slide y and
    hinge z joints, two coupled force-limited fingers with an 85 mm stroke) that grasps by contact
    and friction alone. See :mod:`occrl.envs.mujoco_world` for the model.

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
        if isinstance(batch_size, int):
            batch_size = (batch_size,)
        batch_size = torch.Size(batch_size)
        if len(batch_size) != 1 or batch_size[0] < 1:
            raise ValueError(f"batch_size must be a positive int or a 1-element shape, got {tuple(batch_size)}")
        if stage not in STAGES:
            raise ValueError(f"stage must be one of {sorted(STAGES)}, got {stage!r}")
        if not 0.0 <= noise <= 1.0:
            raise ValueError(f"noise must be in [0, 1] (the paper uses 0 to 0.25), got {noise}")
        if visibility not in VISIBILITY_BACKENDS:
            raise ValueError(f"visibility must be one of {VISIBILITY_BACKENDS}, got {visibility!r}")
        if scenes is not None:
            scenes = list(scenes)
            if not scenes or not all(isinstance(s, Scene) for s in scenes):
                raise ValueError("scenes must be a non-empty sequence of occrl.envs.Scene")
        h, w = (int(v) for v in camera_size)
        if h < 8 or w < 8:
            raise ValueError(f"camera_size must be (height, width) of at least 8 pixels, got {camera_size}")
        super().__init__(device=device, batch_size=batch_size)
        self.num_worlds = int(batch_size[0])
        self.stage = stage
        self.noise = float(noise)
        self.scenes = scenes
        self.num_objects = num_objects
        self.max_steps = int(max_steps)
        self.camera = CameraConfig(height=h, width=w)
        self.object_height = object_height
        self.record_camera = bool(record_camera)
        self.visibility = self._pick_visibility(visibility)
        self._scene_cursor = 0
        self.worlds: list[MujocoWorld | None] = [None] * self.num_worlds
        self._steps = np.zeros(self.num_worlds, dtype=np.int64)
        self._make_specs()
        if isinstance(seed, (list, tuple)):
            if len(seed) != self.num_worlds:
                raise ValueError(f"a list of seeds needs one per world ({self.num_worlds}), got {len(seed)}")
            self._rngs = [np.random.default_rng(int(s)) for s in seed]
            self._seed = list(seed)
        else:
            self._set_seed(seed)

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
        ShelfEnv._make_specs(self)  # the same specs as the 2D env, so everything downstream runs unchanged
        if self.record_camera:
            h, w = self.camera.height, self.camera.width
            self.observation_spec["camera_rgb"] = Bounded(0, 255, shape=(*self.batch_size, 3, h, w), dtype=torch.uint8)

    # ------------------------------------------------------------------ seeding
    _set_seed = ShelfEnv._set_seed
    _next_scene = ShelfEnv._next_scene

    # ------------------------------------------------------------------ lifecycle
    def close(self, *, raise_if_closed: bool = True) -> None:
        """Free the worlds' OpenGL contexts."""
        for w in self.worlds:
            if w is not None:
                w.close()
        super().close(raise_if_closed=raise_if_closed)

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

    # ------------------------------------------------------------------ reset / step
    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        if tensordict is not None and "_reset" in tensordict.keys():
            mask = tensordict.get("_reset").reshape(self.num_worlds).cpu().numpy()
        else:
            mask = np.ones(self.num_worlds, dtype=bool)
        for i in np.flatnonzero(mask):
            if self.worlds[i] is not None:
                self.worlds[i].close()
            self.worlds[i] = self._new_world(i)
            self._steps[i] = 0
        zeros = np.zeros(self.num_worlds, dtype=bool)
        out = self._observe(success=zeros, dropped=zeros)
        flags = torch.zeros((self.num_worlds, 1), dtype=torch.bool)
        out.update({"done": flags, "terminated": flags.clone(), "truncated": flags.clone()})
        return out

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        actions = tensordict.get("action").detach().cpu().numpy().astype(np.float64).reshape(self.num_worlds, -1)
        if actions.shape[1] != C.ACTION_DIM:
            raise ValueError(f"actions must have {C.ACTION_DIM} entries, got shape {tuple(actions.shape)}")
        bad = ~np.isfinite(actions).all(axis=1)
        if bad.any():
            raise ValueError(
                f"action of world(s) {np.flatnonzero(bad).tolist()} contains NaN or inf: "
                f"{actions[bad].tolist()}; allowed: finite numbers, clipped to [-1, 1]. No world was stepped."
            )
        B = self.num_worlds
        reward = np.empty(B, dtype=np.float32)
        success = np.zeros(B, dtype=bool)
        dropped = np.zeros(B, dtype=bool)
        for i, world in enumerate(self.worlds):
            reward[i], success[i], drops = world.step(actions[i])
            dropped[i] = bool(drops)
        self._steps += 1
        terminated = success | dropped
        truncated = (self._steps >= self.max_steps) & ~terminated
        out = self._observe(success=success, dropped=dropped)
        out.update(
            {
                "reward": torch.from_numpy(reward).unsqueeze(-1),
                "terminated": torch.from_numpy(terminated).unsqueeze(-1),
                "truncated": torch.from_numpy(truncated).unsqueeze(-1),
                "done": torch.from_numpy(terminated | truncated).unsqueeze(-1),
            }
        )
        return out

    # ------------------------------------------------------------------ perception
    def _observe(self, success: np.ndarray, dropped: np.ndarray) -> TensorDictBase:
        B, N, V = self.num_worlds, MAX_SLOTS, MAX_POLY_VERTICES
        gripper_pose = np.zeros((B, 3), np.float32)
        opening = np.zeros((B, 1), np.float32)
        closed = np.zeros((B, 1), bool)
        target_type = np.zeros((B, 1), np.int64)
        target_vertices = np.zeros((B, V, 2), np.float32)
        target_nv = np.zeros((B, 1), np.int64)
        det = np.zeros((B, N), bool)
        type_id = np.zeros((B, N), np.int64)
        pose = np.zeros((B, N, 3), np.float32)
        verts = np.zeros((B, N, V, 2), np.float32)
        nverts = np.zeros((B, N), np.int64)
        present = np.zeros((B, N), bool)
        true_pose = np.zeros((B, N, 3), np.float32)
        true_verts = np.zeros((B, N, V, 2), np.float32)
        true_nv = np.zeros((B, N), np.int64)
        frac = np.zeros((B, N), np.float32)
        target_slot = np.zeros((B, 1), np.int64)
        target_pose = np.zeros((B, 3), np.float32)
        target_held = np.zeros((B, 1), bool)
        rgb = np.zeros((B, 3, self.camera.height, self.camera.width), np.uint8) if self.record_camera else None
        for i, w in enumerate(self.worlds):
            n = w.num_objects
            poses = w.object_poses()
            f = w.visible_fractions()
            d = detect(f)
            gripper_pose[i] = w.gripper_pose()
            opening[i, 0] = w.opening
            closed[i, 0] = w.closed
            t = w.target_index
            target_type[i, 0] = w.type_ids[t]
            target_vertices[i] = w.padded_vertices[t]
            target_nv[i, 0] = w.num_vertices[t]
            present[i, :n] = True
            true_pose[i, :n] = poses
            true_verts[i, :n] = w.padded_vertices
            true_nv[i, :n] = w.num_vertices
            frac[i, :n] = f
            det[i, :n] = d
            verts[i, :n] = np.where(d[:, None, None], w.padded_vertices, 0.0)
            nverts[i, :n] = np.where(d, w.num_vertices, 0)
            type_id[i, :n] = np.where(d, w.type_ids, 0)
            pose[i, :n] = np.where(d[:, None], poses, 0.0)
            target_slot[i, 0] = t
            target_pose[i] = poses[t]
            target_held[i, 0] = w.held_object() == t
            if rgb is not None:
                rgb[i] = w.rgb().transpose(2, 0, 1)
        t = torch.from_numpy
        batch = self.batch_size
        out = TensorDict(
            {
                "gripper_pose": t(gripper_pose),
                "gripper_opening": t(opening),
                "gripper_closed": t(closed),
                "target_type": t(target_type),
                "target_vertices": t(target_vertices),
                "target_num_vertices": t(target_nv),
                "objects": TensorDict(
                    {"detected": t(det), "type_id": t(type_id), "pose": t(pose), "vertices": t(verts), "num_vertices": t(nverts)},
                    batch_size=(*batch, N),
                ),
                "success": t(success.copy()).unsqueeze(-1),
                "dropped": t(dropped.copy()).unsqueeze(-1),
                "privileged": TensorDict(
                    {
                        "object_present": t(present),
                        "object_pose": t(true_pose),
                        "object_vertices": t(true_verts),
                        "object_num_vertices": t(true_nv),
                        "visible_fraction": t(frac),
                        "target_slot": t(target_slot),
                        "target_pose": t(target_pose),
                        "target_held": t(target_held),
                    },
                    batch_size=batch,
                ),
            },
            batch_size=batch,
        )
        if rgb is not None:
            out["camera_rgb"] = t(rgb)
        return out
