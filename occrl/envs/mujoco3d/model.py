"""The 3D shelf model of :class:`~occrl.envs.MujocoShelfEnv`, built with dm_control ``mjcf``
(DESIGN section 10). Shelf frame with z up; the shelf floor's top is z = 0.

* Shelf W 0.50 x D 0.35 x H 0.30 m (``shelf_height``; the papers' real shelf is 0.40 m high,
  :data:`PAPERS_SHELF_HEIGHT`): floor, side walls, back wall and top board (2 cm boards); the
  front y = 0 is open. A ground plane 0.75 m below catches what falls off.
* Objects: each scene polygon extruded to a prism (a mesh geom; MuJoCo collides with its convex
  hull, which is the prism itself) on a free joint, of height ``object_height`` (by default a
  fixed height per type id in 10-18 cm), density 400 kg/m^3 (a light solid) and friction 0.3.
  Object geoms have contact priority over the shelf, so their (noisy) friction is the one used.
* Gripper: a planar Robotiq 2F-85. The hand body (palm 9 x 5 cm, forearm 7 x 25 cm behind it,
  both 6 cm tall, 1.5 cm above the floor) moves on slide x, slide y and hinge z joints driven by
  force-limited position servos (20 N, 2 N m, as in the 2D world). Two fingers (1.2 x 4.5 x 2.2 cm
  pads, friction 1, stiff contacts) slide along the hand's x axis over the 85 mm stroke, each
  driven by a 40 N force-limited servo from the same command, so they close in step and centre
  what they grasp. Grasping is contact and friction only: there is no weld.
* Camera ``"wrist"``: at the palm's front centre (the gripper frame origin), 7 cm above the floor
  (below every object's top, as the 2D model assumes), looking along the approach axis, 70 degree
  horizontal field of view. No multisampling, so segmentation renders are exact.
"""

from __future__ import annotations

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.mujoco3d.camera import NEAR, CameraConfig, require_mujoco
from occrl.envs.scene import Scene

__all__ = [
    "build_mjcf",
    "check_shelf_height",
    "type_height",
    "OBJECT_HEIGHT_RANGE",
    "OBJECT_DENSITY",
    "TIMESTEP",
    "SHELF_HEIGHT",
    "PAPERS_SHELF_HEIGHT",
    "SHELF_HEIGHT_RANGE",
]

# --- 3D model (metres, kg, s) ------------------------------------------------------------------
SHELF_HEIGHT = 0.30  # m, inside: the floor's top to the top board's underside
PAPERS_SHELF_HEIGHT = 0.40  # m: the shelf of the papers' real-robot experiments (W 50 x D 35 x H 40 cm)
SHELF_HEIGHT_RANGE = (0.20, 1.0)  # m: above the tallest object (18 cm), within the scene's lighting
BOARD = C.WALL_THICKNESS
GROUND_Z = -0.75
OBJECT_HEIGHT_RANGE = (0.10, 0.18)
OBJECT_DENSITY = 400.0  # kg/m^3: a light solid (soft wood, packed cardboard)
FINGER_FRICTION = 1.0  # rubber pads
HAND_Z = 0.045  # height of the gripper frame (finger pad centre) above the floor
HAND_HALF_HEIGHT = 0.03  # palm and forearm are 6 cm tall: z in [0.015, 0.075]
FINGER_HALF_HEIGHT = 0.011
CAMERA_Z = 0.07
HAND_MASS = 1.0
FINGER_MASS = 0.05
FINGER_FORCE = 40.0  # N (the 2F-85 grips with 20-235 N)
HAND_KP, HAND_KV = 2000.0, 90.0  # N/m, N s/m: critically damped for the 1 kg hand
TURN_KP, TURN_KV = 60.0, 2.0
FINGER_KP, FINGER_KV = 2000.0, 20.0
FINGER_SOLREF = (0.004, 1.0)  # stiff pads: the measured opening is the object's width within 1 mm
FINGER_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
FINGER_CLOSED_TARGET = -0.02  # servo target beyond full closure: the fingers squeeze at FINGER_FORCE
TIMESTEP = 0.002


def type_height(type_id: int, height_range=OBJECT_HEIGHT_RANGE) -> float:
    """A deterministic height per type id in ``height_range`` (a float means a fixed height).

    Examples:
        >>> from occrl.envs.mujoco3d.model import type_height
        >>> [round(type_height(t), 3) for t in (1, 2, 3)]  # in the default 10-18 cm range
        [0.149, 0.119, 0.168]
        >>> type_height(5, 0.12)
        0.12
    """
    if isinstance(height_range, (int, float)):
        return float(height_range)
    lo, hi = height_range
    return float(lo + (hi - lo) * ((type_id * 0.6180339887498949) % 1.0))


