"""Calibrating the wrist camera from images of a printed ChArUco board (:mod:`occrl.perception.board`).

Two steps, each from a set of images:

* :func:`calibrate_intrinsics`: the camera's focal lengths, principal point and 5 distortion
  coefficients (OpenCV's model and conventions, :mod:`occrl.perception.camera`) by
  ``cv2.calibrateCamera`` on the board's corners, with its RMS reprojection error in pixels;
* :func:`calibrate_hand_camera`: the camera's pose in the gripper frame (``hand_camera``) from
  images of a board that stays still while the arm moves, each with the gripper's pose: the board's
  pose in each image by ``cv2.solvePnP``, then ``cv2.calibrateHandEye``.

A gripper pose is the 4x4 transform from the gripper frame to the arm's base frame (``p_base =
gripper_pose @ p_gripper``, metres), as the arm's forward kinematics give it. The gripper frame is
occrl's: origin at the palm's front centre (between the finger bases), +y along the approach
direction, +x to the gripper's right, +z up; the base frame is any frame fixed to the arm's base.

A poses file (JSON) pairs each image with its gripper pose::

    {"poses": [{"image": "000.png", "gripper_pose": [[1, 0, 0, 0.4], [0, 1, 0, 0.1], [0, 0, 1, 0.3], [0, 0, 0, 1]]},
               ...]}

The residuals say how well the result explains the images: the board, seen from every gripper
pose through the calibrated camera, should stay where it is in the base frame
(:attr:`HandCameraCalibration.board_spread_m`, ``board_spread_deg``) and its corners should
reproject where they were found (``reprojection_rms_px``).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from occrl.perception.board import BoardView, CalibrationBoard, find_board
from occrl.perception.camera import CameraModel, load_camera, save_camera
from occrl.perception.checks import rigid_transform
from occrl.perception.frames import invert_transform, rotation_angle_deg
from occrl.perception.opencv import as_grey_image, require_opencv

__all__ = [
    "IntrinsicCalibration",
    "HandCameraCalibration",
    "calibrate_intrinsics",
    "calibrate_hand_camera",
    "board_pose",
    "write_camera_file",
    "read_images",
    "read_gripper_poses",
    "IMAGE_SUFFIXES",
    "MIN_INTRINSIC_IMAGES",
    "MIN_HAND_POSES",
]

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
MIN_INTRINSIC_IMAGES = 5
MIN_HAND_POSES = 3
MAX_REACH_M = 5.0  # a gripper further from the base than this is a pose in millimetres
MIN_TURN_DEG = 5.0  # the gripper must turn at least this much between some poses, about two axes
HAND_EYE_METHODS = ("tsai", "park", "horaud", "andreff", "daniilidis")


@dataclass(frozen=True)
class IntrinsicCalibration:
    """The result of :func:`calibrate_intrinsics`: the camera's intrinsics and distortion
    (OpenCV's conventions), the RMS reprojection error of the board's corners over all images used
    (pixels) and per image, and the indices of the images used (those where the board was found)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...]
    rms_px: float
    image_rms_px: tuple[float, ...]
    used: tuple[int, ...]

    def camera(self, hand_camera: np.ndarray | None = None) -> CameraModel:
        """The :class:`~occrl.perception.camera.CameraModel` with these intrinsics and
        ``hand_camera`` (the model's default, a camera at the gripper frame's origin looking along
        the approach direction, when ``None``)."""
        extra = {} if hand_camera is None else {"hand_camera": hand_camera}
        return CameraModel(self.width, self.height, self.fx, self.fy, self.cx, self.cy, self.distortion, **extra)


