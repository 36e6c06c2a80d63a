"""A method's success split by when it first saw the target: at the start, after a search, or never.

    python scripts/search_split.py --results F.json [--weights W] [--out SPLIT.json]
    python scripts/search_split.py --start-only --results F1.json F2.json ...

F.json is an `occrl eval --method M --stage S --tasks N --workers 1 [--weights W] --out F.json`
result (replicate 0, the stage's own tasks); the method (with ``--weights W``, the network the
evaluation ran on) is run again on the same tasks, seeded and batched as the evaluation runs
them, up to the first observation in which perception reports the target
(``occrl.training.start_scenes.collect_handover_scenes``), and the evaluation's episodes are
grouped by that step: 0 (the target seen from the start), later (after a search), or never.
``--start-only`` runs no method: it splits any number of results by the task alone, target
seen in the first observation or hidden (the same for every method; the first group above).
A diagnosis for issue 16 (docs/decisions.md): which share of the failures lies in the tasks whose
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
from occrl.training.start_scenes import collect_handover_scenes, hidden_target_scenes


def read_results(parser: argparse.ArgumentParser, path: str) -> dict:
    results = json.loads(open(path).read())
    if results.get("replicate", 0) != 0 or results.get("objects") is not None or results.get("world", "pymunk") != "pymunk":
        parser.error(f"{path}: needs a replicate-0 result on the stage's own pymunk tasks (no --objects, --replicate or --world)")
    return results


def print_groups(label: str, episodes: dict, groups: dict[str, list[int]]) -> dict:
    rows = {}
    print(label)
    for group, seeds in groups.items():
        won = sum(episodes[s]["success"] for s in seeds)
        rows[group] = {"tasks": len(seeds), "solved": won}
        rate = f"{100 * won / len(seeds):5.1f} %" if seeds else "   -"
        print(f"  target {group:30s} {len(seeds):4d} tasks, solved {won:4d} ({rate}), failed {len(seeds) - won}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", required=True, nargs="+", help="`occrl eval` results (one without --start-only)")
    parser.add_argument("--weights", default=None, help="the network it ran on (a weights file or a shipped name; default: the method's)")
    parser.add_argument("--start-only", action="store_true", help="split by the task alone: target seen at the start or hidden")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    if not args.start_only and len(args.results) != 1:
        parser.error("give one --results file (or --start-only for several)")
    if args.start_only and args.weights:
        parser.error("--weights applies without --start-only (the method is run again)")
    out: dict = {}
    if args.start_only:
        hidden_by_stage: dict = {}
        for path in args.results:
            results = read_results(parser, path)
            episodes = {e["seed"]: e for e in results["episodes"]}
            stage, seeds = results["stage"], sorted(episodes)
            known = hidden_by_stage.setdefault(stage, {})
            unknown = [s for s in seeds if s not in known]
            if unknown:
                hidden = {scene.seed for scene in hidden_target_scenes(stage, unknown)}
                known.update({s: s in hidden for s in unknown})
            groups = {"seen at the start": [s for s in seeds if not known[s]], "hidden at the start": [s for s in seeds if known[s]]}
            method = results.get("method") or f"{results['from']} -> {results['to']}"  # or scripts/handover.py's results
            label = (
                f"{method} ({results.get('network') or results.get('weights') or 'no network'}), stage {stage}, {len(seeds)} tasks: {path}"
            )
            out[path] = print_groups(label, episodes, groups)
    else:
        path = args.results[0]
        results = read_results(parser, path)
        stage, name = results["stage"], results["method"]
        episodes = {e["seed"]: e for e in results["episodes"]}
        method = make_method(name, weights_file(args.weights) if args.weights else None)
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
        groups: dict[str, list[int]] = {"first seen at the start": [], "first seen after a search": [], "never seen": []}
        for seed, step in counts["first_sight"].items():
            groups["never seen" if step is None else "first seen at the start" if step == 0 else "first seen after a search"].append(seed)
        network = network_name(args.weights) if args.weights else method.network
        label = f"{name}{f' on {network}' if network else ''}, stage {stage}, {len(episodes)} tasks ({path})"
        rows = print_groups(label, episodes, groups)
        if any(episodes[s]["success"] for s in groups["never seen"]):  # a solved task shows its target on the way
            print("warning: a task never seen here was solved in the evaluation: the episodes are not the evaluation's (another network?)")
        out = {"method": name, "weights": network, "results": path, "stage": stage, "groups": rows, "first_sight": counts["first_sight"]}
    if args.out:
        with open(args.out, "w") as f:
            json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
