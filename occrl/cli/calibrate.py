"""``occrl calibrate board | intrinsics | hand-camera``: print a ChArUco board, then calibrate the
wrist camera's intrinsics and its pose on the gripper from images of it
(:mod:`occrl.perception.calibration`)."""

from __future__ import annotations

import argparse

from occrl.cli.options import HelpFormatter, bounded

__all__ = ["add_calibrate_parser", "run_board", "run_intrinsics", "run_hand_camera"]

DPI = bounded(int, 50, 2400, what="an integer in [50, 2400]")
SQUARES = bounded(int, 3, 50, what="an integer in [3, 50]")
LENGTH = bounded(float, 0.0, 1.0, low_open=True, what="metres in (0, 1]")

EPILOG = """\
examples:
  occrl calibrate board --out board.pdf                    the default board (5 x 7 squares of 35 mm) on A4
  occrl calibrate intrinsics --images calib/ --out camera.json
  occrl calibrate hand-camera --images hand/ --poses hand/poses.json --camera camera.json --out camera.json
  occrl calibrate intrinsics --help                        a step's options

Print the board at 100 %, measure a square, and give the measured length (--square) if it differs."""

BOARD_EPILOG = """\
examples:
  occrl calibrate board --out board.pdf                    5 x 7 squares of 35 mm, A4
  occrl calibrate board --out board.png --dpi 600 --page letter
  occrl calibrate board --out big.pdf --squares-x 4 --squares-y 6 --square 0.045 --marker 0.034

Print at 100 % (actual size), glue the page flat on a rigid board, and measure a square."""

INTRINSICS_EPILOG = """\
examples:
  occrl calibrate intrinsics --images calib/ --out camera.json
  occrl calibrate intrinsics --images calib/ --out camera.json --square 0.0349   the printed square measured 34.9 mm

Take 15-30 images at the camera's working size, the board over all parts of the image at
different slants and distances. Expect an RMS error under 0.5 pixel; images with far larger errors
than the others are blurred or show a bent board."""

HAND_EPILOG = """\
examples:
  occrl calibrate hand-camera --images hand/ --poses hand/poses.json --camera camera.json --out camera.json

Fix the board; take 10-20 images from gripper poses that turn the gripper about different axes
(up and down as well as left and right), each with the gripper's pose from the arm's forward
kinematics in the poses file: {"poses": [{"image": "000.png", "gripper_pose": 4 rows of 4 numbers}, ...]},
the 4 x 4 transform from the gripper frame (origin at the palm's front centre, x right, y along the
approach direction, z up) to the arm's base frame, in metres."""


def add_board_options(parser: argparse.ArgumentParser) -> None:
    """The board's settings, shared by the three steps."""
    g = parser.add_argument_group("the board (as printed by occrl calibrate board)")
    g.add_argument("--squares-x", type=SQUARES, default=5, help="squares across the board")
    g.add_argument("--squares-y", type=SQUARES, default=7, help="squares down the board")
    g.add_argument("--square", type=LENGTH, default=0.035, help="side of a square in metres (measure the print)")
    g.add_argument("--marker", type=LENGTH, default=0.026, help="side of a marker's black square in metres")
    g.add_argument("--dictionary", default="aruco_5x5_100", help="the markers' dictionary (aruco_4x4_50, aruco_5x5_100, ...)")