@dataclass(frozen=True)
class HandCameraCalibration:
    """The result of :func:`calibrate_hand_camera`: ``hand_camera`` (the camera's 4x4 pose in the
    gripper frame), the board's pose in the base frame it implies (``base_board``), the residuals
    (RMS distance and angle of the board's pose seen from each image to ``base_board``; RMS pixel
    error of the board's corners reprojected from ``base_board`` through each gripper pose), the
    ``cv2.calibrateHandEye`` method that gave the smallest reprojection error, and the indices of
    the images used."""

    hand_camera: np.ndarray
    base_board: np.ndarray
    board_spread_m: float
    board_spread_deg: float
    reprojection_rms_px: float
    method: str
    used: tuple[int, ...]

    def camera(self, camera: CameraModel) -> CameraModel:
        """``camera`` with this ``hand_camera``."""
        return replace(camera, hand_camera=self.hand_camera)


def find_views(images: Sequence[np.ndarray], board: CalibrationBoard) -> tuple[list[BoardView | None], tuple[int, int]]:
    """The board's corners in each image (``None`` where it was not found) and the images' (width,
    height); ``ValueError`` for an empty list, a bad image or images of different sizes."""
    if isinstance(images, np.ndarray) or not isinstance(images, Sequence) or len(images) == 0:
        raise ValueError(f"images must be a non-empty list of images, got {type(images).__name__}")
    if not isinstance(board, CalibrationBoard):
        raise TypeError(f"board must be a CalibrationBoard, got {type(board).__name__}")
    greys = [as_grey_image(f"image {k}", image) for k, image in enumerate(images)]
    sizes = {g.shape for g in greys}
    if len(sizes) > 1:
        raise ValueError(f"the images must all have one size (the camera's); got (height, width) {sorted(sizes)}")
    cv2 = require_opencv()
    detector = cv2.aruco.CharucoDetector(board.opencv_board())
    views = [find_board(g, board, detector) for g in greys]
    height, width = greys[0].shape
    return views, (width, height)


def calibrate_intrinsics(
    images: Sequence[np.ndarray], board: CalibrationBoard, min_images: int = MIN_INTRINSIC_IMAGES
) -> IntrinsicCalibration:
    """The camera's intrinsics and distortion from images of ``board`` (grey or RGB uint8, all of
    one size), by ``cv2.calibrateCamera`` on the ChArUco corners found.

    Use 15-30 images with the board at different places in the image and different slants. Images
    where the board is not found are left out (see ``used``); fewer than ``min_images`` (at least
    4) usable images raise ``ValueError``.
    """
    if isinstance(min_images, (bool, np.bool_)) or not isinstance(min_images, (int, np.integer)) or min_images < 4:
        raise ValueError(f"min_images must be an int of at least 4, got {min_images!r}")
    views, (width, height) = find_views(images, board)
    used = [k for k, v in enumerate(views) if v is not None]
    if len(used) < min_images:
        raise ValueError(
            f"the board ({board.describe()}) was found in {len(used)} of {len(views)} images; calibrating the intrinsics "
            f"needs at least {min_images}: check the board's settings, the focus and the light, and show it whole"
        )
    cv2 = require_opencv()
    board_points = [views[k].board_points.astype(np.float32) for k in used]
    image_points = [views[k].image_points.astype(np.float32).reshape(-1, 1, 2) for k in used]
    rms, matrix, distortion, rvecs, tvecs = cv2.calibrateCamera(board_points, image_points, (width, height), None, None)
    distortion = distortion.ravel()[:5]
    per_image = []
    for k, rvec, tvec in zip(used, rvecs, tvecs):
        projected, _ = cv2.projectPoints(views[k].board_points, rvec, tvec, matrix, distortion)
        per_image.append(float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - views[k].image_points) ** 2, axis=1)))))
    log.info("intrinsics from %d of %d images: RMS %.3f px", len(used), len(views), rms)
    return IntrinsicCalibration(
        width=width,
        height=height,
        fx=float(matrix[0, 0]),
        fy=float(matrix[1, 1]),
        cx=float(matrix[0, 2]),
        cy=float(matrix[1, 2]),
        distortion=tuple(float(d) for d in distortion),
        rms_px=float(rms),
        image_rms_px=tuple(per_image),
        used=tuple(used),
    )


