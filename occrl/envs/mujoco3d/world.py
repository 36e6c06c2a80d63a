"""One MuJoCo shelf world (DESIGN section 10): a scene built in 3D (:mod:`occrl.envs.mujoco3d.model`),
the planar actions executed quasi-statically, the contact grasp, and what the gripper camera sees
(:mod:`occrl.envs.mujoco3d.camera`).

An action: if the gripper command changed, the fingers close or open first (0.4 s, the hand held
in place); then the hand's servo targets move at constant velocity to the commanded pose
increment (0.5 s, workspace-limited as in the 2D world) and hold it while everything settles
(0.2 s). Time step 2 ms. An object counts as held when the gripper is closed and both fingers
touch it (and it is the only such object).
"""

from __future__ import annotations

import math

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.mujoco3d.camera import VISIBLE_GROUPS, CameraConfig, RendererOwner, new_renderer, prism_pixel_counts, require_mujoco
from occrl.envs.mujoco3d.tags import DEFAULT_TAG_LAYOUT, TagLayout, TagPlacement, add_tags, as_tag_layout, tag_placements
from occrl.envs.mujoco3d.model import FINGER_CLOSED_TARGET, OBJECT_HEIGHT_RANGE, SHELF_HEIGHT, TIMESTEP, build_mjcf, type_height
from occrl.envs.pymunk2d.physics_settings import INVALID_PENETRATION
from occrl.envs.scene import Scene
from occrl.envs.shelf_geometry import beyond_walls
from occrl.envs.task import StepOutcome, task_outcome

__all__ = ["MujocoWorld", "FINGER_TIME", "SETTLE_TIME"]

FINGER_TIME = 0.4  # s to open or close (the 2F-85 closes its 85 mm in ~0.6 s at full speed)
SETTLE_TIME = 0.2  # s of holding still after a motion (quasi-static execution)


