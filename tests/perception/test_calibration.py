"""Camera calibration from a ChArUco board: the intrinsics and the hand-camera transform recovered
from images that real MuJoCo renders of the printed board, seen by a camera fixed to a moving
gripper at a known pose and field of view; the board page at true size; bad input named."""

import json

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("cv2")
pytest.importorskip("mujoco")

from occrl.cli import main  # noqa: E402
from occrl.envs.mujoco3d.calibration_scene import CalibrationScene, axis_rotation  # noqa: E402
from occrl.envs.mujoco3d.camera import gl_available  # noqa: E402
from occrl.perception import load_camera  # noqa: E402
from occrl.perception.board import CalibrationBoard, board_page, find_board  # noqa: E402
from occrl.perception.calibration import (  # noqa: E402
    board_pose,
    calibrate_hand_camera,
    calibrate_intrinsics,
    read_gripper_poses,
)
from occrl.perception.camera import CameraModel  # noqa: E402
from occrl.perception.frames import invert_transform, rotation_angle_deg  # noqa: E402

needs_gl = pytest.mark.skipif(not gl_available()[0], reason=f"no OpenGL backend for MuJoCo: {gl_available()[1]}")

BOARD = CalibrationBoard()
SCENE = CalibrationScene(BOARD)  # 640 x 480, 55 degrees high: fx = fy = 461.04 px
TRUE = SCENE.true_camera()
HAND_CAMERA = SCENE.hand_camera


def rotation(axis: str, deg: float) -> np.ndarray:
    return axis_rotation("xyz".index(axis), deg)


@pytest.fixture(scope="module")
def views() -> dict[str, tuple[list[np.ndarray], list[np.ndarray]]]:
    """16 images of the board across the image for the intrinsics, 12 for the hand-camera transform."""
    out = {}
    for name, count, seed, spread in (("intrinsics", 16, 1, 0.12), ("hand", 12, 2, 0.03)):
        poses = SCENE.gripper_poses(count, seed, spread)
        out[name] = (poses, SCENE.render(poses))
    return out


@needs_gl
def test_rendered_board_is_where_mujoco_put_it(views):
    # the scene's own check: solvePnP with the true camera finds the board where the model has it
    poses, images = views["hand"]
    for pose, image in zip(poses, images):
        view = find_board(image, BOARD)
        assert view is not None and len(view.ids) >= 20
        truth = invert_transform(pose @ HAND_CAMERA) @ SCENE.world_board()
        found = board_pose(view, TRUE)
        assert np.abs(found[:3, 3] - truth[:3, 3]).max() < 1.5e-3
        assert rotation_angle_deg(found[:3, :3].T @ truth[:3, :3]) < 0.3


@needs_gl
def test_intrinsics_are_recovered_from_rendered_views(views):
    _, images = views["intrinsics"]
    result = calibrate_intrinsics(images, BOARD)
    assert result.used == tuple(range(16)) and (result.width, result.height) == (640, 480)
    assert result.rms_px < 0.3
    # measured: fx, fy within 0.5 px of 461.0, cx, cy within 1 px of (319.5, 239.5), |k1| < 0.01
    assert abs(result.fx - TRUE.fx) < 2.0 and abs(result.fy - TRUE.fx) < 2.0, (result.fx, result.fy, TRUE.fx)
    assert abs(result.cx - TRUE.cx) < 2.0 and abs(result.cy - TRUE.cy) < 2.0, (result.cx, result.cy)
    assert np.abs(result.distortion[:2]).max() < 0.05


@needs_gl
def test_hand_camera_is_recovered_from_rendered_views(views, tmp_path):
    poses, images = views["hand"]
    intrinsics = calibrate_intrinsics(views["intrinsics"][1], BOARD)
    result = calibrate_hand_camera(images, poses, intrinsics.camera(), BOARD)
    error_m = np.linalg.norm(result.hand_camera[:3, 3] - HAND_CAMERA[:3, 3])
    error_deg = rotation_angle_deg(result.hand_camera[:3, :3].T @ HAND_CAMERA[:3, :3])
    # measured: 0.61 mm, 0.17 degrees (0.4-0.8 mm, 0.15-0.21 degrees over seeds 2-4; 0.3-0.6 mm, 0.04-0.06 degrees
    # with the true intrinsics): the intrinsics' error dominates
    assert error_m < 2e-3 and error_deg < 0.5, (error_m, error_deg, result.method)
    assert result.reprojection_rms_px < 1.0 and result.board_spread_m < 2e-3 and result.board_spread_deg < 0.5
    assert np.abs(result.base_board[:3, 3] - SCENE.world_board()[:3, 3]).max() < 3e-3


