"""Training throughput on this machine: frames/s for collection alone and collection + update.

Usage:
    python benchmarks/train_throughput.py [--iterations 3] [--envs 32] [--collectors single,multi,ray]

Measures the paper network with the `cpu` training preset settings (PPO update, 2 epochs) for a
single-process Collector, a 2-worker MultiSyncCollector and a 2-worker RayCollector on a local Ray
runtime (needs ``pip install "occrl[ray]"``). The first iteration (worker start-up) is not counted.
Also prints the update's time per frame by part (advantages, PPO epochs, batch-norm refresh) and
the throughput bound it sets: the update runs on every core while collection waits, so no
collector can take the end-to-end rate above 1 / (update time per frame).
"""

from __future__ import annotations

import argparse
import tempfile
import time

import torch

from occrl.objectives import compute_advantages
from occrl.training import Trainer, get_train_config


def measure(collector: str, envs: int, iterations: int) -> tuple[float, float, dict]:
    """Frames/s of collection alone and of collection + update, and seconds per frame of each
    part of the update (batch-norm refresh, advantages, the PPO epochs)."""
    cfg = get_train_config("cpu", collector=collector, num_envs=envs, imitation_iters=0)
    trainer = Trainer(cfg, tempfile.mkdtemp(), seed=0, progress=False, tensorboard=False, checkpoint_every_s=1e9)
    parts = {"advantages": 0.0, "ppo_epochs": 0.0, "batch_norm": 0.0}
    try:
        trainer._collect()  # start-up
        collect_s = total_s = 0.0
        frames = 0
        for _ in range(iterations):
            t0 = time.time()
            data = trainer._collect()
            t1 = time.time()
            compute_advantages(trainer.net, data)
            t2 = time.time()
            trainer.learner.update(data, "ppo")
            t3 = time.time()
            trainer.learner.refresh_batch_norm(data)
            t4 = time.time()
            parts["advantages"] += t2 - t1
            parts["ppo_epochs"] += t3 - t2
            parts["batch_norm"] += t4 - t3
            collect_s += t1 - t0
            total_s += t4 - t0
            frames += data.numel()
        return frames / collect_s, frames / total_s, {k: v / frames for k, v in parts.items()}
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
        c, t, parts = measure(collector, args.envs, args.iterations)
        print(f"{collector:>6} collector: collection {c:6.0f} frames/s, collection + update {t:6.0f} frames/s")
        update = sum(parts.values())
        detail = ", ".join(f"{k} {v * 1e3:.2f}" for k, v in parts.items())
        # the update uses every core while the collector workers wait (synchronous collection), so
        # even a collection that took no time at all could not exceed 1 / (update time per frame)
        print(f"{'':>6}   update per frame {update * 1e3:.2f} ms ({detail}); bound with free collection {1 / update:6.0f} frames/s")


if __name__ == "__main__":
    main()
