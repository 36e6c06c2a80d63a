"""``occrl calibrate`` on a simulated camera: MuJoCo renders the printed ChArUco board seen by a
camera on a moving gripper whose mount and field of view are known; the calibration commands run
on the images as they would on a robot's, and what they recover is compared with the truth.

    MUJOCO_GL=egl python examples/calibrate_simulated_camera.py --out /tmp/calib

writes ``/tmp/calib/intrinsics/*.png`` (images for the intrinsics), ``/tmp/calib/hand/*.png`` and
``/tmp/calib/hand/poses.json`` (images of the fixed board at known gripper poses) and
``/tmp/calib/camera.json``, and prints the errors.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from occrl.cli import main
from occrl.envs.mujoco3d.calibration_scene import CalibrationScene
from occrl.perception import load_camera
from occrl.perception.frames import rotation_angle_deg


def run(out: Path, intrinsic_images: int, hand_images: int, seed: int) -> dict[str, float]:
    scene = CalibrationScene()
    truth = scene.true_camera()
    scene.write_images(out / "intrinsics", scene.gripper_poses(intrinsic_images, seed, spread=0.12), poses_file=False)
    scene.write_images(out / "hand", scene.gripper_poses(hand_images, seed + 1, spread=0.03))
    camera_file = str(out / "camera.json")
    commands = [
        ["calibrate", "intrinsics", "--images", str(out / "intrinsics"), "--out", camera_file],
        ["calibrate", "hand-camera", "--images", str(out / "hand"), "--poses", str(out / "hand" / "poses.json")]
        + ["--camera", camera_file, "--out", camera_file],
    ]
    for argv in commands:
        print("$ occrl " + " ".join(argv))
        if main(argv) != 0:
            raise SystemExit(f"occrl {' '.join(argv[:2])} failed")
    camera = load_camera(camera_file)
    errors = {
        "fx_px": camera.fx - truth.fx,
        "fy_px": camera.fy - truth.fy,
        "cx_px": camera.cx - truth.cx,
        "cy_px": camera.cy - truth.cy,
        "hand_camera_mm": 1000 * float(np.linalg.norm(camera.hand_camera[:3, 3] - truth.hand_camera[:3, 3])),
        "hand_camera_deg": rotation_angle_deg(camera.hand_camera[:3, :3].T @ truth.hand_camera[:3, :3]),
    }
    print(f"truth: fx = fy = {truth.fx:.2f}, cx {truth.cx}, cy {truth.cy} px (MuJoCo's pinhole, no distortion)")
    print(
        f"errors: fx {errors['fx_px']:+.2f}, fy {errors['fy_px']:+.2f}, cx {errors['cx_px']:+.2f}, cy {errors['cy_px']:+.2f} px; "
        f"hand_camera {errors['hand_camera_mm']:.2f} mm, {errors['hand_camera_deg']:.3f} degrees"
    )
    return errors


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", default=None, help="folder for the images and camera.json (default: a temporary folder)")
    parser.add_argument("--intrinsic-images", type=int, default=16, help="images for the intrinsics")
    parser.add_argument("--hand-images", type=int, default=12, help="images (gripper poses) for the hand-camera transform")
    parser.add_argument("--seed", type=int, default=1, help="seed of the gripper poses")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        run(Path(args.out or scratch), args.intrinsic_images, args.hand_images, args.seed)
