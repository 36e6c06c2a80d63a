"""``occrl export``: a training run's weights shipped inside the package as a named pretrained
network, with its model card (recipe, preset, frames, CPU-hours, stage reached)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["run_export", "read_recipe_steps", "RECIPE_STEP_KEYS"]

RECIPE_STEP_KEYS = {"what": str, "command": str, "frames": int, "cpu_hours": float}  # one earlier step of a model card's recipe


def read_recipe_steps(path: Path) -> list[dict]:
    """The earlier training steps of an exported network (``occrl export --recipe-before``): a JSON
    list of objects with ``what`` and ``command`` (text), ``frames`` (environment frames, or null
    for steps that collect none, such as an offline fit) and ``cpu_hours`` (or null where not
    measured).

    Raises:
        ValueError: when the file is missing, not JSON, or a step lacks a key or has a wrong type.
    """
    try:
        steps = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ValueError(f"cannot read a JSON list of steps ({error})") from None
    if not isinstance(steps, list) or not steps:
        raise ValueError(f"expected a non-empty JSON list of steps, each with {sorted(RECIPE_STEP_KEYS)}")
    for i, step in enumerate(steps):
        if not isinstance(step, dict) or set(step) != set(RECIPE_STEP_KEYS):
            keys = sorted(step) if isinstance(step, dict) else type(step).__name__
            raise ValueError(f"step {i} has {keys}; each step needs exactly {sorted(RECIPE_STEP_KEYS)}")
        for key, kind in RECIPE_STEP_KEYS.items():
            value = step[key]
            number = kind in (int, float) and (
                value is None or (isinstance(value, (int, float)) and not isinstance(value, bool) and value >= 0)
            )
            if not (number or (kind is str and isinstance(value, str) and value)):
                allowed = "a non-empty string" if kind is str else "a number >= 0 or null"
                raise ValueError(f"step {i}: {key} must be {allowed}, got {value!r}")
    return steps


def run_export(args: argparse.Namespace) -> int:
    """Ship a run's weights inside the package as a named pretrained network."""
    import shutil

    import torch

    from occrl.pretrained import DEFAULT_NETWORKS, PRETRAINED_DIR, PRETRAINED_FILES
    from occrl.modules.weights import load_weights, save_weights
    from occrl.training.checkpoint import load_checkpoint
    from occrl.training.plots import read_metrics

    if args.name not in PRETRAINED_FILES:
        print(
            f"name must be a shipped network's own name, one of {sorted(PRETRAINED_FILES)} (the default names "
            f"{sorted(DEFAULT_NETWORKS)} stand for one of them: occrl.pretrained.DEFAULT_NETWORKS), got {args.name!r}",
            file=sys.stderr,
        )
        return 2
    recipe_before = None
    if args.recipe_before:
        try:
            recipe_before = read_recipe_steps(Path(args.recipe_before))
        except ValueError as error:
            print(f"occrl export: error: --recipe-before {args.recipe_before}: {error}", file=sys.stderr)
            return 2
    run = Path(args.run_dir)
    weights_path = run / (args.weights or "weights.pt")
    net = load_weights(weights_path)
    meta = torch.load(weights_path, map_location="cpu", weights_only=True).get("meta", {})
    rows = read_metrics(run / "metrics.jsonl")
    iteration = int(meta.get("iteration", rows[-1]["iteration"]))  # the file's own iteration, else the run's last
    upto = [r for r in rows if r["iteration"] <= iteration] or rows
    last = upto[-1]
    stage = max(r["stage"] for r in upto)
    card = {
        "train_preset": args.preset,
        "seed": args.seed,
        "weights_file": weights_path.name,
        "iterations": last["iteration"],
        "frames": last["frames"],
        # CPU time of the run's process tree (occrl.training.cpu_time); None for runs from before it was measured
        "cpu_hours": round(last["cpu_hours"], 2) if "cpu_hours" in last else None,
        "wall_hours": round(last["train_hours"], 2),
        "stage_reached": stage,
        "phase": last["phase"],
        "summary": f"{args.name}: preset {args.preset}, iteration {last['iteration']}, {last['frames']:,} frames, stage {stage}, "
        f"{last['phase']} phase",
    }
    checkpoint = run / "checkpoint.pt"
    saved = load_checkpoint(checkpoint) if checkpoint.exists() else None
    started_from = saved["state"].get("init_weights") if saved else None
    if saved and "train_config" in saved:  # the recipe: the run's settings that differ from its preset's
        from occrl.training import TrainConfig, get_train_config

        preset = get_train_config(args.preset).flat_settings()  # by the names of occrl train's options
        run = TrainConfig.from_dict(saved["train_config"]).flat_settings()
        changed = {k: v for k, v in run.items() if preset[k] != v}
        card["settings_beyond_preset"] = changed
        card["summary"] += "".join(f", {k}={v}" for k, v in changed.items() if k not in ("stage", "start_stage"))
    if started_from:  # the run began from another network (--init-weights): its own training comes first
        card["init_weights"] = Path(started_from["path"]).name
        card["summary"] += f", started from {Path(started_from['path']).name}"
    if recipe_before is not None:  # the training that made the starting network, ahead of this run
        card["recipe_before"] = recipe_before
        steps = [*recipe_before, {"frames": card["frames"], "cpu_hours": card["cpu_hours"]}]
        card["recipe_frames"] = sum(step["frames"] or 0 for step in steps)
        cpu = [step["cpu_hours"] for step in steps]
        card["recipe_cpu_hours"] = None if None in cpu else round(sum(cpu), 2)
        card["summary"] += f", after {len(recipe_before)} earlier steps (recipe_before)"
    dest = Path(args.dest) if args.dest else PRETRAINED_DIR
    dest.mkdir(parents=True, exist_ok=True)
    save_weights(dest / PRETRAINED_FILES[args.name], net, card)
    cards_path = dest / "model_cards.json"
    cards = json.loads(cards_path.read_text()) if cards_path.exists() else {}
    cards[args.name] = card
    cards_path.write_text(json.dumps(cards, indent=2))
    docs = Path(__file__).resolve().parents[2] / "docs"
    if not args.dest and docs.exists() and (run / "learning_curves.png").exists():
        shutil.copy(run / "learning_curves.png", docs / f"learning_curves_{args.name}.png")
    print(json.dumps(card, indent=2))
    return 0
