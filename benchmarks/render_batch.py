"""The observation render of many worlds: one batched call against one call per world.

Usage:
    python benchmarks/render_batch.py [--worlds 12] [--rounds 20]

Renders the shelf-frame label maps (``occrl.envs.render.render_labels_batch``) of recreated
stage-2 worlds (the scripted retriever's visited states, as the planner's roll-outs see them) in
batches of ``--worlds``, once as one call and once as one call per world, alternated in rounds
in this process, one thread. Checks that both give the same labels, bit for bit.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch

from occrl.baselines import ScriptedRetriever
from occrl.envs import Scene, make_env
from occrl.envs.observation import detected_world_polygons, detection_arrays, worlds_visible_fractions
from occrl.envs.render import render_labels_batch
from occrl.planners import make_world, recreate


def visited_worlds(count: int) -> list:
    worlds, seed = [], 0
    while len(worlds) < count:
        env = make_env(batch_size=1, scenes=[Scene.sample(2, seed=30_000 + seed)], heatmap_target=False)
        seed += 1
        td = env.rollout(12, ScriptedRetriever())
        worlds += [make_world(recreate(td[0, t])) for t in range(0, td.shape[1], 2)]
    return worlds[:count]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=12)
    parser.add_argument("--rounds", type=int, default=20)
    args = parser.parse_args()
    torch.set_num_threads(1)
    worlds = visited_worlds(args.worlds)
    a = detection_arrays(worlds, worlds_visible_fractions(worlds))
    polygons = detected_world_polygons(a["detected"], a["type_id"], a["pose"], a["vertices"], a["num_vertices"], a["target_type"])
    poses, openings = a["gripper_pose"].astype(np.float64), a["gripper_opening"].reshape(-1).astype(np.float64)
    spent = {"batched": 0.0, "per world": 0.0}
    for _ in range(args.rounds):
        t = time.perf_counter()
        together = render_labels_batch(poses, openings, polygons)
        spent["batched"] += time.perf_counter() - t
        t = time.perf_counter()
        alone = np.stack([render_labels_batch(poses[b : b + 1], openings[b : b + 1], polygons[b : b + 1])[0] for b in range(len(worlds))])
        spent["per world"] += time.perf_counter() - t
        assert np.array_equal(together, alone)
    n = args.rounds * len(worlds)
    print(
        f"{len(worlds)} worlds per call: batched {1e3 * spent['batched'] / n:.3f} ms vs per world {1e3 * spent['per world'] / n:.3f} ms "
        f"per world's labels: {spent['per world'] / spent['batched']:.2f}x; identical labels"
    )


if __name__ == "__main__":
    main()