def board_pose(view: BoardView, camera: CameraModel) -> np.ndarray:
    """The board's 4x4 pose in the camera frame (``p_camera = camera_board @ p_board``) from its
    corners in one image: ``cv2.solvePnP`` (IPPE, for a plane) refined by Levenberg-Marquardt."""
    cv2 = require_opencv()
    k, d = camera.intrinsic_matrix, camera.distortion_array
    ok, rvec, tvec = cv2.solvePnP(view.board_points, view.image_points, k, d, flags=cv2.SOLVEPNP_IPPE)
    if not ok:  # pragma: no cover - IPPE fails only on degenerate corners, which find_board refuses
        raise ValueError("cv2.solvePnP found no board pose for the corners")
    rvec, tvec = cv2.solvePnPRefineLM(view.board_points, view.image_points, k, d, rvec, tvec)
    pose = np.eye(4)
    pose[:3, :3] = cv2.Rodrigues(rvec)[0]
    pose[:3, 3] = tvec.ravel()
    return pose


def check_gripper_poses(gripper_poses: Sequence[Any]) -> list[np.ndarray]:
    """The gripper poses as rigid 4x4 arrays in metres that turn about two axes; ``ValueError``
    naming the pose and the problem otherwise."""
    if isinstance(gripper_poses, np.ndarray) and gripper_poses.ndim == 3:
        gripper_poses = list(gripper_poses)
    if not isinstance(gripper_poses, Sequence) or isinstance(gripper_poses, (str, bytes)):
        raise ValueError(f"gripper_poses must be a list of 4x4 transforms, got {type(gripper_poses).__name__}")
    poses = [rigid_transform(f"gripper pose {k}", p, tolerance=1e-3) for k, p in enumerate(gripper_poses)]
    for k, p in enumerate(poses):
        if np.linalg.norm(p[:3, 3]) > MAX_REACH_M:
            raise ValueError(
                f"gripper pose {k} puts the gripper {np.linalg.norm(p[:3, 3]):.4g} m from the base: translations must be "
                f"in metres (at most {MAX_REACH_M:g}), not millimetres"
            )
    return poses


def check_turns(poses: list[np.ndarray]) -> None:
    """``ValueError`` unless the gripper turns by :data:`MIN_TURN_DEG` or more about at least two
    different axes between the poses (hand-eye calibration is undetermined otherwise)."""
    cv2 = require_opencv()
    axes = []
    for p in poses[1:]:
        rvec = cv2.Rodrigues(poses[0][:3, :3].T @ p[:3, :3])[0].ravel()
        if np.degrees(np.linalg.norm(rvec)) >= MIN_TURN_DEG:
            axes.append(rvec / np.linalg.norm(rvec))
    if len(axes) >= 2 and np.linalg.svd(np.array(axes), compute_uv=False)[1] > np.sin(np.radians(MIN_TURN_DEG)):
        return
    raise ValueError(
        f"the gripper must turn by {MIN_TURN_DEG:g} degrees or more about at least two different axes between the poses "
        "(tilt it up and down as well as left and right): these poses leave the hand-camera transform undetermined"
    )


def mean_rotation(rotations: Sequence[np.ndarray]) -> np.ndarray:
    """The rotation nearest to the mean of ``rotations`` (chordal L2 mean)."""
    u, _, vt = np.linalg.svd(np.sum(rotations, axis=0))
    r = u @ vt
    if np.linalg.det(r) < 0:
        r = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    return r