class MujocoWorld(RendererOwner):
    """A scene executed in MuJoCo: planar actions in, poses, grasp state and visibility out.

    Args:
        scene: objects and the gripper's start pose.
        camera: camera image size and field of view.
        visibility: ``"render"`` (segmentation render, needs OpenGL) or ``"rays"``.
        record_camera: also keep a renderer for RGB frames (needs OpenGL).
        noise: execution noise on density and friction, drawn before each action from ``rng``.
        object_height: a height in m, or a (low, high) range sampled per type id.
        tags: put fiducial tags on the side faces (:mod:`~occrl.envs.mujoco3d.tags`; needs
            OpenCV): ``True`` for the :data:`~occrl.envs.mujoco3d.tags.DEFAULT_TAG_LAYOUT`, or a
            :class:`~occrl.envs.mujoco3d.tags.TagLayout` or a name in
            :data:`~occrl.envs.mujoco3d.tags.TAG_LAYOUTS`; the cards are visual only, so physics
            and visibility are unchanged.
        shelf_height: the shelf's inside height in m (0.30 by default; the papers' real shelf: 0.40).

    Examples:
        >>> from occrl.envs import Scene
        >>> from occrl.envs.mujoco3d.world import MujocoWorld
        >>> world = MujocoWorld(Scene.sample(stage=1, seed=0))  # visibility by ray casting: no OpenGL
        >>> (world.visible_fractions() > 0.5).tolist()  # object 2 is mostly hidden
        [True, True, False, True]
        >>> out = world.step([1.0, 0.0, 0.0, -1.0])  # a full step forward, gripper open
        >>> out.terminal, world.gripper_pose().round(3).tolist()
        (False, [0.034, -0.05, 0.0])
    """

    def __init__(
        self,
        scene: Scene,
        camera: CameraConfig = CameraConfig(),
        visibility: str = "rays",
        record_camera: bool = False,
        noise: float = 0.0,
        rng: np.random.Generator | None = None,
        object_height=OBJECT_HEIGHT_RANGE,
        tags: bool | TagLayout = False,
        shelf_height: float = SHELF_HEIGHT,
    ) -> None:
        mujoco, mjcf = require_mujoco()
        if visibility not in ("render", "rays"):
            raise ValueError(f"visibility must be 'render' or 'rays', got {visibility!r}")
        self._mj = mujoco
        self.scene = scene
        self.camera = camera
        self.visibility = visibility
        self.noise = float(noise)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.num_objects = len(scene.objects)
        self.target_index = scene.target_index
        self.type_ids = np.array([o.type_id for o in scene.objects], dtype=np.int64)
        self.num_vertices = np.array([len(o.vertices) for o in scene.objects], dtype=np.int64)
        self.padded_vertices = np.zeros((self.num_objects, C.MAX_VERTICES, 2))
        for i, o in enumerate(scene.objects):
            self.padded_vertices[i, : len(o.vertices)] = o.vertices
            self.padded_vertices[i, len(o.vertices) :] = o.vertices[0]
        self.heights = np.array([type_height(int(t), object_height) for t in self.type_ids])

        self.mjcf_model = build_mjcf(scene, camera, object_height, shelf_height)
        self.tags: list[TagPlacement] = []
        if tags:
            self.tags = tag_placements(scene, self.heights, as_tag_layout(DEFAULT_TAG_LAYOUT if tags is True else tags))
            add_tags(self.mjcf_model, self.tags)
        self.physics = mjcf.Physics.from_mjcf_model(self.mjcf_model)
        m = self.model = self.physics.model.ptr
        d = self.data = self.physics.data.ptr
        name = lambda kind, n: mujoco.mj_name2id(m, kind, n)  # noqa: E731
        OBJ = mujoco.mjtObj
        self._obj_body = np.array([name(OBJ.mjOBJ_BODY, f"obj{i}") for i in range(self.num_objects)], dtype=np.int64)
        self._obj_geom = np.array([name(OBJ.mjOBJ_GEOM, f"obj{i}") for i in range(self.num_objects)], dtype=np.int64)
        self._hand_q = m.jnt_qposadr[[name(OBJ.mjOBJ_JOINT, j) for j in ("hand_x", "hand_y", "hand_th")]]
        self._finger_q = m.jnt_qposadr[[name(OBJ.mjOBJ_JOINT, f"finger_{s}") for s in ("left", "right")]]
        self._finger_geoms = {name(OBJ.mjOBJ_GEOM, f"finger_{s}") for s in ("left", "right")}
        # contacts with these carry the objects' weight: their depth is MuJoCo's soft support, not
        # an overlap of two solids in the plane
        self._support_geoms = np.array([name(OBJ.mjOBJ_GEOM, g) for g in ("ground", "floor")], dtype=np.int64)
        self._cam = name(OBJ.mjOBJ_CAMERA, "wrist")
        self._hand = name(OBJ.mjOBJ_BODY, "hand")
        self.camera_id = self._cam
        self.geom_slot = np.full(m.ngeom + 1, -1, dtype=np.int64)  # last entry: "no hit" (-1 ids)
        self.geom_slot[self._obj_geom] = np.arange(self.num_objects)
        self._nominal_mass = m.body_mass[self._obj_body].copy()
        self._nominal_inertia = m.body_inertia[self._obj_body].copy()
        self._prism_local = [
            np.concatenate([np.c_[o.vertices, np.full(len(o.vertices), -hz / 2)], np.c_[o.vertices, np.full(len(o.vertices), hz / 2)]])
            for o, hz in zip(scene.objects, self.heights)
        ]
        self._ray_dirs_cam = camera.ray_directions()
        self._ray_geom = np.empty(camera.height * camera.width, dtype=np.int32)
        self._ray_dist = np.empty(camera.height * camera.width, dtype=np.float64)

        self.closed = False
        self.penetration = 0.0
        self.crossed_wall = False
        gx, gy, gth = scene.gripper_pose
        d.qpos[self._hand_q] = (gx, gy, gth)
        d.qpos[self._finger_q] = C.GRIPPER_STROKE / 2
        d.ctrl[:] = (gx, gy, gth, C.GRIPPER_STROKE / 2, C.GRIPPER_STROKE / 2)
        mujoco.mj_forward(m, d)

        self.renderer = None
        if visibility == "render" or record_camera:
            self.renderer = new_renderer(m, camera.height, camera.width)
            self._seg_option = mujoco.MjvOption()
            self._seg_option.geomgroup[:] = VISIBLE_GROUPS

    # ------------------------------------------------------------------ state
    def gripper_pose(self) -> np.ndarray:
        return self.data.qpos[self._hand_q].copy()

    @property
    def held(self) -> int | None:
        """The held object (a contact grasp), as ``ShelfWorld.held``."""
        return self.held_object()

    @property
    def opening(self) -> float:
        return float(np.clip(self.data.qpos[self._finger_q].sum(), 0.0, C.GRIPPER_STROKE))

    def object_poses(self) -> np.ndarray:
        """(n, 3) planar poses: centroid x, y and the heading of the body's x axis."""
        d = self.data
        pos = d.xpos[self._obj_body]
        mat = d.xmat[self._obj_body].reshape(-1, 3, 3)
        return np.c_[pos[:, :2], np.arctan2(mat[:, 1, 0], mat[:, 0, 0])].reshape(-1, 3)

    def object_heights_z(self) -> np.ndarray:
        return self.data.xpos[self._obj_body, 2].copy()

    def held_object(self) -> int | None:
        """The object both closed fingers touch (a contact grasp), else None."""
        if not self.closed:
            return None
        touching: dict[int, set] = {}
        d = self.data
        for k in range(d.ncon):
            g1, g2 = int(d.contact.geom1[k]), int(d.contact.geom2[k])
            for f, o in ((g1, g2), (g2, g1)):
                if f in self._finger_geoms and self.geom_slot[o] >= 0:
                    touching.setdefault(int(self.geom_slot[o]), set()).add(f)
        both = [i for i, fs in touching.items() if len(fs) == 2]
        return both[0] if len(both) == 1 else None

    def state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """Everything an action changes (for tests): qpos, qvel, ctrl, gripper command."""
        return self.data.qpos.copy(), self.data.qvel.copy(), self.data.ctrl.copy(), self.closed

    # ------------------------------------------------------------------ dynamics
    def step(self, action) -> StepOutcome:
        """Execute one clipped action (the same interface as :meth:`ShelfWorld.step`)."""
        mj, m, d = self._mj, self.model, self.data
        a = np.clip(np.asarray(action, dtype=float).reshape(-1), -1.0, 1.0)
        if self.noise > 0.0:
            self._perturb()
        close = bool(a[3] > 0.0)
        x, y, th = self.gripper_pose()
        d.ctrl[:3] = (x, y, th)
        if close != self.closed:
            self.closed = close
            start = float(d.ctrl[3])
            goal = FINGER_CLOSED_TARGET if close else C.GRIPPER_STROKE / 2
            n = int(round(FINGER_TIME / TIMESTEP))
            for k in range(1, n + 1):
                d.ctrl[3:5] = start + (goal - start) * min(1.0, 2.0 * k / n)  # ramp in the first half, then hold
                mj.mj_step(m, d)
            x, y, th = self.gripper_pose()
        fwd, lat, rot = a[0] * C.MAX_FORWARD, a[1] * C.MAX_LATERAL, a[2] * C.MAX_ROTATION
        c, s = math.cos(th), math.sin(th)
        goal = np.array(
            [
                min(max(x + c * lat - s * fwd, C.GRIPPER_X_LIMITS[0]), C.GRIPPER_X_LIMITS[1]),
                min(max(y + s * lat + c * fwd, C.GRIPPER_Y_LIMITS[0]), C.GRIPPER_Y_LIMITS[1]),
                min(max(th + rot, C.GRIPPER_THETA_LIMITS[0]), C.GRIPPER_THETA_LIMITS[1]),
            ]
        )
        start = np.array([x, y, th])
        n = int(round(C.ACTION_DURATION / TIMESTEP))
        for k in range(1, n + 1):
            d.ctrl[:3] = start + (goal - start) * (k / n)  # constant velocity, as in the 2D world
            mj.mj_step(m, d)
        mj.mj_step(m, d, int(round(SETTLE_TIME / TIMESTEP)))
        mj.mj_forward(m, d)  # positions, contacts and camera of the final state
        self.penetration, self.crossed_wall = self._measure_validity()
        return self._outcome()

    def physically_valid(self, max_penetration: float = INVALID_PENETRATION) -> bool:
        """As :meth:`ShelfWorld.physically_valid`: no overlap deeper than ``max_penetration`` (m)
        between two solids (objects, gripper, walls) and no object centroid beyond a wall."""
        return self.penetration <= max_penetration and not self.crossed_wall

    def _measure_validity(self) -> tuple[float, bool]:
        d = self.data
        n = d.ncon
        deepest = 0.0
        if n:
            geom1, geom2, dist = d.contact.geom1[:n], d.contact.geom2[:n], d.contact.dist[:n]
            solid = ~np.isin(geom1, self._support_geoms) & ~np.isin(geom2, self._support_geoms)
            if solid.any():
                deepest = max(0.0, float(-dist[solid].min()))
        return deepest, beyond_walls(self.object_poses())

    def _outcome(self) -> StepOutcome:
        # an object that fell off the shelf (below the board) counts as dropped wherever it lies
        return task_outcome(self.object_poses(), self.held_object(), self.target_index, fallen=self.object_heights_z() < -0.05)

    def _perturb(self) -> None:
        """Density and friction ~ N(nominal, level * nominal), floored at 5 % and 0 (as in 2D)."""
        m, lvl, rng = self.model, self.noise, self.rng
        for i in range(self.num_objects):
            f = max(rng.normal(1.0, lvl), 0.05)
            mu = max(rng.normal(C.NOMINAL_FRICTION, lvl * C.NOMINAL_FRICTION), 0.0)
            b = self._obj_body[i]
            m.body_mass[b] = self._nominal_mass[i] * f
            m.body_inertia[b] = self._nominal_inertia[i] * f
            m.geom_friction[self._obj_geom[i], 0] = mu

    # ------------------------------------------------------------------ camera
    def camera_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """Camera position and rotation (columns: right, up, backwards) in the shelf frame."""
        return self.data.cam_xpos[self._cam].copy(), self.data.cam_xmat[self._cam].reshape(3, 3).copy()

    def gripper_transform(self) -> np.ndarray:
        """4 x 4 pose of the gripper frame in the shelf frame (origin at the palm's front centre,
        at the finger pads' height; x to the right, y along the approach, z up)."""
        pose = np.eye(4)
        pose[:3, :3] = self.data.xmat[self._hand].reshape(3, 3)
        pose[:3, 3] = self.data.xpos[self._hand]
        return pose

    def visible_pixels(self, method: str | None = None) -> np.ndarray:
        """Per object, the camera pixels whose first hit it is (gripper excluded)."""
        method = method or self.visibility
        if method == "render":
            if self.renderer is None:
                raise RuntimeError("this world has no renderer (built with visibility='rays' and record_camera=False)")
            r = self.renderer
            r.enable_segmentation_rendering()
            r.update_scene(self.data, camera=self._cam, scene_option=self._seg_option)
            seg = r.render()
            r.disable_segmentation_rendering()
            ids = np.where(seg[..., 1] == int(self._mj.mjtObj.mjOBJ_GEOM), seg[..., 0], -1).ravel()
        elif method == "rays":
            pos, rot = self.camera_frame()
            vec = self._ray_dirs_cam @ rot.T
            n = len(vec)
            self._mj.mj_multiRay(
                self.model, self.data, pos, vec.ravel(), VISIBLE_GROUPS, 1, -1, self._ray_geom, self._ray_dist, None, n, 100.0
            )
            ids = self._ray_geom
        else:
            raise ValueError(f"method must be 'render' or 'rays', got {method!r}")
        slots = self.geom_slot[ids]
        return np.bincount(slots[slots >= 0], minlength=self.num_objects)[: self.num_objects]

    def alone_pixels(self) -> tuple[np.ndarray, np.ndarray]:
        """Per object, the pixels it would cover with nothing else in the world: on the camera's
        rows extended without bound sideways (the visibility denominator), and within the image."""
        pos, rot = self.camera_frame()
        counts = np.zeros((2, self.num_objects))
        for i, local in enumerate(self._prism_local):
            b = self._obj_body[i]
            world = self.data.xpos[b] + local @ self.data.xmat[b].reshape(3, 3).T
            counts[:, i] = prism_pixel_counts((world - pos) @ rot, self.camera)
        return counts[0], counts[1]

    def visible_fractions(self, method: str | None = None) -> np.ndarray:
        """Visible pixels over the pixels the object covers alone (0 to 1)."""
        vis = self.visible_pixels(method)
        total, _ = self.alone_pixels()
        return np.clip(np.where(total > 0, vis / np.maximum(total, 1.0), 0.0), 0.0, 1.0)

    def rgb(self) -> np.ndarray:
        """(H, W, 3) uint8 image of the gripper camera (everything drawn, fingers included)."""
        if self.renderer is None:
            raise RuntimeError("this world has no renderer (record_camera=False and visibility='rays')")
        self.renderer.disable_segmentation_rendering()
        self.renderer.update_scene(self.data, camera=self._cam)
        return self.renderer.render().copy()
