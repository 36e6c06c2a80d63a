"""Whether this checkout's perception gives the same bytes as a reference checkout's.

Usage:
    git worktree add /tmp/occrl-ref <commit>        # the code to compare against
    python scripts/perception_identity.py --reference /tmp/occrl-ref [--batches 150] [--seed 1]

For speed work that must not change behaviour: both checkouts, each in a child process, build
the same random batches of 1-12 worlds (stages 1-3), step each batch four times with the same
random actions and after every step record the visible fractions
(``worlds_visible_fractions``) and the network input (``world_pixels``); after the first step
also the whole shelf-frame label maps (``render_labels_batch``) and the true top-down views
(``render_true_scene``, both canvases). Every array must match in dtype, shape and every bit;
it prints how many did, or the first that did not, and exits 1 then.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

# what each child runs: only public API that both sides have
CHILD = r"""
import sys
import numpy as np
from occrl.envs import Scene, ShelfWorld
from occrl.envs import observation as O
from occrl.envs import render as R

rng = np.random.default_rng(int(sys.argv[1]))
out = []
for _ in range(int(sys.argv[2])):
    worlds = [ShelfWorld(Scene.sample(int(rng.integers(1, 4)), seed=int(rng.integers(0, 10**6)))) for _ in range(int(rng.integers(1, 13)))]
    for step in range(4):
        for w in worlds:
            w.step(rng.uniform(-1, 1, 4))
        fractions = O.worlds_visible_fractions(worlds)
        out.append(np.concatenate(fractions) if fractions else np.zeros(0))
        out.append(O.world_pixels(worlds).numpy())
        if step == 0:
            a = O.detection_arrays(worlds, fractions)
            polygons = O.detected_world_polygons(a["detected"], a["type_id"], a["pose"], a["vertices"], a["num_vertices"], a["target_type"])
            out.append(R.render_labels_batch(a["gripper_pose"], a["gripper_opening"], polygons))
            w = worlds[0]
            shapes = [p[:k] for p, k in zip(w.object_world_padded(None), w.num_vertices)]
            targets = [i == w.target_index for i in range(len(shapes))]
            for canvas in (R.DEFAULT_CANVAS, R.SHELF_VIEW):
                out.append(R.render_true_scene(w.gripper_pose(), w.opening, shapes, targets, canvas))
out.append(R.render_labels_batch(np.array([[0.0, -0.1, 0.0]]), np.array([0.085]), [([], [])]))
np.savez(sys.argv[3], *out)
"""


def dump(root: Path, seed: int, batches: int, path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(root), OMP_NUM_THREADS="1")
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, str(seed), str(batches), str(path)], cwd=root, env=env, capture_output=True, text=True, check=False
    )
    if proc.returncode != 0:
        raise SystemExit(f"the run in {root} failed:\n{proc.stderr[-3000:]}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", required=True, help="a checkout of the code to compare against (e.g. a git worktree)")
    parser.add_argument("--batches", type=int, default=150, help="random batches of 1-12 worlds")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    reference = Path(args.reference).resolve()
    if not (reference / "occrl").is_dir():
        raise SystemExit(f"--reference must be a checkout of occrl (a folder holding occrl/), got {reference}")
    if args.batches < 1:
        raise SystemExit(f"--batches must be >= 1, got {args.batches}")
    here = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        paths = {name: Path(tmp) / f"{name}.npz" for name in ("this", "reference")}
        dump(here, args.seed, args.batches, paths["this"])
        dump(reference, args.seed, args.batches, paths["reference"])
        this, ref = np.load(paths["this"]), np.load(paths["reference"])
        if this.files != ref.files:
            raise SystemExit(f"different numbers of arrays: {len(this.files)} here, {len(ref.files)} in the reference")
        for key in this.files:
            a, b = this[key], ref[key]
            if a.dtype != b.dtype or a.shape != b.shape or not np.array_equal(a, b):
                print(f"array {key} differs: {a.dtype}{a.shape} here, {b.dtype}{b.shape} in the reference")
                sys.exit(1)
    print(f"identical: {len(this.files)} arrays from {args.batches} batches (visible fractions, windows, label maps, true views)")


if __name__ == "__main__":
    main()
