"""MujocoShelfEnv speed on one core: physics per action and camera visibility per observation.

Usage:
    python benchmarks/mujoco_env_speed.py [--stage 2] [--steps 40] [--height 120 --width 160]

Prints the physics ms per action (one quasi-static action: finger phase when the command changes,
0.5 s motion, 0.2 s settling at a 2 ms time step), the ms per observation of each visibility
backend (segmentation render, mj_multiRay; both include the exact per-object denominator, which
is also printed alone), and the whole ``env.step`` (physics + visibility + observation assembly)
at B = 1 for each backend, with the cost of a reset (model compilation, GL context) apart. The render backend needs an OpenGL backend (EGL headless works).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch

from occrl.envs import MujocoShelfEnv, Scene
from occrl.envs.mujoco3d.camera import CameraConfig, gl_available
from occrl.envs.mujoco3d.world import MujocoWorld


def _worlds(stage: int, camera: CameraConfig, visibility: str, n: int = 4) -> list[MujocoWorld]:
    return [MujocoWorld(Scene.sample(stage, seed=s), camera=camera, visibility=visibility) for s in range(n)]


def physics_ms(stage: int, steps: int, camera: CameraConfig) -> float:
    rng = np.random.default_rng(0)
    worlds = _worlds(stage, camera, "rays")
    actions = rng.uniform(-1, 1, (steps, 4))
    t = time.perf_counter()
    for k in range(steps):
        worlds[k % len(worlds)].step(actions[k])
    return (time.perf_counter() - t) / steps * 1e3


def visibility_ms(stage: int, steps: int, camera: CameraConfig, method: str) -> tuple[float, float]:
    """(ms per visible_fractions call, ms of the analytic denominator alone), over moved cameras."""
    rng = np.random.default_rng(1)
    worlds = _worlds(stage, camera, method)
    for w in worlds:
        w.step(np.r_[rng.uniform(-1, 1, 3), -1.0])
        w.visible_fractions(method)  # warm up (first GL frame)
    t_all = t_den = 0.0
    for k in range(steps):
        w = worlds[k % len(worlds)]
        t0 = time.perf_counter()
        w.visible_fractions(method)
        t1 = time.perf_counter()
        w.alone_pixels()
        t2 = time.perf_counter()
        t_all += t1 - t0
        t_den += t2 - t1
    for w in worlds:
        w.close()
    return t_all / steps * 1e3, t_den / steps * 1e3


def env_step_ms(stage: int, steps: int, camera: CameraConfig, visibility: str) -> tuple[float, float]:
    """(ms per env.step, ms per reset) at B = 1 with random actions; resets (building the MuJoCo
    model and, for rendering, a GL context) are timed apart from steps."""
    env = MujocoShelfEnv(batch_size=1, stage=stage, seed=0, visibility=visibility, camera_size=(camera.height, camera.width))
    g = torch.Generator().manual_seed(0)
    t_step = t_reset = 0.0
    resets = 0
    t0 = time.perf_counter()
    td = env.reset()
    t_reset += time.perf_counter() - t0
    resets += 1
    for _ in range(steps):
        td["action"] = torch.rand(1, 4, generator=g) * 2 - 1
        t0 = time.perf_counter()
        td = env.step_mdp(env.step(td))
        t_step += time.perf_counter() - t0
        if td["done"].any():
            t0 = time.perf_counter()
            td = env.reset()
            t_reset += time.perf_counter() - t0
            resets += 1
    env.close()
    return t_step / steps * 1e3, t_reset / resets * 1e3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--stage", type=int, default=2)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--width", type=int, default=160)
    args = ap.parse_args()
    torch.set_num_threads(1)
    camera = CameraConfig(height=args.height, width=args.width)
    ok, why = gl_available()
    print(f"stage {args.stage}, camera {camera.width}x{camera.height}, OpenGL: {why if ok else 'none (' + why + ')'}")
    print(f"physics            {physics_ms(args.stage, args.steps, camera):7.2f} ms per action")
    methods = ["rays"] + (["render"] if ok else [])
    for m in methods:
        total, den = visibility_ms(args.stage, args.steps, camera, m)
        print(f"visibility {m:7s} {total:7.2f} ms per observation (of which {den:.2f} ms exact denominator)")
    for m in methods:
        step, reset = env_step_ms(args.stage, args.steps, camera, m)
        print(f"env.step   {m:7s} {step:7.2f} ms per step (B = 1, physics + visibility + assembly); reset {reset:.1f} ms")


if __name__ == "__main__":
    main()
