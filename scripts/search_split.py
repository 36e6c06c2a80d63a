"""A method's success split by when it first saw the target: at the start, after a search, or never.

    python scripts/search_split.py --results F.json [--weights W] [--out SPLIT.json]

F.json is an `occrl eval --method M --stage S --tasks N --workers 1 [--weights W] --out F.json`
result (replicate 0, the stage's own tasks); the method (with ``--weights W``, the network the
evaluation ran on) is run again on the same tasks, seeded and batched as the evaluation runs
them, up to the first observation in which perception reports the target
(``occrl.training.start_scenes.collect_handover_scenes``), and the evaluation's episodes are
grouped by that step: 0 (the target seen from the start), later (after a search), or never. A
diagnosis for issue 16 (docs/decisions.md): which share of the failures lies in the tasks whose
target is hidden at the start (the motive for training pools of them, scripts/start_scene_pool.py).
"""

from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch

from occrl.eval.methods import is_planner, make_method
from occrl.pretrained import network_name, weights_file
from occrl.training.start_scenes import collect_handover_scenes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", required=True, help="an `occrl eval` result")
    parser.add_argument("--weights", default=None, help="the network it ran on (a weights file or a shipped name; default: the method's)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    results = json.loads(open(args.results).read())
    if results.get("replicate", 0) != 0 or results.get("objects") is not None or results.get("world", "pymunk") != "pymunk":
        parser.error(f"{args.results}: needs a replicate-0 result on the stage's own pymunk tasks (no --objects, --replicate or --world)")
    stage, name = results["stage"], results["method"]
    episodes = {e["seed"]: e for e in results["episodes"]}
    method = make_method(name, weights_file(args.weights) if args.weights else None)
    label = f"{name} on {network_name(args.weights)}" if args.weights else name
    _, counts = collect_handover_scenes(
        method.policy,
        stage,
        sorted(episodes),
        primers=method.primers,
        size=method.image_size,
        remembered_detections=method.remembered_detections,
        noise=results.get("noise", 0.0),
        batch=1 if is_planner(name) else int(results.get("batch", 16)),  # the evaluation's batches: the same episodes
        progress=True,
    )
    groups: dict[str, list[int]] = {"at the start": [], "after a search": [], "never": []}
    for seed, step in counts["first_sight"].items():
        groups["never" if step is None else "at the start" if step == 0 else "after a search"].append(seed)
    rows = {}
    print(f"{label}, stage {stage}, {len(episodes)} tasks ({args.results})")
    for name, seeds in groups.items():
        won = sum(episodes[s]["success"] for s in seeds)
        rows[name] = {"tasks": len(seeds), "solved": won}
        rate = f"{100 * won / len(seeds):5.1f} %" if seeds else "   -"
        print(f"  target first seen {name:15s} {len(seeds):4d} tasks, solved {won:4d} ({rate}), failed {len(seeds) - won}")
    if any(episodes[s]["success"] for s in groups["never"]):  # a solved task shows its target on the way
        print("warning: a task never seen here was solved in the evaluation: the episodes are not the evaluation's (another network?)")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(
                {
                    "weights": network_name(args.weights),
                    "results": args.results,
                    "stage": stage,
                    "groups": rows,
                    "first_sight": counts["first_sight"],
                },
                f,
                indent=1,
            )


if __name__ == "__main__":
    main()
