"""A simulated camera calibration: MuJoCo renders the printed ChArUco board
(:mod:`occrl.perception.board`) seen by a camera fixed to a moving gripper, at a known mount on
the gripper and a known field of view, so that what ``occrl calibrate`` recovers can be compared
with the truth.

The board stands upright in the world, its printed face towards -y, its centre at
:data:`BOARD_CENTRE`. The gripper is a mocap body; its pose is the 4x4 transform from occrl's
gripper frame to the world (the arm's base frame). The camera is MuJoCo's pinhole: square pixels,
the principal point at the image centre, no distortion, its focal length ``height / 2 /
tan(fovy / 2)`` pixels. MuJoCo's camera frame (x right, y up, looking along -z) is OpenCV's
rotated half a turn about x.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from occrl.envs.mujoco3d.camera import close_renderer, new_renderer, require_mujoco
from occrl.perception.board import CalibrationBoard, board_image
from occrl.perception.camera import CameraModel, forward_looking_hand_camera
from occrl.perception.checks import rigid_transform
from occrl.perception.frames import invert_transform
from occrl.perception.opencv import require_opencv

__all__ = ["CalibrationScene", "default_hand_camera", "BOARD_CENTRE"]

BOARD_CENTRE = (0.0, 0.5, 0.3)
OPENCV_TO_MUJOCO = np.diag([1.0, -1.0, -1.0, 1.0])  # a camera frame's axes in the other convention
TEXTURE_PIXELS_PER_SQUARE = 80


def axis_rotation(axis: int, degrees: float) -> np.ndarray:
    """The 4x4 rotation by ``degrees`` about axis 0 (x), 1 (y) or 2 (z)."""
    cv2 = require_opencv()
    t = np.eye(4)
    t[:3, :3] = cv2.Rodrigues(math.radians(degrees) * np.eye(3)[axis])[0]
    return t


def default_hand_camera() -> np.ndarray:
    """The simulated camera's mount: 1.2 cm right of, 3.5 cm ahead of and 2.8 cm above the gripper
    frame's origin, looking along the approach direction tilted 8 degrees down and turned 3 degrees."""
    return forward_looking_hand_camera((0.012, 0.035, 0.028)) @ axis_rotation(0, -8.0) @ axis_rotation(1, 3.0)