@needs_gl
def test_residuals_expose_mixed_up_poses(views):
    # the residuals are what a user checks: poses paired with the wrong images, or given
    # base-to-gripper instead of gripper-to-base, spread the board over centimetres
    poses, images = views["hand"]
    shuffled = poses[1:] + poses[:1]
    inverted = [invert_transform(p) for p in poses]
    for wrong in (shuffled, inverted):
        result = calibrate_hand_camera(images, wrong, TRUE, BOARD)
        assert result.board_spread_m > 0.01 and result.reprojection_rms_px > 10.0, (result.board_spread_m, result.reprojection_rms_px)


@needs_gl
def test_cli_calibrates_from_image_folders(views, tmp_path, capsys):
    for name, (poses, images) in views.items():
        (tmp_path / name).mkdir()
        for k, image in enumerate(images):
            Image.fromarray(image).save(tmp_path / name / f"{k:03d}.png")
    poses = [{"image": f"{k:03d}.png", "gripper_pose": p.tolist()} for k, p in enumerate(views["hand"][0])]
    (tmp_path / "poses.json").write_text(json.dumps({"poses": poses}))
    camera_file = str(tmp_path / "camera.json")
    assert main(["calibrate", "intrinsics", "--images", str(tmp_path / "intrinsics"), "--out", camera_file]) == 0
    out = capsys.readouterr().out
    assert "16 of 16 images" in out and "RMS" in out
    args = ["--images", str(tmp_path / "hand"), "--poses", str(tmp_path / "poses.json"), "--camera", camera_file, "--out", camera_file]
    assert main(["calibrate", "hand-camera", *args]) == 0
    assert "board spread" in capsys.readouterr().out
    camera = load_camera(camera_file)
    assert abs(camera.fx - TRUE.fx) < 2.0 and np.abs(camera.hand_camera[:3, 3] - HAND_CAMERA[:3, 3]).max() < 2e-3


def test_board_page_prints_squares_at_true_size(tmp_path):
    assert main(["calibrate", "board", "--out", str(tmp_path / "board.png"), "--dpi", "200"]) == 0
    page = Image.open(tmp_path / "board.png")
    assert page.size == (1654, 2339) and page.info["dpi"] == pytest.approx((200, 200), abs=0.01)  # A4 at 200 dpi
    view = find_board(np.asarray(page), BOARD)
    assert view is not None and len(view.ids) == BOARD.corner_count
    square_px = BOARD.square_length * 1000 / 25.4 * 200  # 35 mm: 275.6 pixels
    steps = np.diff(view.image_points.reshape(BOARD.squares_y - 1, BOARD.squares_x - 1, 2), axis=1)[..., 0]
    assert np.abs(steps - square_px).max() <= 1.0
    assert np.asarray(board_page(BOARD, 100)).shape == (1169, 827)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"squares_x": 2}, r"squares_x must be in \[3, 51\), got 2"),
        ({"square_length": 35.0}, "must be in metres"),
        ({"marker_length": 0.035}, "must be shorter than square_length"),
        ({"dictionary": "aruco_4x4_50", "squares_x": 11, "squares_y": 11}, "needs 60 markers; aruco_4x4_50 has 50"),
        ({"dictionary": "dict_5x5"}, "unknown board dictionary 'dict_5x5'; allowed"),
    ],
)
def test_bad_boards_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CalibrationBoard(**kwargs)