def hand_eye_residuals(
    hand_camera: np.ndarray, gripper_poses: list[np.ndarray], camera_boards: list[np.ndarray], views: list[BoardView], camera: CameraModel
) -> tuple[np.ndarray, float, float, float]:
    """The board's pose in the base frame (the mean over the images) and the residuals of
    ``hand_camera``: RMS distance (m) and angle (degrees) of each image's board pose to the mean,
    and the RMS reprojection error (pixels) of the corners from the mean pose."""
    cv2 = require_opencv()
    bases = [g @ hand_camera @ c for g, c in zip(gripper_poses, camera_boards)]
    base_board = np.eye(4)
    base_board[:3, :3] = mean_rotation([b[:3, :3] for b in bases])
    base_board[:3, 3] = np.mean([b[:3, 3] for b in bases], axis=0)
    spread_m = float(np.sqrt(np.mean([np.sum((b[:3, 3] - base_board[:3, 3]) ** 2) for b in bases])))
    spread_deg = float(np.sqrt(np.mean([rotation_angle_deg(base_board[:3, :3].T @ b[:3, :3]) ** 2 for b in bases])))
    errors = []
    for g, view in zip(gripper_poses, views):
        camera_board = invert_transform(g @ hand_camera) @ base_board
        rvec = cv2.Rodrigues(camera_board[:3, :3])[0]
        projected, _ = cv2.projectPoints(view.board_points, rvec, camera_board[:3, 3], camera.intrinsic_matrix, camera.distortion_array)
        errors.append(np.sum((projected.reshape(-1, 2) - view.image_points) ** 2, axis=1))
    return base_board, spread_m, spread_deg, float(np.sqrt(np.mean(np.concatenate(errors))))


def calibrate_hand_camera(
    images: Sequence[np.ndarray], gripper_poses: Sequence[Any], camera: CameraModel, board: CalibrationBoard
) -> HandCameraCalibration:
    """The camera's pose in the gripper frame from images of a still ``board``, each taken at the
    matching gripper pose (4x4, gripper frame to base frame, metres; see
    :mod:`occrl.perception.calibration`), with ``camera``'s intrinsics.

    The board's pose in each image comes from ``cv2.solvePnP``; ``cv2.calibrateHandEye`` then
    solves for the transform with each of its methods, and the one whose board reprojects best is
    kept. Use 10-20 poses that view the board from different directions, turning the gripper about
    different axes. ``ValueError`` for fewer than 3 poses, a count of poses other than of images,
    a pose that is not a rigid transform in metres, poses that turn about one axis only, or fewer
    than 3 images showing the board.
    """
    if not isinstance(camera, CameraModel):
        raise TypeError(f"camera must be a CameraModel (its intrinsics calibrated), got {type(camera).__name__}")
    poses = check_gripper_poses(gripper_poses)
    if len(poses) < MIN_HAND_POSES:
        raise ValueError(f"hand-camera calibration needs at least {MIN_HAND_POSES} gripper poses (10-20 recommended), got {len(poses)}")
    if isinstance(images, np.ndarray) or not isinstance(images, Sequence) or len(images) != len(poses):
        count = len(images) if isinstance(images, Sequence) else type(images).__name__
        raise ValueError(f"one image per gripper pose is needed: {len(poses)} poses, {count} images")
    views, (width, height) = find_views(images, board)
    if (width, height) != (camera.width, camera.height):
        raise ValueError(f"the images are {width} x {height} pixels but the camera was calibrated at {camera.width} x {camera.height}")
    used = [k for k, v in enumerate(views) if v is not None]
    if len(used) < MIN_HAND_POSES:
        raise ValueError(
            f"the board ({board.describe()}) was found in {len(used)} of {len(views)} images; "
            f"hand-camera calibration needs it in at least {MIN_HAND_POSES}"
        )
    poses = [poses[k] for k in used]
    views = [views[k] for k in used]
    check_turns(poses)
    camera_boards = [board_pose(v, camera) for v in views]
    cv2 = require_opencv()
    best = None
    for method in HAND_EYE_METHODS:
        flag = getattr(cv2, f"CALIB_HAND_EYE_{method.upper()}")
        try:
            r, t = cv2.calibrateHandEye(
                [p[:3, :3] for p in poses],
                [p[:3, 3] for p in poses],
                [c[:3, :3] for c in camera_boards],
                [c[:3, 3] for c in camera_boards],
                method=flag,
            )
        except cv2.error as err:  # e.g. Andreff's least squares on inconsistent motions
            log.info("calibrateHandEye %s failed: %s", method, str(err).strip().splitlines()[-1])
            continue
        hand = np.eye(4)
        hand[:3, :3], hand[:3, 3] = r, t.ravel()
        if not np.all(np.isfinite(hand)) or abs(np.linalg.det(r) - 1) > 1e-3:
            log.info("calibrateHandEye %s gave no rotation", method)
            continue
        hand[:3, :3] = mean_rotation([r])  # re-orthonormalise
        base_board, spread_m, spread_deg, rms = hand_eye_residuals(hand, poses, camera_boards, views, camera)
        log.info("calibrateHandEye %s: board spread %.2f mm %.2f deg, reprojection %.2f px", method, spread_m * 1e3, spread_deg, rms)
        if best is None or rms < best.reprojection_rms_px:
            best = HandCameraCalibration(hand, base_board, spread_m, spread_deg, rms, method, tuple(used))
    if best is None:
        raise ValueError(
            "cv2.calibrateHandEye found no transform with any of its methods: the gripper poses and the board's poses "
            "disagree; check that each pose is gripper-to-base, in metres, and paired with its image"
        )
    return best


