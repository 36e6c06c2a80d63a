"""The one-screen summary a training run ends with (``occrl train``, also after a stop)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["training_summary"]

LOSS_NAMES = ("loss_imitation", "loss_objective", "loss_critic", "loss_entropy", "loss_heatmap")


def training_summary(rows: list[dict], run_dir: str | Path, preset: str | None = None, seed: int | None = None) -> str:
    """A few lines on where a run stands: iterations, frames, hours, curriculum stage, the
    success of its training episodes (first and last ten iterations), the hybrid validation
    checks, the last losses, and the files to look at next.

    Args:
        rows: the run's metrics rows (:func:`occrl.training.plots.read_metrics`).
        run_dir: the run folder.
        preset, seed: named in the first line when given.

    Examples:
        >>> rows = [{"iteration": i, "frames": 400 * i, "stage": 2, "phase": "imitation", "success_rate": 0.5,
        ...          "train_hours": 0.01 * i, "loss_critic": 1.0} for i in range(1, 26)]
        >>> rows[-1]["hybrid_success_rate"] = 0.66
        >>> print(training_summary(rows, "RUN", preset="cpu-curriculum", seed=0))
        run RUN (preset cpu-curriculum, seed 0): 25 iterations, 10,000 frames, 0.25 wall-hours
        curriculum: stage 2 (started at 2), imitation phase
        training-episode success: 0.50 over the first 10 iterations, 0.50 over the last 10
        hybrid 4x4 validation checks (iteration: success): 25: 0.66
        last losses: critic 1
        files: RUN/checkpoint.pt (run the same command to resume), RUN/weights.pt, RUN/metrics.jsonl, RUN/learning_curves.png
    """
    run = Path(run_dir)
    if not rows:
        return f"run {run}: no iteration finished yet"
    last = rows[-1]
    named = ", ".join(p for p in (f"preset {preset}" if preset else "", f"seed {seed}" if seed is not None else "") if p)
    lines = [
        f"run {run}{f' ({named})' if named else ''}: {last['iteration']} iterations, {last['frames']:,} frames, "
        f"{last['train_hours']:.2f} wall-hours",
        f"curriculum: stage {last['stage']} (started at {rows[0]['stage']}), {last['phase']} phase",
    ]
    success = [r["success_rate"] for r in rows if not math.isnan(r.get("success_rate", math.nan))]
    if success:
        lines.append(
            f"training-episode success: {np.mean(success[:10]):.2f} over the first {min(10, len(success))} iterations, "
            f"{np.mean(success[-10:]):.2f} over the last {min(10, len(success))}"
        )
    checks = [(r["iteration"], r["hybrid_success_rate"]) for r in rows if "hybrid_success_rate" in r]
    if checks:
        lines.append("hybrid 4x4 validation checks (iteration: success): " + ", ".join(f"{i}: {v:.2f}" for i, v in checks[-8:]))
    losses = [f"{k[5:]} {last[k]:.4g}" for k in LOSS_NAMES if k in last]
    if losses:
        lines.append("last losses: " + ", ".join(losses))
    files = [f"{run / 'checkpoint.pt'} (run the same command to resume)"] + [
        str(run / name) for name in ("weights.pt", "metrics.jsonl", "learning_curves.png")
    ]
    lines.append("files: " + ", ".join(files))
    return "\n".join(lines)
