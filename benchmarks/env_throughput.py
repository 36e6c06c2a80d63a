"""Env throughput on one core: physics, perception + rendering, and the full TorchRL pipeline.

Usage:
    python benchmarks/env_throughput.py [--stage 2] [--steps 60]

Prints physics ms per action with the default physics and with occrl 0.1.0's
(``LEGACY_PHYSICS``) side by side, alternated in rounds in this run (their ratio is the cost of
the physics-validity change), detection + render ms per observation, ShelfEnv + transforms
steps/s at B = 1, 16, 64, and the share of step time outside physics and rendering (TorchRL /
tensordict overhead and observation assembly).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch

from occrl.envs import DEFAULT_PHYSICS, LEGACY_PHYSICS, PhysicsSettings, Scene, ShelfWorld, make_env
from occrl.envs.render import DEFAULT_CANVAS, render_labels
from occrl.envs.robot_frame import robot_centric_points
from occrl.envs.visibility import detect, visible_fractions
from occrl.envs.shelf_geometry import wall_polygons


def physics_ms(stage: int, n: int, physics: PhysicsSettings = DEFAULT_PHYSICS) -> float:
    rng = np.random.default_rng(0)
    worlds = [ShelfWorld(Scene.sample(stage, seed=s), physics=physics) for s in range(8)]
    actions = rng.uniform(-1, 1, (n, 4))
    t = time.perf_counter()
    for k in range(n):
        worlds[k % len(worlds)].step(actions[k])
    return (time.perf_counter() - t) / n * 1e3


def physics_old_and_new(stage: int, n: int, rounds: int = 5) -> tuple[float, float, float]:
    """Median ms per action of the default and the 0.1.0 physics, and the median of the per-round
    ratios, the two alternated in ``rounds`` rounds of ``n`` actions on the same shelves."""
    new, old = [], []
    for _ in range(rounds):
        new.append(physics_ms(stage, n))
        old.append(physics_ms(stage, n, LEGACY_PHYSICS))
    ratio = float(np.median(np.array(new) / np.array(old)))
    return float(np.median(new)), float(np.median(old)), ratio


def perception_ms(stage: int, n: int) -> tuple[float, float]:
    walls = wall_polygons()
    worlds = [ShelfWorld(Scene.sample(stage, seed=s)) for s in range(8)]
    for w in worlds:
        w.step([1.0, 0.0, 0.0, -1.0])
    det_t = ren_t = 0.0
    for k in range(n):
        w = worlds[k % len(worlds)]
        t0 = time.perf_counter()
        polys = w.object_world_polygons()
        d = detect(visible_fractions(polys, w.gripper_pose(), walls))
        t1 = time.perf_counter()
        labels = render_labels(
            w.gripper_pose(), w.opening, [p for p, x in zip(polys, d) if x], [i == w.target_index for i, x in enumerate(d) if x]
        )
        DEFAULT_CANVAS.lookup(labels, robot_centric_points(w.gripper_pose()))
        t2 = time.perf_counter()
        det_t += t1 - t0
        ren_t += t2 - t1
    return det_t / n * 1e3, ren_t / n * 1e3


def pipeline_steps_per_s(batch: int, stage: int, steps: int) -> float:
    env = make_env(batch_size=batch, stage=stage, seed=0)
    g = torch.Generator().manual_seed(0)

    def policy(tensordict):
        return tensordict.set("action", torch.rand(batch, 4, generator=g) * 2 - 1)

    env.rollout(3, policy, break_when_any_done=False)
    t = time.perf_counter()
    env.rollout(steps, policy, break_when_any_done=False)
    return batch * steps / (time.perf_counter() - t)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=int, default=2)
    parser.add_argument("--steps", type=int, default=60)
    args = parser.parse_args()
    torch.set_num_threads(1)
    phys, old, ratio = physics_old_and_new(args.stage, 400)
    det, ren = perception_ms(args.stage, 2000)
    print(f"stage {args.stage} scenes, one core")
    print(f"physics:                 {phys:.3f} ms per action (occrl 0.1.0's physics {old:.3f} ms; {ratio:.2f}x, same run)")
    print(f"detection (visibility):  {det:.3f} ms per observation")
    print(f"render + crop:           {ren:.3f} ms per observation")
    for batch in (1, 16, 64):
        sps = pipeline_steps_per_s(batch, args.stage, args.steps if batch > 1 else 4 * args.steps)
        per_step_ms = 1e3 / sps
        outside = 1.0 - (phys + det + ren) / per_step_ms
        print(
            f"B={batch:3d}: {sps:7.0f} env steps/s ({per_step_ms:.3f} ms/step; {100 * max(outside, 0):.0f} % outside physics, detection and rendering)"
        )


if __name__ == "__main__":
    main()
