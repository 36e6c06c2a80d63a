"""How much of the target's position does the network's image hold? The scripted retriever, told
where the target is only as well as a robot-centric image of it shows.

    python scripts/image_limited_retriever.py --stage 2 --tasks 200 --size 64 [--window 0.8] [--canvas-mm 8]
        [--fovea-size 64 --fovea-window 0.4 --fovea-offset 0.1] [--baseline F.json] [--out F.json]

The privileged scripted retriever (`occrl eval --method scripted`) reads the target's true pose.
Here, from the first time the target shows in the image on, its position is replaced by what
the image says: the mean of the pixel centres labelled "target" in a robot-centric window drawn
from the detections (the network input's pipeline, :func:`occrl.envs.render.render_labels_at`),
shifted by the known offset between the target shape's area centroid and its pose (the shape is
part of every observation; the orientation is taken as true: only the position is read). While
the target is out of the image the last reading's error is kept. Before the first sight the
retriever keeps its privilege: the test is of the retrieval, not of the search. It also decides
when to close from the estimated position (the rule: the target alone between the fingers).

``--size`` / ``--window`` / ``--canvas-mm``: the window's pixels a side, its width in metres and
the resolution of the shelf-frame label map it samples (the network's input: 64 px over 0.8 m
of an 8 mm map). ``--fovea-size`` etc.: a second, finer window ahead of the gripper, read
instead of the first whenever the whole target shows in it (no target pixel on its border).

Against the retriever's own episodes (``--baseline``, an `occrl eval --method scripted --out`
file of the same tasks) it prints the tasks only one solved and the exact McNemar p-value. A
diagnosis for issue 16 (docs/decisions.md): it reads ``"privileged"``, so it is analysis, never
a method.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from tqdm import tqdm

from occrl.baselines import ScriptedRetriever
from occrl.envs.episodes import run_episodes, task_scenes
from occrl.envs.geometry import polygon_centroid, transform_polygons
from occrl.envs.perception import detected_polygons
from occrl.envs.render import LABELS, Canvas, render_labels_at
from occrl.envs.robot_frame import DEFAULT_FORWARD_OFFSET, DEFAULT_SIZE, DEFAULT_WINDOW, robot_centric_points
from occrl.eval.runner import EVAL_SEED_BASE, paired_with, summarize


class ImageLimitedRetriever(TensorDictModuleBase):
    """:class:`~occrl.baselines.ScriptedRetriever` with the target's position read from images
    (``windows``: (size px, width m, forward offset m), the first the coarse one; later ones are
    read instead whenever the target shows in them)."""

    in_keys = ["gripper_pose", "gripper_opening", "gripper_closed", "is_init", "objects", "target_type", "privileged"]
    out_keys = ["action"]

    def __init__(self, windows: list[tuple[int, float, float]], canvas: Canvas) -> None:
        super().__init__()
        self.windows, self.canvas = windows, canvas
        self.retriever = ScriptedRetriever()
        self.error: dict[int, np.ndarray] = {}  # per world: the last reading's error of the target's position

    def reset(self) -> None:
        self.retriever.reset()
        self.error.clear()

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        poses32 = flat.get("gripper_pose").cpu().numpy()
        gripper = poses32.astype(float)
        polygons = detected_polygons(flat)
        readings = []  # per window: the points of its pixels and their labels
        for size, width, offset in self.windows:
            points = robot_centric_points(gripper, width, size, offset)
            labels = render_labels_at(poses32, flat.get("gripper_opening").cpu().numpy(), polygons, points, self.canvas)
            target = labels == LABELS["target"]
            edge = np.zeros_like(target)  # the target cut by the window's border would read off-centre
            edge[:, [0, -1], :] = edge[:, :, [0, -1]] = True
            readings.append((points, target, (target & edge).any(axis=(1, 2))))
        privileged = flat.get("privileged").clone()
        poses = privileged.get("object_pose").cpu().numpy().astype(float)
        vertices = privileged.get("object_vertices").cpu().numpy().astype(float)
        counts = privileged.get("object_num_vertices").cpu().numpy()
        slot = privileged.get("target_slot").cpu().numpy().reshape(-1)
        first = flat.get("is_init").cpu().numpy().reshape(-1)
        for b in range(flat.shape[0]):
            if first[b]:
                self.error.pop(b, None)
            k = slot[b]
            for i, (points, target, cut) in reversed(list(enumerate(readings))):
                # the finest window that shows the whole target (the first one: any part of it)
                if target[b].any() and (i == 0 or not cut[b]):
                    truth = polygon_centroid(transform_polygons(vertices[b, k, : counts[b, k]], poses[b, k]))
                    self.error[b] = points[b][target[b]].mean(axis=0) - truth
                    break
            if b in self.error:
                poses[b, k, :2] += self.error[b]
        privileged.set("object_pose", torch.as_tensor(poses, dtype=privileged.get("object_pose").dtype))
        view = flat.select("gripper_pose", "gripper_opening", "gripper_closed").clone()
        view.set("privileged", privileged)
        self.retriever(view)
        tensordict.set("action", view.get("action").reshape(*tensordict.shape, -1))
        return tensordict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=200)
    parser.add_argument("--size", type=int, default=DEFAULT_SIZE, help="pixels a side of the window (default: the network's 64)")
    parser.add_argument("--window", type=float, default=DEFAULT_WINDOW, help="its width in metres (default 0.8)")
    parser.add_argument("--offset", type=float, default=DEFAULT_FORWARD_OFFSET, help="its centre ahead of the gripper, m (default 0.15)")
    parser.add_argument(
        "--canvas-mm", type=float, default=8.0, help="the shelf-frame label map's resolution (default: the pipeline's 8 mm)"
    )
    parser.add_argument("--fovea-size", type=int, default=None, help="pixels a side of a second, finer window")
    parser.add_argument("--fovea-window", type=float, default=0.4, help="its width in metres")
    parser.add_argument("--fovea-offset", type=float, default=0.1, help="its centre ahead of the gripper, m")
    parser.add_argument("--baseline", default=None, help="an `occrl eval --method scripted --out` file of the same tasks")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    if args.size < 8 or args.window <= 0 or args.canvas_mm <= 0:
        parser.error("--size must be >= 8 pixels and --window and --canvas-mm positive")
    torch.set_num_threads(1)
    windows = [(args.size, args.window, args.offset)]
    name = f"scripted reading the target from {args.size} px over {args.window:g} m"
    if args.fovea_size:
        windows.append((args.fovea_size, args.fovea_window, args.fovea_offset))
        name += f" and {args.fovea_size} px over {args.fovea_window:g} m"
    name += f" ({args.canvas_mm:g} mm map)"
    retriever = ImageLimitedRetriever(windows, Canvas(resolution=args.canvas_mm / 1000))
    seeds = list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + args.tasks))
    t0 = time.time()
    results = []
    for start in tqdm(range(0, len(seeds), 25), desc=name, unit="batch"):
        chunk = seeds[start : start + 25]
        retriever.reset()
        results += run_episodes(retriever, task_scenes(args.stage, chunk), chunk, 0.0, len(chunk))
    summary = summarize(results)
    lo, hi = summary["success_ci95"]
    print(
        f"{name}, stage {args.stage}: {100 * summary['success_rate']:.1f} % "
        f"({100 * lo:.1f}-{100 * hi:.1f}) of {len(results)} tasks, {summary['dropped']} dropped; {time.time() - t0:.0f} s"
    )
    report = {"stage": args.stage, "windows": windows, "canvas_mm": args.canvas_mm, **summary}
    report["episodes"] = [r.to_dict() for r in results]
    if args.baseline:
        pair = paired_with(report["episodes"], json.loads(open(args.baseline).read())["episodes"])
        print(
            f"reading the true pose on the same {pair['tasks']} tasks: {100 * pair['baseline_success_rate']:.1f} %; solved only "
            f"from the image: {pair['only_run']}, only from the true pose: {pair['only_baseline']} (McNemar p = {pair['p']:.3f})"
        )
        report["baseline"] = {"file": args.baseline, **pair}
    if args.out:
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