def test_bad_images_and_poses_are_named(tmp_path):
    blank = np.full((48, 64), 255, np.uint8)
    with pytest.raises(ValueError, match="image 1 must be uint8"):
        calibrate_intrinsics([blank, blank.astype(float)], BOARD)
    with pytest.raises(ValueError, match=r"image 0 must be a grey \(H, W\) or RGB \(H, W, 3\) image .* got shape \(48, 64, 2\)"):
        calibrate_intrinsics([np.zeros((48, 64, 2), np.uint8)], BOARD)
    with pytest.raises(ValueError, match="must all have one size"):
        calibrate_intrinsics([blank, blank[:40]], BOARD)
    with pytest.raises(ValueError, match="the board .* was found in 0 of 6 images; calibrating the intrinsics needs at least 5"):
        calibrate_intrinsics([blank] * 6, BOARD)
    camera = CameraModel.from_fov(64, 48, 60.0)
    turn = [rotation("x", 10.0), rotation("y", 10.0), np.eye(4)]
    with pytest.raises(ValueError, match="at least 3 gripper poses"):
        calibrate_hand_camera([blank] * 2, turn[:2], camera, BOARD)
    with pytest.raises(ValueError, match="gripper pose 1 must be a rigid transform"):
        calibrate_hand_camera([blank] * 3, [np.eye(4), np.diag([2.0, 1.0, 1.0, 1.0]), np.eye(4)], camera, BOARD)
    millimetres = [p.copy() for p in turn]
    millimetres[0][:3, 3] = [400.0, 100.0, 300.0]
    with pytest.raises(ValueError, match="translations must be in metres"):
        calibrate_hand_camera([blank] * 3, millimetres, camera, BOARD)
    with pytest.raises(ValueError, match="one image per gripper pose is needed: 3 poses, 2 images"):
        calibrate_hand_camera([blank] * 2, turn, camera, BOARD)
    with pytest.raises(ValueError, match="was found in 0 of 3 images; hand-camera calibration needs it in at least 3"):
        calibrate_hand_camera([blank] * 3, turn, camera, BOARD)
    (tmp_path / "poses.json").write_text(json.dumps({"poses": [{"image": "a.png", "gripper_pose": np.eye(4).tolist()}]}))
    with pytest.raises(ValueError, match=r"one pose per image: no pose for \['b.png'\], no image for \[\]"):
        read_gripper_poses(tmp_path / "poses.json", ["a.png", "b.png"])


@needs_gl
def test_poses_turning_about_one_axis_are_refused(views):
    poses, images = views["hand"]
    flat = [SCENE.gripper_poses(1, 3, 0.0)[0] @ rotation("y", a) for a in (-10.0, 0.0, 10.0)]
    with pytest.raises(ValueError, match="about at least two different axes"):
        calibrate_hand_camera(images[:3], flat, TRUE, BOARD)


def test_every_calibrate_step_has_examples_and_shows_its_defaults():
    import argparse

    from occrl.cli import make_parser

    [sub] = [a for a in make_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    [steps] = [a for a in sub.choices["calibrate"]._actions if isinstance(a, argparse._SubParsersAction)]
    assert sorted(steps.choices) == ["board", "hand-camera", "intrinsics"]
    for name, parser in steps.choices.items():
        assert "examples:" in parser.epilog, name
        formatter = parser._get_formatter()
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            shown = formatter._expand_help(action)
            assert len(shown) > 10 and ("(default" in shown or action.required), (name, action.option_strings, shown)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["board", "--out", "{tmp}/board.jpg"], "the board's file must end in .pdf or .png, got 'board.jpg'"),
        (["board", "--out", "{tmp}/board.png", "--square", "35"], "argument --square: 35 is out of range; allowed: metres in (0, 1]"),
        (["board", "--out", "{tmp}/board.png", "--squares-x", "9"], "does not fit the a4 page"),
        (["intrinsics", "--images", "{tmp}/none", "--out", "{tmp}/camera.json"], "the image folder"),
        (["intrinsics", "--images", "{tmp}", "--out", "{tmp}/camera.json"], "holds no images"),
        (["board", "--out", "{tmp}/board.png", "--dictionary", "dict_5x5"], "unknown board dictionary 'dict_5x5'"),
    ],
)
def test_cli_bad_input_is_named_and_writes_nothing(tmp_path, capsys, argv, message):
    assert main(["calibrate"] + [a.format(tmp=tmp_path) for a in argv]) == 2
    assert message in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