def _box(body, name, lo, hi, **kw):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return body.add("geom", name=name, type="box", pos=(lo + hi) / 2, size=(hi - lo) / 2, **kw)


def check_shelf_height(shelf_height: float) -> float:
    """``shelf_height`` as a float, or ``ValueError`` unless it is a number of metres in
    :data:`SHELF_HEIGHT_RANGE`.

    Examples:
        >>> from occrl.envs.mujoco3d.model import check_shelf_height
        >>> check_shelf_height(0.4)
        0.4
        >>> check_shelf_height(0.1)
        Traceback (most recent call last):
        ...
        ValueError: shelf_height must be a number of metres in [0.2, 1.0] (above the tallest object, 0.18 m), got 0.1
    """
    lo, hi = SHELF_HEIGHT_RANGE
    if isinstance(shelf_height, bool) or not isinstance(shelf_height, (int, float)) or not lo <= shelf_height <= hi:
        raise ValueError(
            f"shelf_height must be a number of metres in [{lo}, {hi}] (above the tallest object, {OBJECT_HEIGHT_RANGE[1]} m), got {shelf_height!r}"
        )
    return float(shelf_height)


def build_mjcf(scene: Scene, camera: CameraConfig, object_height=OBJECT_HEIGHT_RANGE, shelf_height: float = SHELF_HEIGHT):
    """The dm_control ``mjcf`` model of a scene (shelf, objects, gripper with camera);
    ``shelf_height``: the shelf's inside height in m (:func:`check_shelf_height`).

    Examples:
        >>> from occrl.envs import Scene
        >>> from occrl.envs.mujoco3d.camera import CameraConfig
        >>> from occrl.envs.mujoco3d.model import build_mjcf
        >>> scene = Scene.sample(stage=1, seed=0)
        >>> model = build_mjcf(scene, CameraConfig())
        >>> len(scene), len(model.find_all("body")), model.find("camera", "wrist") is not None  # objects, hand, fingers
        (4, 7, True)
    """
    _, mjcf = require_mujoco()
    shelf_height = check_shelf_height(shelf_height)
    root = mjcf.RootElement(model="shelf")
    root.compiler.angle = "radian"
    root.option.timestep = TIMESTEP
    root.option.integrator = "implicitfast"
    root.option.cone = "elliptic"
    root.option.impratio = 10
    root.statistic.extent = 1.0
    root.statistic.center = (0.0, 0.1, 0.1)
    root.visual.map.znear = NEAR  # times extent (1 m)
    root.visual.map.zfar = 10.0
    getattr(root.visual, "global").offwidth = max(640, camera.width)
    getattr(root.visual, "global").offheight = max(480, camera.height)
    root.visual.quality.offsamples = 0  # no multisampling: blended edge colours would corrupt segment ids
    root.visual.headlight.ambient = (0.4, 0.4, 0.4)
    root.visual.headlight.diffuse = (0.6, 0.6, 0.6)
    root.default.geom.friction = (C.NOMINAL_FRICTION, 0.005, 0.0001)

    wb = root.worldbody
    wb.add("light", pos=(0.0, 0.1, 1.0), dir=(0, 0, -1), diffuse=(0.5, 0.5, 0.5))
    wb.add("geom", name="ground", type="plane", size=(2, 2, 0.1), pos=(0, 0, GROUND_Z), rgba=(0.3, 0.3, 0.3, 1))
    w, d, t, h = C.SHELF_HALF_WIDTH, C.SHELF_DEPTH, BOARD, shelf_height
    wood = dict(rgba=(0.55, 0.35, 0.2, 1.0), group=0)
    _box(wb, "floor", (-w - t, 0.0, -t), (w + t, d + t, 0.0), rgba=(0.75, 0.75, 0.75, 1.0), group=0)
    _box(wb, "wall_left", (-w - t, 0.0, 0.0), (-w, d + t, h), **wood)
    _box(wb, "wall_right", (w, 0.0, 0.0), (w + t, d + t, h), **wood)
    _box(wb, "wall_back", (-w, d, 0.0), (w, d + t, h), **wood)
    _box(wb, "top", (-w - t, 0.0, h), (w + t, d + t, h + t), **wood)

    for i, o in enumerate(scene.objects):
        hz = type_height(o.type_id, object_height) / 2
        v = np.asarray(o.vertices, float)
        prism = np.concatenate([np.c_[v, np.full(len(v), -hz)], np.c_[v, np.full(len(v), hz)]])
        root.asset.add("mesh", name=f"obj{i}", vertex=prism.ravel())
        x, y, th = o.pose
        body = wb.add("body", name=f"obj{i}", pos=(x, y, hz + 1e-4), euler=(0, 0, th))
        body.add("freejoint", name=f"obj{i}")
        rgba = (0.1, 0.75, 0.2, 1.0) if o.is_target else (0.8, 0.15, 0.1, 1.0)
        body.add("geom", name=f"obj{i}", type="mesh", mesh=f"obj{i}", density=OBJECT_DENSITY, rgba=rgba, group=1, priority=1)

    hand = wb.add("body", name="hand", pos=(0, 0, HAND_Z))
    hand.add("joint", name="hand_x", type="slide", axis=(1, 0, 0), armature=0.01)
    hand.add("joint", name="hand_y", type="slide", axis=(0, 1, 0), armature=0.01)
    hand.add("joint", name="hand_th", type="hinge", axis=(0, 0, 1), armature=0.001)
    hand.add("inertial", pos=(0, -0.1, 0), mass=HAND_MASS, diaginertia=(0.01, 0.002, 0.01))
    grey = dict(rgba=(0.35, 0.35, 0.4, 1.0), group=2, contype=1, conaffinity=1)
    hh = HAND_HALF_HEIGHT
    _box(hand, "palm", (-C.PALM_WIDTH / 2, -C.PALM_DEPTH, -hh), (C.PALM_WIDTH / 2, 0.0, hh), **grey)
    fa = C.FOREARM_WIDTH / 2
    _box(hand, "forearm", (-fa, -C.PALM_DEPTH - C.FOREARM_LENGTH, -hh), (fa, -C.PALM_DEPTH, hh), **grey)
    hand.add("camera", name="wrist", pos=(0, 0, CAMERA_Z - HAND_Z), xyaxes=(1, 0, 0, 0, 0, 1), fovy=camera.fovy_degrees)
    half = C.GRIPPER_STROKE / 2
    fh = FINGER_HALF_HEIGHT
    pad = dict(
        rgba=(0.15, 0.15, 0.15, 1.0),
        group=2,
        friction=(FINGER_FRICTION, 0.01, 0.0005),
        condim=6,
        priority=2,
        solref=FINGER_SOLREF,
        solimp=FINGER_SOLIMP,
    )
    for side, sign in (("left", -1.0), ("right", 1.0)):
        f = hand.add("body", name=f"finger_{side}")
        f.add("joint", name=f"finger_{side}", type="slide", axis=(sign, 0, 0), range=(0.0, half), armature=0.001, damping=2.0)
        f.add("inertial", pos=(sign * C.FINGER_WIDTH / 2, C.FINGER_LENGTH / 2, 0), mass=FINGER_MASS, diaginertia=(1e-5, 1e-5, 1e-5))
        x0, x1 = sorted((0.0, sign * C.FINGER_WIDTH))
        _box(f, f"finger_{side}", (x0, 0.0, -fh), (x1, C.FINGER_LENGTH, fh), **pad)
    root.contact.add("exclude", body1="finger_left", body2="finger_right")

    xl, yl, tl = C.GRIPPER_X_LIMITS, C.GRIPPER_Y_LIMITS, C.GRIPPER_THETA_LIMITS
    f, tq = C.GRIPPER_MAX_FORCE, C.GRIPPER_MAX_TORQUE
    act = root.actuator
    act.add("position", name="hand_x", joint="hand_x", kp=HAND_KP, kv=HAND_KV, ctrlrange=xl, forcerange=(-f, f))
    act.add("position", name="hand_y", joint="hand_y", kp=HAND_KP, kv=HAND_KV, ctrlrange=yl, forcerange=(-f, f))
    act.add("position", name="hand_th", joint="hand_th", kp=TURN_KP, kv=TURN_KV, ctrlrange=tl, forcerange=(-tq, tq))
    for side in ("left", "right"):  # one command drives both: they close in step, centring the object
        act.add(
            "position",
            name=f"finger_{side}",
            joint=f"finger_{side}",
            kp=FINGER_KP,
            kv=FINGER_KV,
            ctrlrange=(FINGER_CLOSED_TARGET, half),
            forcerange=(-FINGER_FORCE, FINGER_FORCE),
        )
    return root