def add_calibrate_parser(sub) -> None:
    """Add the ``calibrate`` command and its three steps to the ``occrl`` subparsers ``sub``."""
    c = sub.add_parser(
        "calibrate",
        help="calibrate the wrist camera: print a ChArUco board, then intrinsics and the hand-camera transform from images",
        description="Calibrate the wrist camera for the tag detector: print a ChArUco board (board), find the camera's "
        "intrinsics and distortion from images of it (intrinsics), then the camera's pose on the gripper from images taken "
        'at known gripper poses (hand-camera). Writes the camera file occrl.perception.load_camera reads. Needs OpenCV: pip install "occrl[camera]".',
        epilog=EPILOG,
        formatter_class=HelpFormatter,
    )
    steps = c.add_subparsers(title="steps", dest="step", required=True, metavar="STEP")
    b = steps.add_parser(
        "board",
        help="write the ChArUco board at true size (PDF or PNG) to print",
        description="Write a page with the ChArUco board at true size, a 50 mm bar to check the print's scale and a line naming the board.",
        epilog=BOARD_EPILOG,
        formatter_class=HelpFormatter,
    )
    b.add_argument("--out", required=True, help="the page: a .pdf or a .png")
    b.add_argument("--dpi", type=DPI, default=300, help="pixels per inch of the page")
    b.add_argument("--page", choices=["a4", "letter"], default="a4", help="paper size")
    add_board_options(b)
    b.set_defaults(func=run_board)
    i = steps.add_parser(
        "intrinsics",
        help="the camera's focal lengths, principal point and distortion from images of the board",
        description="Find the board's corners in every image of a folder and calibrate the camera (cv2.calibrateCamera); "
        "write a camera file whose hand_camera is the default until the hand-camera step measures it.",
        epilog=INTRINSICS_EPILOG,
        formatter_class=HelpFormatter,
    )
    i.add_argument("--images", metavar="DIR", required=True, help="folder of the board's images (.png, .jpg, ...), all of one size")
    i.add_argument("--out", metavar="FILE", required=True, help="the camera file to write (.json, or .yaml with PyYAML)")
    add_board_options(i)
    i.set_defaults(func=run_intrinsics)
    h = steps.add_parser(
        "hand-camera",
        help="the camera's pose on the gripper from images of a fixed board at known gripper poses",
        description="Find the board's pose in each image (cv2.solvePnP), solve for the camera's pose in the gripper frame "
        "(cv2.calibrateHandEye) and write it into the camera file.",
        epilog=HAND_EPILOG,
        formatter_class=HelpFormatter,
    )
    h.add_argument("--images", metavar="DIR", required=True, help="folder of the board's images, one per gripper pose")
    h.add_argument("--poses", metavar="FILE", required=True, help="the poses file (JSON): each image's gripper pose")
    h.add_argument("--camera", metavar="FILE", required=True, help="the camera file with the calibrated intrinsics")
    h.add_argument("--out", metavar="FILE", required=True, help="the camera file to write (may be --camera itself)")
    add_board_options(h)
    h.set_defaults(func=run_hand_camera)


def board_of(args: argparse.Namespace):
    from occrl.perception.board import CalibrationBoard

    return CalibrationBoard(args.squares_x, args.squares_y, args.square, args.marker, args.dictionary)


def run_board(args: argparse.Namespace) -> int:
    from occrl.perception.board import write_board

    board = board_of(args)
    path = write_board(board, args.out, dpi=args.dpi, page=args.page)
    print(f"{board.describe()} on {path}")
    print("print at 100 % (actual size), check the 50 mm bar, glue the page flat on a rigid board and measure a square")
    return 0


def run_intrinsics(args: argparse.Namespace) -> int:
    from occrl.perception.calibration import calibrate_intrinsics, read_images, write_camera_file

    board = board_of(args)
    names, images = read_images(args.images)
    result = calibrate_intrinsics(images, board)
    camera = write_camera_file(result.camera(), args.out)
    print(
        f"the board in {len(result.used)} of {len(images)} images: RMS reprojection error {result.rms_px:.3f} px; "
        f"fx {camera.fx:.1f}, fy {camera.fy:.1f}, cx {camera.cx:.1f}, cy {camera.cy:.1f} px, "
        f"distortion {', '.join(f'{d:.4f}' for d in camera.distortion)}"
    )
    worst = sorted(zip(result.image_rms_px, (names[k] for k in result.used)), reverse=True)[:3]
    print("largest errors: " + ", ".join(f"{name} {rms:.2f} px" for rms, name in worst))
    missed = [names[k] for k in range(len(names)) if k not in result.used]
    if missed:
        print(f"board not found in: {', '.join(missed)}")
    print(f"wrote {args.out}; its hand_camera is the default until occrl calibrate hand-camera measures it")
    return 0


def run_hand_camera(args: argparse.Namespace) -> int:
    import numpy as np

    from occrl.perception.calibration import calibrate_hand_camera, read_gripper_poses, read_images, write_camera_file
    from occrl.perception.camera import load_camera

    board = board_of(args)
    camera = load_camera(args.camera)
    names, images = read_images(args.images)
    poses = read_gripper_poses(args.poses, names)
    result = calibrate_hand_camera(images, poses, camera, board)
    write_camera_file(result.camera(camera), args.out)
    with np.printoptions(precision=4, suppress=True):
        print(f"hand_camera (the camera's pose in the gripper frame, {result.method}):\n{result.hand_camera}")
    print(
        f"the board in {len(result.used)} of {len(images)} images: board spread {result.board_spread_m * 1000:.2f} mm, "
        f"{result.board_spread_deg:.2f} degrees; reprojection error {result.reprojection_rms_px:.2f} px RMS"
    )
    print(f"wrote {args.out}")
    return 0