def write_camera_file(camera: CameraModel, path: str | Path) -> CameraModel:
    """Write ``camera`` to a camera file (JSON or YAML by the suffix) and read it back with
    :func:`~occrl.perception.camera.load_camera`, whose camera is returned."""
    save_camera(camera, path)
    return load_camera(path)


def read_images(folder: str | Path) -> tuple[list[str], list[np.ndarray]]:
    """The names and grey images of the image files in ``folder`` (suffixes
    :data:`IMAGE_SUFFIXES`), in name order."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"the image folder {folder} does not exist")
    paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    if not paths:
        raise ValueError(f"the folder {folder} holds no images (files ending in {', '.join(IMAGE_SUFFIXES)})")
    cv2 = require_opencv()
    images = []
    for p in paths:
        image = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise ValueError(f"OpenCV could not read the image {p}")
        images.append(image)
    return [p.name for p in paths], images


def read_gripper_poses(path: str | Path, names: Sequence[str]) -> list[np.ndarray]:
    """The gripper pose of each image in ``names`` from a poses file (format in
    :mod:`occrl.perception.calibration`); ``ValueError`` for an image without a pose, a pose
    without an image, or an entry that is not ``{"image": NAME, "gripper_pose": 4x4}``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"the poses file {path} does not exist")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"the poses file {path} is not valid JSON: {err}") from None
    entries = data.get("poses") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        raise ValueError(f'the poses file {path} must hold {{"poses": [{{"image": NAME, "gripper_pose": 4x4}}, ...]}}')
    poses: dict[str, Any] = {}
    for k, entry in enumerate(entries):
        if not isinstance(entry, dict) or set(entry) != {"image", "gripper_pose"} or not isinstance(entry["image"], str):
            raise ValueError(f'{path}: entry {k} must be {{"image": NAME, "gripper_pose": 4x4}}, got {entry!r}')
        if entry["image"] in poses:
            raise ValueError(f"{path}: the image {entry['image']!r} has two poses")
        poses[entry["image"]] = entry["gripper_pose"]
    missing = [n for n in names if n not in poses]
    extra = sorted(set(poses) - set(names))
    if missing or extra:
        raise ValueError(f"{path} must give one pose per image: no pose for {missing}, no image for {extra}")
    return [rigid_transform(f"{path}: gripper_pose of {n}", poses[n], tolerance=1e-3) for n in names]
