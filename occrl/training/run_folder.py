"""A training run's folder: its file names and its metrics log."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path


__all__ = [
    "CHECKPOINT",
    "DAGGER_DATA",
    "WEIGHTS",
    "WARM_START_WEIGHTS",
    "METRICS",
    "complete_row",
    "file_sha256",
    "truncate_metrics",
]

CHECKPOINT = "checkpoint.pt"
DAGGER_DATA = "dagger_buffer.pt"
WEIGHTS = "weights.pt"
WARM_START_WEIGHTS = "weights_warmstart.pt"  # the network at the end of the DAgger warm start, before PPO
METRICS = "metrics.jsonl"


def complete_row(line: str) -> bool:
    """Whether a metrics line is a whole JSON row (a crash mid-append leaves a partial one)."""
    try:
        return isinstance(json.loads(line), dict)
    except json.JSONDecodeError:
        return False


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file (a run records the one of its initial weights)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def truncate_metrics(path: Path, iteration: int) -> None:
    """Drop the metric rows after ``iteration`` (written after the checkpoint a run resumed from;
    they will be redone) and any partial row a crash left."""
    if path.exists():
        rows = [line for line in path.read_text().splitlines() if complete_row(line) and json.loads(line)["iteration"] <= iteration]
        tmp = path.with_suffix(".jsonl.tmp")
        tmp.write_text("".join(r + "\n" for r in rows))
        tmp.replace(path)
