"""Success of a network's own policy split by when it first saw the target: at the start, after a
search, or never.

    python scripts/search_split.py --weights W --results F.json [--stage 2] [--out SPLIT.json]

F.json is `occrl eval --method stochastic-gen --stage S --tasks N --workers 1 --weights W --out
F.json` on the held-out tasks; the policy is run again on the same tasks, seeded as the
evaluation seeds it, up to the first observation in which perception reports the target
(``occrl.training.start_scenes.collect_handover_scenes``), and the evaluation's episodes are
grouped by that step: 0 (the target seen from the start), later (after a search), or never. A
diagnosis for issue 16 (docs/decisions.md): it says which share of the failures a better search
could address, and motivates training pools of target-hidden tasks (scripts/start_scene_pool.py).
"""

from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch

from occrl.eval.methods import make_method
from occrl.pretrained import network_name, weights_file
from occrl.training.start_scenes import collect_handover_scenes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", required=True, help="the network (a weights file or a shipped name)")
    parser.add_argument("--results", required=True, help="its `occrl eval --method stochastic-gen` result on these tasks")
    parser.add_argument("--stage", type=int, default=None, help="default: the results' stage")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    results = json.loads(open(args.results).read())
    if results.get("method") != "stochastic-gen" or results.get("replicate", 0) != 0 or results.get("objects") is not None:
        parser.error(f"{args.results}: needs a replicate-0 stochastic-gen result on the stage's own tasks (no --objects)")
    stage = args.stage or results["stage"]
    episodes = {e["seed"]: e for e in results["episodes"]}
    method = make_method("stochastic-gen", weights_file(args.weights))
    _, counts = collect_handover_scenes(
        method.policy,
        stage,
        sorted(episodes),
        primers=method.primers,
        size=method.image_size,
        remembered_detections=method.remembered_detections,
        noise=results.get("noise", 0.0),
        batch=int(results.get("batch", 16)),  # the evaluation's batches: the same network calls, the same episodes
        progress=True,
    )
    groups: dict[str, list[int]] = {"at the start": [], "after a search": [], "never": []}
    for seed, step in counts["first_sight"].items():
        groups["never" if step is None else "at the start" if step == 0 else "after a search"].append(seed)
    rows = {}
    print(f"{network_name(args.weights)}, stage {stage}, {len(episodes)} tasks ({args.results})")
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