@dataclass(frozen=True)
class CalibrationScene:
    """The board and a ``width`` x ``height`` camera of ``fovy_deg`` (vertical field of view) on
    the gripper at ``hand_camera`` (its pose in the gripper frame, OpenCV's camera axes).

    Examples:
        >>> from occrl.envs.mujoco3d.calibration_scene import CalibrationScene
        >>> scene = CalibrationScene()
        >>> camera = scene.true_camera()
        >>> round(camera.fx, 2), camera.cx, camera.cy
        (461.04, 319.5, 239.5)
        >>> len(scene.gripper_poses(12, seed=2))
        12
    """

    board: CalibrationBoard = field(default_factory=CalibrationBoard)
    width: int = 640
    height: int = 480
    fovy_deg: float = 55.0
    hand_camera: np.ndarray = field(default_factory=default_hand_camera)

    def __post_init__(self) -> None:
        object.__setattr__(self, "hand_camera", rigid_transform("hand_camera", self.hand_camera))
        if not 1.0 <= self.fovy_deg <= 150.0:
            raise ValueError(f"fovy_deg must be in [1, 150] degrees, got {self.fovy_deg}")

    def true_camera(self) -> CameraModel:
        """The camera as it is: MuJoCo's pinhole and the mount."""
        f = self.height / 2 / math.tan(math.radians(self.fovy_deg) / 2)
        return CameraModel(self.width, self.height, f, f, (self.width - 1) / 2, (self.height - 1) / 2, hand_camera=self.hand_camera)

    def world_board(self) -> np.ndarray:
        """The board frame (OpenCV's: top-left outer corner, x right, y down, z into the board) in the world."""
        t = np.eye(4)
        t[:3, :3] = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]
        width, height = self.board.size
        t[:3, 3] = np.array(BOARD_CENTRE) + [-width / 2, -0.001, height / 2]
        return t

    def model(self):
        """The MuJoCo model: the board as a textured card and the camera on a mocap gripper."""
        mujoco, _ = require_mujoco()
        cv2 = require_opencv()
        ok, png = cv2.imencode(".png", np.repeat(board_image(self.board, TEXTURE_PIXELS_PER_SQUARE)[..., None], 3, axis=-1))
        if not ok:  # pragma: no cover - OpenCV failing to encode a small image
            raise RuntimeError("OpenCV could not encode the board's texture")
        mount = self.hand_camera @ OPENCV_TO_MUJOCO
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, mount[:3, :3].ravel())
        width, height = self.board.size
        xml = f"""
        <mujoco>
          <visual><headlight ambient="0.5 0.5 0.5" diffuse="0.5 0.5 0.5" specular="0 0 0"/><quality offsamples="8"/></visual>
          <asset>
            <texture name="board" type="2d" file="board.png"/>
            <material name="board" texture="board" specular="0" shininess="0" reflectance="0"/>
          </asset>
          <worldbody>
            <geom type="box" pos="{" ".join(map(str, BOARD_CENTRE))}" size="{width / 2} 0.001 {height / 2}" material="board"/>
            <body name="gripper" mocap="true">
              <camera name="wrist" fovy="{self.fovy_deg}" pos="{" ".join(map(str, mount[:3, 3]))}" quat="{" ".join(map(str, quat))}"/>
            </body>
          </worldbody>
        </mujoco>"""
        return mujoco.MjModel.from_xml_string(xml, {"board.png": png.tobytes()})

    def gripper_poses(self, count: int, seed: int, spread: float = 0.03) -> list[np.ndarray]:
        """``count`` gripper poses (seeded) whose camera looks at the board from 0.3-0.55 m, up to
        35 degrees left or right and 30 up or down off its normal, at a point up to ``spread``
        metres from its centre, rolled up to 20 degrees."""
        rng = np.random.default_rng(seed)
        centre = np.array(BOARD_CENTRE)
        poses = []
        for _ in range(count):
            yaw, pitch = np.radians(rng.uniform(-35, 35)), np.radians(rng.uniform(-30, 30))
            direction = np.array([np.sin(yaw) * np.cos(pitch), -np.cos(yaw) * np.cos(pitch), np.sin(pitch)])
            eye = centre + rng.uniform(0.3, 0.55) * direction
            target = centre + [rng.uniform(-spread, spread), 0.0, rng.uniform(-spread, spread)]
            z = (target - eye) / np.linalg.norm(target - eye)
            x = np.cross(z, [0.0, 0.0, -1.0])
            x /= np.linalg.norm(x)
            world_camera = np.eye(4)
            world_camera[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
            world_camera[:3, 3] = eye
            poses.append(world_camera @ axis_rotation(2, rng.uniform(-20, 20)) @ invert_transform(self.hand_camera))
        return poses

    def render(self, gripper_poses: list[np.ndarray]) -> list[np.ndarray]:
        """The camera's RGB image (uint8, ``height`` x ``width`` x 3) at each gripper pose."""
        mujoco, _ = require_mujoco()
        model = self.model()
        data = mujoco.MjData(model)
        renderer = new_renderer(model, self.height, self.width)
        images = []
        try:
            for k, pose in enumerate(gripper_poses):
                pose = rigid_transform(f"gripper pose {k}", pose)
                quat = np.zeros(4)
                mujoco.mju_mat2Quat(quat, pose[:3, :3].ravel())
                data.mocap_pos[0], data.mocap_quat[0] = pose[:3, 3], quat
                mujoco.mj_forward(model, data)
                renderer.update_scene(data, camera="wrist")
                images.append(renderer.render().copy())
        finally:
            close_renderer(renderer)
        return images

    def write_images(self, folder: str | Path, gripper_poses: list[np.ndarray], poses_file: bool = True) -> list[Path]:
        """Render the images at ``gripper_poses`` into ``folder`` as ``000.png``, ``001.png``, ...
        and, with ``poses_file``, write ``poses.json`` pairing each with its gripper pose (the
        format ``occrl calibrate hand-camera`` reads); returns the image paths."""
        cv2 = require_opencv()
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        paths = []
        for k, image in enumerate(self.render(gripper_poses)):
            paths.append(folder / f"{k:03d}.png")
            if not cv2.imwrite(str(paths[-1]), image[..., ::-1]):
                raise OSError(f"OpenCV could not write {paths[-1]}")
        if poses_file:
            entries = [{"image": p.name, "gripper_pose": g.tolist()} for p, g in zip(paths, gripper_poses)]
            (folder / "poses.json").write_text(json.dumps({"poses": entries}, indent=1) + "\n")
        return paths
