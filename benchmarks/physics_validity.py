"""Physics validity against cost: penetration under adversarial pushing for several settings.

Usage:
    python benchmarks/physics_validity.py [--states 1250] [--cost-actions 400] [--mujoco 0]

For each setting: the share of states with an overlap deeper than 2 mm and 5 mm, the worst
overlap and the number of states with an object beyond a wall, over stages 2 and 3 at noise 0
and 0.25 (``--states`` per cell, the same shelves and actions for every setting), and the
physics time per action relative to occrl 0.1.0's settings (``legacy``), measured in this run
on the same shelves, alternating the settings in rounds so that a change in the machine's
speed falls on both. ``--mujoco N`` also pushes the MuJoCo world N times per cell (a
reference point; needs the mujoco extra). Source of the table in docs/lab/environment.md
("Physics validity").
"""

from __future__ import annotations

import argparse
import gc
import os
import time
from dataclasses import replace

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from occrl.envs import Scene, ShelfWorld
from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, LEGACY_PHYSICS, PYMUNK_COLLISION_BIAS, PhysicsSettings
from occrl.envs.pymunk2d.physics_validity import adversarial_pushing, pymunk_world_factory

# From occrl 0.1.0's settings towards the default, one change at a time, and the neighbours of
# the default in step count.
_OLD_GRIPPER = dict(gripper_mass=0.5, gripper_max_force=20.0, gripper_max_torque=2.0)
_STEPS_1 = dict(substeps=10, contact_substeps=1)
SETTINGS = {
    "legacy (0.1.0)": LEGACY_PHYSICS,
    "slop 0.5 mm": PhysicsSettings(**_STEPS_1, collision_bias=PYMUNK_COLLISION_BIAS, finger_contact=False, **_OLD_GRIPPER),
    "+ 40 steps": PhysicsSettings(
        substeps=40, contact_substeps=1, collision_bias=PYMUNK_COLLISION_BIAS, finger_contact=False, **_OLD_GRIPPER
    ),
    "+ fingers stop at contact": PhysicsSettings(substeps=40, contact_substeps=1, collision_bias=PYMUNK_COLLISION_BIAS, **_OLD_GRIPPER),
    "+ 10 g gripper, 0.4 N": PhysicsSettings(substeps=40, contact_substeps=1, collision_bias=PYMUNK_COLLISION_BIAS),
    "+ bias 1e-7 (40 steps)": PhysicsSettings(substeps=40, contact_substeps=1),
    "30 steps, x2 in contact": PhysicsSettings(substeps=30, contact_substeps=2),
    "20 steps, x3 in contact": PhysicsSettings(substeps=20, contact_substeps=3),
    "60 steps": PhysicsSettings(substeps=60, contact_substeps=1),
    "default: 40 steps, x2 in contact": DEFAULT_PHYSICS,
}
CELLS = [(2, 0.0), (2, 0.25), (3, 0.0), (3, 0.25)]


def cost_ratios(settings: dict[str, PhysicsSettings], actions: int, rounds: int = 5) -> dict[str, float]:
    """Physics seconds per action of each setting over the legacy one, same shelves and actions,
    settings alternated in ``rounds`` rounds; the median of the per-round ratios."""
    rng = np.random.default_rng(0)
    plan = rng.uniform(0.5, 1.0, (actions, 4)) * rng.choice([-1.0, 1.0], (actions, 4))
    scenes = [Scene.sample(2 + s % 2, seed=s) for s in range(8)]
    per_round: dict[str, list[float]] = {name: [] for name in settings}
    for _ in range(rounds):
        for name, physics in settings.items():
            worlds = [ShelfWorld(sc, physics=physics) for sc in scenes]
            snaps = [w.snapshot() for w in worlds]
            gc.collect()
            gc.disable()
            t = time.perf_counter()
            for k, a in enumerate(plan):
                w = k % len(worlds)
                if k % (10 * len(worlds)) < len(worlds):
                    worlds[w].restore(snaps[w])  # back to the start every 10 actions of a world
                worlds[w].step(a)
            per_round[name].append((time.perf_counter() - t) / actions)
            gc.enable()
    legacy = np.array(per_round["legacy (0.1.0)"])
    return {name: float(np.median(np.array(v) / legacy)) for name, v in per_round.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=1250, help="states per (stage, noise) cell")
    parser.add_argument("--cost-actions", type=int, default=400, help="actions per setting and round for the cost ratio")
    parser.add_argument("--mujoco", type=int, default=0, help="also push the MuJoCo world this many times per cell")
    parser.add_argument("--only", nargs="*", default=None, help="names of the settings to run (default: all)")
    args = parser.parse_args()
    settings = {k: v for k, v in SETTINGS.items() if args.only is None or k in args.only or k == "legacy (0.1.0)"}
    ratios = cost_ratios(settings, args.cost_actions)
    print(f"adversarial pushing, stages 2 and 3 x noise 0 and 0.25, {args.states} states per cell ({4 * args.states} in all)")
    print(f"{'setting':36s} {'> 2 mm':>8s} {'> 5 mm':>8s} {'worst':>8s} {'crossed':>8s} {'cost':>6s}   per cell (> 2 mm / worst)")
    for name, physics in settings.items():
        measured = replace(physics, measure_validity=True)  # 0.1.0 did not measure itself
        reports = [adversarial_pushing(pymunk_world_factory(measured), st, nz, args.states) for st, nz in CELLS]
        pen = np.concatenate([r.penetration for r in reports])
        crossed = sum(r.crossings for r in reports)
        cells = "  ".join(f"{100 * r.share_above(0.002):.2f}%/{r.worst_mm:.1f}" for r in reports)
        print(
            f"{name:36s} {100 * np.mean(pen > 0.002):7.2f}% {100 * np.mean(pen > 0.005):7.2f}% {1000 * pen.max():6.1f}mm "
            f"{crossed:8d} {ratios[name]:5.2f}x   {cells}",
            flush=True,
        )
    if args.mujoco:
        from occrl.envs.mujoco3d.world import MujocoWorld

        def make(scene, noise, seed):
            return MujocoWorld(scene, noise=noise, rng=np.random.default_rng(seed))

        reports = [adversarial_pushing(make, st, nz, args.mujoco) for st, nz in CELLS]
        pen = np.concatenate([r.penetration for r in reports])
        crossed = sum(r.crossings for r in reports)
        print(
            f"{'MuJoCo world (reference)':36s} {100 * np.mean(pen > 0.002):7.2f}% {100 * np.mean(pen > 0.005):7.2f}% "
            f"{1000 * pen.max():6.1f}mm {crossed:8d} {'':6s}   {args.mujoco} states per cell; "
            f"{1000 * np.mean([r.seconds_per_action for r in reports]):.1f} ms per action"
        )


if __name__ == "__main__":
    main()
