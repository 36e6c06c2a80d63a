"""Training on a GPU: frames per second for collection and for the update, against the CPU update.

Usage (a prepared check, under 8 minutes on a GPU machine):
    python benchmarks/gpu_training.py [--device cuda] [--preset paper] [--collector multi --workers 8]
                                      [--iterations 6] [--cpu-iterations 2]

Trains the preset (PPO from scratch, the paper network with its heat-map loss) for a few iterations
with the network and the loss on ``--device`` and the collectors on the CPU (``TrainConfig.device``),
then the same preset on the CPU, in the same process. For each it prints frames/s of collection
and of the update (advantages, PPO epochs, batch-norm refresh) from the run's own metrics (the
first iteration, with the workers' start-up, is not counted), and the ratio of the update speeds.
On a machine without CUDA, ``--device cuda`` stops with the trainer's error.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import torch

from occrl.training import Trainer, get_train_config
from occrl.training.plots import read_metrics


def measure(preset: str, device: str, collector: str, workers: int, num_envs: int | None, iterations: int) -> dict:
    overrides = {"device": device, "collector": collector, "workers": workers, "imitation_iters": 0}
    if num_envs:
        overrides["num_envs"] = num_envs
    cfg = get_train_config(preset, **overrides)
    run = tempfile.mkdtemp()
    trainer = Trainer(cfg, run, seed=0, progress=False, tensorboard=False, checkpoint_every_s=1e9)
    t0 = time.time()
    try:
        trainer.train(iterations=iterations + 1)
    finally:
        trainer.close()
    rows = read_metrics(os.path.join(run, "metrics.jsonl"))
    steps = [(r["frames"] - p["frames"], r) for p, r in zip(rows, rows[1:])]  # without the start-up iteration
    frames = sum(n for n, _ in steps)
    total_s = sum(n / r["fps"] for n, r in steps)
    collect_s = sum(n / r["collect_fps"] for n, r in steps)
    update_s = total_s - collect_s
    return {
        "device": device,
        "frames": frames,
        "wall_s": time.time() - t0,
        "end_to_end_fps": frames / total_s,
        "collect_fps": frames / collect_s,
        "update_fps": frames / update_s,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--collector", default="multi", choices=["single", "multi"])
    parser.add_argument("--workers", type=int, default=min(8, max(1, (os.cpu_count() or 2) // 2)))
    parser.add_argument("--num-envs", type=int, default=None, help="default: the preset's, rounded to a multiple of --workers")
    parser.add_argument("--iterations", type=int, default=6)
    parser.add_argument("--cpu-iterations", type=int, default=2, help="0: skip the CPU reference")
    args = parser.parse_args()
    num_envs = args.num_envs
    if num_envs is None and args.collector == "multi":
        base = get_train_config(args.preset).num_envs
        num_envs = max(args.workers, base // args.workers * args.workers)
    gpu = torch.cuda.get_device_name(torch.device(args.device)) if args.device.startswith("cuda") and torch.cuda.is_available() else "-"
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, accelerator: {gpu}, torch {torch.__version__}")
    print(f"preset {args.preset}, collector {args.collector} x {args.workers} workers, {num_envs or 'preset'} envs")
    results = [measure(args.preset, args.device, args.collector, args.workers, num_envs, args.iterations)]
    if args.cpu_iterations > 0 and args.device != "cpu":
        results.append(measure(args.preset, "cpu", args.collector, args.workers, num_envs, args.cpu_iterations))
    print("| device | frames | collection frames/s | update frames/s | end to end frames/s |")
    print("| --- | --- | --- | --- | --- |")
    for r in results:
        print(f"| {r['device']} | {r['frames']} | {r['collect_fps']:.0f} | {r['update_fps']:.0f} | {r['end_to_end_fps']:.0f} |")
    if len(results) == 2:
        print(f"update speed {results[0]['device']} / cpu: {results[0]['update_fps'] / results[1]['update_fps']:.2f}x (same run)")


if __name__ == "__main__":
    main()
