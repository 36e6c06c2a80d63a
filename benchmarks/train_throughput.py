"""Training throughput on this machine: frames/s for collection alone and collection + update.

Usage:
    python benchmarks/train_throughput.py [--iterations 3] [--envs 32] [--collectors single,multi,ray]

Measures the paper network with the `cpu` training preset settings (PPO update, 2 epochs) for a
single-process Collector, a 2-worker MultiSyncCollector and a 2-worker RayCollector on a local Ray
runtime (needs ``pip install "occrl[ray]"``). The first iteration (worker start-up) is not counted.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import torch

from occrl.training import Trainer, get_train_config


def measure(collector: str, envs: int, iterations: int) -> tuple[float, float]:
    cfg = get_train_config("cpu", collector=collector, num_envs=envs, imitation_iters=0)
    trainer = Trainer(cfg, tempfile.mkdtemp(), seed=0, progress=False, tensorboard=False, checkpoint_every_s=1e9)
    try:
        trainer._collect()  # start-up
        collect_s = total_s = 0.0
        frames = 0
        for _ in range(iterations):
            t0 = time.time()
            data = trainer._collect()
            t1 = time.time()
            trainer._refresh_batch_norm(data)
            from occrl.objectives import compute_advantages

            compute_advantages(trainer.net, data)
            trainer._update(data, "ppo")
            t2 = time.time()
            collect_s += t1 - t0
            total_s += t2 - t0
            frames += data.numel()
        return frames / collect_s, frames / total_s
    finally:
        trainer.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=3)
    parser.add_argument("--envs", type=int, default=32)
    parser.add_argument("--collectors", default="single,multi,ray")
    args = parser.parse_args()
    print(f"paper network, cpu preset PPO update, {args.envs} envs x 50 steps per batch, torch threads {torch.get_num_threads()}")
    for collector in args.collectors.split(","):
        c, t = measure(collector, args.envs, args.iterations)
        print(f"{collector:>6} collector: collection {c:6.0f} frames/s, collection + update {t:6.0f} frames/s")


if __name__ == "__main__":
    main()
