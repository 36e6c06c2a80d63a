"""Tag pose accuracy and decode time: OpenCV's ArUco module against pupil-apriltags.

Usage:
    python benchmarks/tag_detection.py [--frames 50] [--noise 2.0] [--seed 0] [--out results.json]
    python benchmarks/tag_detection.py --planar [--frames 50] [--noise 2.0] [--seed 0]

Synthetic 640 x 480 frames of one AprilTag 36h11 tag (3 cm) at a known pose: the tag image warped by
the homography of its pose (occrl.perception.synthetic: 4x supersampled, averaged down) over grey,
with Gaussian pixel noise (sigma ``--noise`` grey levels). The camera: 70 degrees across (the MuJoCo
wrist camera's), no distortion. The tag stands upright at ``--frames`` random bearings in view for
each distance (0.1-0.4 m along the optical axis) and viewing angle (0-60 degrees between the tag's
normal and the direction to the camera, turned about the vertical).

Per frame: the error of the tag's position (mm) and orientation (degrees, the angle of the rotation
between estimate and truth) in the camera frame, for

* ``opencv``: OpenCV ArUco (corner refinement subpix, occrl's default), the pose IPPE ranks best;
* ``opencv-edges``: the same with occrl's edge-fit refinement after subpix (``refine="edges"``);
* ``opencv-upright``: the same corners, of IPPE's two poses the one whose up axis is closest to the
  camera's (the rule occrl's TagDetector applies to objects standing on the shelf floor);
* ``pupil-apriltags``: the AprilTag 3 library's detector and pose (``quad_decimate`` 2, its default,
  and 1).

and the time per frame (one thread) to decode (the tag's corners) and to decode and estimate the
pose. A frame where the tag is not decoded counts as missed.

``--planar``: occrl's whole path instead, ``TagDetector.detect`` (the pose from the tag's own pose with
subpix and with edge-fitted corners, and the default: edge-fitted corners and the planar fit): a 4 x 4 cm
box with one 3 cm tag on a side (its centre 5 cm up) stands on the shelf floor, its tagged face
``--frames`` times at each distance from the camera and turned each viewing angle away from it, at a
random bearing in view, seen by the wrist camera (7 cm above the floor, looking along the shelf's
floor); the error of the reported planar pose: position (mm) and heading (degrees).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from importlib.metadata import version

import numpy as np

from occrl.perception import CameraModel, TagCatalogue, TagDetector
from occrl.perception.frames import rotation_angle_deg
from occrl.perception.opencv import require_opencv
from occrl.perception.synthetic import render_tags

DISTANCES = (0.1, 0.2, 0.3, 0.4)
ANGLES = (0.0, 20.0, 40.0, 60.0)
TAG_SIZE = 0.03
TAG_ID = 7
PUPIL_TO_OPENCV = np.diag([-1.0, 1.0, -1.0])
UPRIGHT = np.diag([1.0, -1.0, -1.0])  # tag frame facing the camera: x right, y up (camera -y), z towards the camera


def rotation_y(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])


def random_pose(camera: CameraModel, distance: float, angle: float, rng: np.random.Generator) -> np.ndarray:
    """A tag at ``distance`` along the optical axis, at a random bearing that keeps it in view, its
    normal ``angle`` degrees (random side) off the direction to the camera, about the vertical."""
    while True:  # until the tag and its white margin lie 5 pixels or more inside the image
        u = rng.uniform(0, camera.width - 1)
        v = rng.uniform(0, camera.height - 1)
        centre = np.array([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0]) * distance
        towards_camera = -centre / np.linalg.norm(centre)
        heading = math.degrees(math.atan2(-towards_camera[0], -towards_camera[2]))  # normal's turn making it face the camera
        pose = np.eye(4)
        pose[:3, :3] = rotation_y(heading + angle * rng.choice([-1.0, 1.0])) @ UPRIGHT
        pose[:3, 3] = centre
        half = TAG_SIZE * 10 / 8 / 2  # the margin is one cell of 8 a side
        outline = (np.array([[-half, half, 0.0], [half, half, 0.0], [half, -half, 0.0], [-half, -half, 0.0]]) @ pose[:3, :3].T) + centre
        px = outline[:, :2] / outline[:, 2:] * [camera.fx, camera.fy] + [camera.cx, camera.cy]
        if px.min() >= 5 and px[:, 0].max() <= camera.width - 6 and px[:, 1].max() <= camera.height - 6:
            return pose


def errors(truth: np.ndarray, rotation: np.ndarray, translation: np.ndarray) -> tuple[float, float]:
    position_mm = float(np.linalg.norm(translation - truth[:3, 3]) * 1e3)
    return position_mm, rotation_angle_deg(truth[:3, :3].T @ rotation)


def summary(values: list[float]) -> dict:
    if not values:
        return {"median": None, "p95": None}
    return {"median": float(np.median(values)), "p95": float(np.percentile(values, 95))}


def planar(args: argparse.Namespace) -> None:
    from occrl.perception import forward_looking_hand_camera, gripper_pose_matrix
    from occrl.perception.synthetic import render_objects

    camera = CameraModel.from_fov(640, 480, 70.0, hand_camera=forward_looking_hand_camera((0.0, 0.0, 0.025)))
    box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
    catalogue = TagCatalogue.from_dict(
        {
            "objects": [
                {
                    "type_id": 1,
                    "height": 0.1,
                    "footprint": box,
                    "tags": [{"tag_id": TAG_ID, "face": 0, "offset": [0.0, 0.05], "size": TAG_SIZE}],
                }
            ]
        }
    )
    detectors = {
        "subpix, tag pose": TagDetector(camera, catalogue, refine="subpix", planar_fit=False),
        "edges, tag pose": TagDetector(camera, catalogue, refine="edges", planar_fit=False),
        "edges, planar fit (default)": TagDetector(camera, catalogue),
    }
    gripper = gripper_pose_matrix(0.0, 0.0, 0.0, z=0.045)
    rng = np.random.default_rng(args.seed)
    found: dict[str, list[dict]] = {r: [] for r in detectors}
    half_fov = math.atan(camera.width / 2 / camera.fx)
    for distance in DISTANCES:
        for angle in ANGLES:
            for _ in range(args.frames):
                bearing = rng.uniform(-0.6, 0.6) * half_fov
                face = np.array([math.sin(bearing), math.cos(bearing)]) * distance  # the tag's centre, gripper at the origin
                # face 0's outward normal, the object's -y turned by theta, (sin theta, -cos theta), points
                # at the camera for theta = -bearing; then `angle` more
                theta = -bearing + math.radians(angle) * rng.choice([-1.0, 1.0])
                centre = face - np.array([-math.sin(theta), math.cos(theta)]) * -0.02
                truth = (float(centre[0]), float(centre[1]), theta)
                image = render_objects(camera, catalogue, [(1, truth)], gripper, noise_std=args.noise, rng=rng)
                for refine, detector in detectors.items():
                    detections = detector.detect(image, gripper)
                    record = {"distance_m": distance, "angle_deg": angle, "position_mm": [], "rotation_deg": [], "missed": 0}
                    if detections:
                        x, y, t = detections[0]["pose"]
                        record["position_mm"].append(math.hypot(x - truth[0], y - truth[1]) * 1e3)
                        record["rotation_deg"].append(abs(math.degrees((t - theta + math.pi) % (2 * math.pi) - math.pi)))
                    else:
                        record["missed"] = 1
                    found[refine].append(record)
    for key, values in (("distance_m", DISTANCES), ("angle_deg", ANGLES)):
        print(f"planar pose by {key} (pooled over the other), median / p95 position and heading:")
        for value in values:
            print(f"{value:g}: " + "; ".join(describe([r for r in found[m] if r[key] == value], m) for m in found))
    print("all frames: " + "; ".join(describe(found[m], m) for m in found))


def timed_opencv(detector: TagDetector, image: np.ndarray, entry, shelf_camera: np.ndarray, times: dict[str, list[float]]) -> list:
    """The tag's pose candidates in ``image`` (empty when it is not decoded); appends the decode
    time and the decode-and-pose time (s) to ``times``."""
    t0 = time.perf_counter()
    tags = [t for t in detector.detect_tags(image) if t["tag_id"] == TAG_ID]
    t1 = time.perf_counter()
    candidates = detector.tag_pose_candidates(entry, tags[0]["corners"], shelf_camera) if tags else []
    t2 = time.perf_counter()
    times["decode"].append(t1 - t0)
    times["decode_and_pose"].append(t2 - t0)
    return candidates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=50, help="frames per distance and viewing angle")
    parser.add_argument("--noise", type=float, default=2.0, help="Gaussian pixel noise (grey levels)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=None, help="write the figures as JSON")
    parser.add_argument("--planar", action="store_true", help="the planar pose through TagDetector.detect (OpenCV only)")
    args = parser.parse_args()
    cv2 = require_opencv()
    cv2.setNumThreads(1)
    if args.planar:
        planar(args)
        return
    try:
        import pupil_apriltags
    except ImportError:
        raise SystemExit("this comparison needs pupil-apriltags (not an occrl dependency): pip install pupil-apriltags") from None

    camera = CameraModel.from_fov(640, 480, 70.0)
    box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
    catalogue = TagCatalogue.from_dict(
        {
            "objects": [
                {
                    "type_id": 1,
                    "height": 0.1,
                    "footprint": box,
                    "tags": [{"tag_id": TAG_ID, "face": 0, "offset": [0.0, 0.05], "size": TAG_SIZE}],
                }
            ]
        }
    )
    entry = catalogue[TAG_ID]
    detector = TagDetector(camera, catalogue, refine="subpix")
    pupil = {d: pupil_apriltags.Detector(families="tag36h11", nthreads=1, quad_decimate=d) for d in (2.0, 1.0)}
    params = (camera.fx, camera.fy, camera.cx, camera.cy)
    # the camera's pose in a frame whose z is up, for the upright rule (the tag stands upright)
    shelf_camera = camera.hand_camera
    methods = ["opencv", "opencv-upright", "opencv-edges", "pupil-apriltags", "pupil-apriltags-decimate1"]
    edges = TagDetector(camera, catalogue, refine="edges")
    rng = np.random.default_rng(args.seed)
    records: dict[str, list[dict]] = {m: [] for m in methods}
    times = {m: {"decode": [], "decode_and_pose": []} for m in ("opencv", "opencv-edges", "pupil-apriltags", "pupil-apriltags-decimate1")}
    for distance in DISTANCES:
        for angle in ANGLES:
            found = {m: {"position_mm": [], "rotation_deg": [], "missed": 0} for m in methods}
            for _ in range(args.frames):
                truth = random_pose(camera, distance, angle, rng)
                image = render_tags(camera, [(TAG_ID, truth, TAG_SIZE)], noise_std=args.noise, rng=rng, rgb=False)
                candidates = timed_opencv(detector, image, entry, shelf_camera, times["opencv"])
                if candidates:
                    best = candidates[0].camera_tag
                    upright = min(candidates, key=lambda c: float(np.arccos(np.clip(c.shelf_object[2, 2], -1, 1)))).camera_tag
                    for name, pose in (("opencv", best), ("opencv-upright", upright)):
                        p, r = errors(truth, pose[:3, :3], pose[:3, 3])
                        found[name]["position_mm"].append(p)
                        found[name]["rotation_deg"].append(r)
                else:
                    found["opencv"]["missed"] += 1
                    found["opencv-upright"]["missed"] += 1
                candidates = timed_opencv(edges, image, entry, shelf_camera, times["opencv-edges"])
                if candidates:
                    p, r = errors(truth, candidates[0].camera_tag[:3, :3], candidates[0].camera_tag[:3, 3])
                    found["opencv-edges"]["position_mm"].append(p)
                    found["opencv-edges"]["rotation_deg"].append(r)
                else:
                    found["opencv-edges"]["missed"] += 1
                for decimate, name in ((2.0, "pupil-apriltags"), (1.0, "pupil-apriltags-decimate1")):
                    t0 = time.perf_counter()
                    pupil[decimate].detect(image)
                    t1 = time.perf_counter()
                    result = [d for d in pupil[decimate].detect(image, True, params, TAG_SIZE) if d.tag_id == TAG_ID]
                    t2 = time.perf_counter()
                    times[name]["decode"].append(t1 - t0)
                    times[name]["decode_and_pose"].append(t2 - t1)
                    if result:
                        # pupil-apriltags' tag frame is OpenCV's turned half a turn about its y axis
                        p, r = errors(truth, result[0].pose_R @ PUPIL_TO_OPENCV, result[0].pose_t.reshape(3))
                        found[name]["position_mm"].append(p)
                        found[name]["rotation_deg"].append(r)
                    else:
                        found[name]["missed"] += 1
            for m in methods:
                records[m].append({"distance_m": distance, "angle_deg": angle, **found[m]})
            print(f"{distance:.1f} m {angle:4.0f} deg: " + "; ".join(describe(records[m][-1:], m) for m in methods), flush=True)
    timing = {m: {k: float(np.median(v) * 1e3) for k, v in t.items()} for m, t in times.items()}
    tables = {}
    for key, values in (("distance_m", DISTANCES), ("angle_deg", ANGLES)):
        print(f"\nby {key} (pooled over the other), median / p95:")
        for value in values:
            print(f"{value:g}: " + "; ".join(describe([r for r in records[m] if r[key] == value], m) for m in methods))
            for m in methods:
                tables.setdefault(f"by_{key}", {}).setdefault(str(value), {})[m] = pooled([r for r in records[m] if r[key] == value])
    print("\nall frames: " + "; ".join(describe(records[m], m) for m in methods))
    print(
        "median ms per frame (one thread): "
        + "; ".join(f"{m} decode {t['decode']:.2f}, with pose {t['decode_and_pose']:.2f}" for m, t in timing.items())
    )
    if args.out:
        record = {
            "command": f"python benchmarks/tag_detection.py --frames {args.frames} --noise {args.noise} --seed {args.seed}",
            "opencv": cv2.__version__,
            "pupil_apriltags": version("pupil-apriltags"),
            "all": {m: pooled(records[m]) for m in methods},
            **tables,
            "time_ms": timing,
        }
        with open(args.out, "w") as f:
            json.dump(record, f, indent=1)


def pooled(records: list[dict]) -> dict:
    position = [p for r in records for p in r["position_mm"]]
    rotation = [a for r in records for a in r["rotation_deg"]]
    return {
        "position_mm": summary(position),
        "rotation_deg": summary(rotation),
        "missed": sum(r["missed"] for r in records),
        "frames": len(position) + sum(r["missed"] for r in records),
    }


def describe(records: list[dict], name: str) -> str:
    s = pooled(records)
    if s["position_mm"]["median"] is None:
        return f"{name} all missed"
    text = f"{name} {s['position_mm']['median']:.1f}/{s['position_mm']['p95']:.1f} mm {s['rotation_deg']['median']:.2f}/{s['rotation_deg']['p95']:.2f} deg"
    return text + (f" ({s['missed']}/{s['frames']} missed)" if s["missed"] else "")


if __name__ == "__main__":
    main()
