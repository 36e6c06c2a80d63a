"""Write a pool of start scenes for training (``occrl train --start-scenes FILE``).

    python scripts/start_scene_pool.py --kind target-hidden --stage 2 --count 8000 --out POOL.json
    python scripts/start_scene_pool.py --kind handover --weights W --stage 2 --count 4000 --out POOL.json

``target-hidden``: the tasks, from task seed ``--seed`` (default 50,000,000: apart from the
held-out tasks at 10,000,000 and the promotion checks' at 20,000,000) on, whose target perception
does not report in the first observation, until ``--count`` are found. ``handover``: the network's
own sampled policy (``--weights``, the `stochastic-gen` method) runs those tasks, and the world at
its first observation reporting the target is kept as a scene (gripper open and empty; see
``occrl.training.start_scenes``), until ``--count`` are kept; ``--later-only`` keeps only
hand-overs after the first observation. The file's meta names the kind, stage, seeds and counts
(the trainer reads its ``"stage"``). Beyond the paper; issue 16, docs/decisions.md.
"""

from __future__ import annotations

import argparse
import os
import time
from collections import Counter

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch

from occrl.envs.scene_files import save_scenes
from occrl.training.start_scenes import collect_handover_scenes, hidden_target_scenes

BLOCK = 512  # task seeds tried per round


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", required=True, choices=("target-hidden", "handover"))
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--count", type=int, required=True, help="scenes to write")
    parser.add_argument("--seed", type=int, default=50_000_000, help="first task seed tried")
    parser.add_argument(
        "--weights", default=None, help="handover: the searching network (a weights file or a shipped name; default occnet)"
    )
    parser.add_argument("--later-only", action="store_true", help="handover: only hand-overs after the first observation")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    if args.count < 1:
        parser.error(f"--count must be >= 1, got {args.count}")
    if args.kind == "target-hidden" and (args.weights or args.later_only):
        parser.error("--weights and --later-only apply to --kind handover")
    torch.set_num_threads(1)
    method = None
    if args.kind == "handover":
        from occrl.eval.methods import make_method
        from occrl.pretrained import network_name, weights_file

        method = make_method("stochastic-gen", weights_file(args.weights))
    scenes, tried, counts, dropped = [], 0, {}, Counter()
    start = time.time()
    while len(scenes) < args.count:
        seeds = range(args.seed + tried, args.seed + tried + BLOCK)
        tried += BLOCK
        if method is None:
            scenes += hidden_target_scenes(args.stage, seeds)
        else:
            found, c = collect_handover_scenes(
                method.policy,
                args.stage,
                seeds,
                primers=method.primers,
                size=method.image_size,
                remembered_detections=method.remembered_detections,
            )
            if args.later_only:
                found = [s for s in found if s.meta["step"] > 0]
            scenes += found
            for k in ("tasks", "handed_over", "kept"):
                counts[k] = counts.get(k, 0) + c[k]
            dropped.update(c["dropped"])
        print(f"{tried} tasks tried, {len(scenes)} scenes ({time.time() - start:.0f} s)", flush=True)
    scenes = scenes[: args.count]
    last_seed = scenes[-1].seed if method is None else scenes[-1].meta["task_seed"]
    meta = {
        "kind": args.kind,
        "stage": args.stage,
        "first_seed": args.seed,
        "last_seed": int(last_seed),
        "tasks_tried": tried,
        "scenes": len(scenes),
    }
    if method is not None:
        meta.update(
            {
                "weights": network_name(args.weights) if args.weights else "occnet",
                "later_only": args.later_only,
                "counts": {**counts, "dropped": dict(dropped)},
            }
        )
    save_scenes(args.out, scenes, meta=meta)
    print(f"wrote {len(scenes)} scenes to {args.out}: {meta}")


if __name__ == "__main__":
    main()
