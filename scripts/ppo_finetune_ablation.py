"""PPO fine-tuning of the shipped warm-start net: which setting makes the policy degrade?

Runs short ``cpu-finetune`` trainings from ``occnet-warmstart`` (seed 0), each with one change, and prints
the learner's success on its own stage-1 training episodes: iterations 1-10 train only the value
head (the policy is the warm-start one), PPO starts at iteration 11.

Usage:
    python scripts/ppo_finetune_ablation.py --out ~/occrl-runs/ppo-ablation [--iterations 40] [--variants a,b]
    python scripts/ppo_finetune_ablation.py --out results/ppo-finetune --table-only

A variant whose run folder already holds ``--iterations`` rows of metrics is not run again.
``results/ppo-finetune/`` holds the metrics of the runs quoted in docs/decisions.md. The
expert-term variants (``bc*``) need training settings removed in occrl 0.2.0: rerun them from
commit eed1cea (``git checkout eed1cea``); ``--table-only`` prints all of them from their metrics.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

BC = {"ppo_bc_coeff": 1.0, "ppo_bc_min_scale": 0.01}  # the expert term as first tried
VARIANTS: dict[str, tuple[str, dict]] = {
    "preset": ("cpu-finetune as shipped (no expert term)", {}),
    "bn-refresh-lr0": (
        "batch-norm refresh on (400 frames), learning rate 0",
        {"batch_norm_frames": 400, "lr": 0.0},  # run with an expert term x0.5, which moves nothing at lr 0
    ),
    "bc1-floor0.01": ("+ expert term: its negative log-likelihood on the batch, x1, spread floor 0.01", BC),
    "bc0.5-floor0.1": ("+ expert term x0.5, spread floor 0.1 (the warm start's)", {"ppo_bc_coeff": 0.5, "ppo_bc_min_scale": 0.1}),
    "bc1-freeze-scale": ("+ expert term x1, no gradient to the spread outputs", {**BC, "freeze_policy_scale": True}),
    "bc1-no-aux": ("+ expert term x1, critic 0.05, no heat-map loss", {**BC, "critic_coeff": 0.05, "heatmap_coeff": 0.0}),
}


def run(name: str, out: Path, iterations: int) -> None:
    from occrl.pretrained import pretrained_path
    from occrl.training import Trainer, get_train_config

    folder = out / name
    metrics = folder / "metrics.jsonl"
    if metrics.exists() and len(metrics.read_text().splitlines()) >= iterations:
        return
    if name.startswith("bc"):
        raise SystemExit(f"variant {name}: the expert term was removed in occrl 0.2.0; rerun it from commit eed1cea")
    trainer = Trainer(
        get_train_config("cpu-finetune", **VARIANTS[name][1]),
        folder,
        seed=0,
        progress=True,
        init_weights=pretrained_path("occnet-warmstart"),
        tensorboard=False,
    )
    try:
        trainer.train(iterations=iterations)
    finally:
        trainer.close()


def table(out: Path) -> None:
    print("| variant | change | success it. 1-10 (value head only) | PPO it. 11-20 | 21-30 | 31-40 | entropy at it. 12 -> last |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, (change, _) in VARIANTS.items():
        path = out / name / "metrics.jsonl"
        if not path.exists():
            continue
        rows = sorted({r["iteration"]: r for r in map(json.loads, path.read_text().splitlines())}.values(), key=lambda r: r["iteration"])
        succ = {r["iteration"]: r["success_rate"] for r in rows}
        cells = []
        for lo, hi in ((1, 10), (11, 20), (21, 30), (31, 40)):
            part = [succ[i] for i in range(lo, hi + 1) if i in succ]
            cells.append(f"{np.mean(part):.2f}" if len(part) == hi - lo + 1 else "-")
        ent = [r["entropy"] for r in rows if "entropy" in r]
        ent_cell = f"{ent[1]:.1f} -> {ent[-1]:.1f}" if len(ent) > 1 else "-"
        print(f"| {name} | {change} | " + " | ".join(cells) + f" | {ent_cell} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--iterations", type=int, default=40)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--table-only", action="store_true")
    args = parser.parse_args()
    out = Path(args.out).expanduser()
    if not args.table_only:
        for name in args.variants.split(","):
            if name not in VARIANTS:
                raise SystemExit(f"unknown variant {name!r}; known: {list(VARIANTS)}")
            run(name, out, args.iterations)
    table(out)


if __name__ == "__main__":
    main()
