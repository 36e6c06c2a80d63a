"""The hybrid-acting teacher's collection: frames (= planner decisions) per second with the
planner's network on torch and on ONNX Runtime, alternated in one run.

Usage:
    python benchmarks/hybrid_teacher_throughput.py [--rounds 3] [--steps 10] [--num-envs 8]

Builds the trainer of the hybrid-acting run (`cpu-curriculum`, ``imitation_teacher="hybrid-acting"``,
collector "single", stage 2, from ``--weights``, default ``occnet``) twice, once per ``teacher_inference``, and times
``--rounds`` collections of ``--num-envs`` x ``--steps`` frames with each, alternating so that
both see the same machine load (its speed varies 2-3x between runs; compare the ratio). The same
iteration seed is collected by both, so they act in the same tasks. One thread (OMP_NUM_THREADS=1).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch

from occrl.pretrained import weights_file
from occrl.training import Trainer, get_train_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=10, help="steps per world and collection")
    parser.add_argument("--num-envs", type=int, default=8)
    parser.add_argument(
        "--weights", default="occnet", help="a weights file or a shipped network's name (occnet-warmstart: the default before 0.3.0)"
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    trainers = {}
    with tempfile.TemporaryDirectory() as tmp:
        for backend in ("torch", "onnxruntime"):
            cfg = get_train_config(
                "cpu-curriculum",
                imitation_teacher="hybrid-acting",
                collector="single",
                replay_stage_workers=0,
                num_envs=args.num_envs,
                steps_per_env=args.steps,
                start_stage=2,
                teacher_inference=backend,
            )
            trainers[backend] = Trainer(
                cfg, f"{tmp}/{backend}", seed=0, progress=False, tensorboard=False, init_weights=weights_file(args.weights)
            )
        seconds: dict[str, list[float]] = {b: [] for b in trainers}
        success: dict[str, list[float]] = {b: [] for b in trainers}
        for r in range(args.rounds):
            for backend, tr in trainers.items():
                tr.iteration = r  # the same iteration seed (tasks, noise) for both
                t0 = time.perf_counter()
                data = tr._collect()
                seconds[backend].append(time.perf_counter() - t0)
                done = data["next", "done"].squeeze(-1)
                success[backend].append(float(data["next", "success"].squeeze(-1)[done].float().mean()) if done.any() else float("nan"))
        for tr in trainers.values():
            tr.close()
    frames = args.num_envs * args.steps
    print(f"{frames} frames per collection, {args.rounds} rounds, one thread")
    print("| inference | frames/s (median) | seconds per collection | success of finished episodes |")
    print("| --- | --- | --- | --- |")
    for backend in trainers:
        s = np.array(seconds[backend])
        finished = [x for x in success[backend] if not np.isnan(x)]
        rate = f"{np.mean(finished):.2f}" if finished else "-"
        print(f"| {backend} | {frames / np.median(s):.1f} | {', '.join(f'{x:.1f}' for x in s)} | {rate} |")
    ratio = np.array(seconds["torch"]) / np.array(seconds["onnxruntime"])
    print(f"ONNX Runtime / torch frames/s, per round: {', '.join(f'{x:.2f}x' for x in ratio)} (median {np.median(ratio):.2f}x)")


if __name__ == "__main__":
    main()
