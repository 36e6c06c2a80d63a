"""Learning-curve plots from a run's ``metrics.jsonl``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["plot_learning_curves", "read_metrics"]


def read_metrics(path: str | Path) -> list[dict]:
    """Rows by iteration; when a run was resumed from an older checkpoint, the rows written
    after the checkpoint and before the stop are superseded by the resumed ones (last wins).

    Examples:
        >>> import json, tempfile
        >>> from pathlib import Path
        >>> from occrl.training.plots import read_metrics
        >>> path = Path(tempfile.mkdtemp()) / "metrics.jsonl"
        >>> rows = [{"iteration": 1, "success_rate": 0.0}, {"iteration": 2, "success_rate": 0.1},
        ...         {"iteration": 2, "success_rate": 0.2}]  # iteration 2 again after a resume
        >>> with open(path, "w") as f:
        ...     for row in rows:
        ...         print(json.dumps(row), file=f)
        >>> [(r["iteration"], r["success_rate"]) for r in read_metrics(path)]
        [(1, 0.0), (2, 0.2)]
    """
    by_iter: dict[int, dict] = {}
    with open(path) as f:
        for line in f:
            if line.strip():
                row = json.loads(line)
                by_iter[row["iteration"]] = row
    return [by_iter[k] for k in sorted(by_iter)]


def _smooth(y: np.ndarray, k: int = 10) -> np.ndarray:
    y = np.asarray(y, float)
    out = np.empty_like(y)
    for i in range(len(y)):
        w = y[max(0, i - k + 1) : i + 1]
        w = w[~np.isnan(w)]
        out[i] = w.mean() if len(w) else np.nan
    return out


def plot_learning_curves(metrics_path: str | Path, out_path: str | Path, title: str | None = None) -> Path:
    """Success rate, return, heat-map loss and stage against frames, one PNG.

    Examples:
        >>> import json, tempfile
        >>> from pathlib import Path
        >>> from occrl.training.plots import plot_learning_curves
        >>> run = Path(tempfile.mkdtemp())
        >>> rows = [{"iteration": i, "frames": 32 * i, "success_rate": 0.1 * i, "stage": 1} for i in (1, 2, 3)]
        >>> with open(run / "metrics.jsonl", "w") as f:
        ...     for row in rows:
        ...         print(json.dumps(row), file=f)
        >>> path = plot_learning_curves(run / "metrics.jsonl", run / "curves.png")
        >>> path.name, path.stat().st_size > 0
        ('curves.png', True)
    """
    from matplotlib.figure import Figure  # no pyplot: leaves the caller's backend (e.g. a notebook's) alone

    rows = read_metrics(metrics_path)
    frames = np.array([r["frames"] for r in rows]) / 1e6
    fig = Figure(figsize=(10, 6.5))
    axes = fig.subplots(2, 2, sharex=True)
    panels = [
        ("success_rate", "training-episode success rate"),
        ("episode_return", "episode return"),
        ("loss_heatmap", "heat-map loss (c3 x BCE)"),
        ("stage", "curriculum stage"),
    ]
    for ax, (key, label) in zip(axes.ravel(), panels):
        y = np.array([r.get(key, np.nan) for r in rows], float)
        if key == "stage":
            ax.step(frames, y, where="post")
            ax.set_yticks([1, 2, 3])
        else:
            ax.plot(frames, y, alpha=0.25, color="C0")
            ax.plot(frames, _smooth(y), color="C0")
        imit = np.array([r.get("phase") == "imitation" for r in rows])
        if imit.any():
            ax.axvspan(frames[imit].min(), frames[imit].max(), color="orange", alpha=0.1, label="imitation warm start")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("frames (millions)")
    axes[0, 0].legend(loc="lower right", fontsize=8) if any(r.get("phase") == "imitation" for r in rows) else None
    fig.suptitle(title or f"training: {Path(metrics_path).parent.name}")
    fig.tight_layout()
    out_path = Path(out_path)
    fig.savefig(out_path, dpi=100)
    return out_path
