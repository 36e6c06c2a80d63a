"""A training run's folder: its file names, its metrics log, and which settings may change when
a run resumes."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from occrl.training.config import TrainConfig

__all__ = [
    "CHECKPOINT",
    "DAGGER_DATA",
    "WEIGHTS",
    "WARM_START_WEIGHTS",
    "METRICS",
    "complete_row",
    "file_sha256",
    "same_run_settings",
    "truncate_metrics",
]

CHECKPOINT = "checkpoint.pt"
DAGGER_DATA = "dagger_buffer.pt"
WEIGHTS = "weights.pt"
WARM_START_WEIGHTS = "weights_warmstart.pt"  # the network at the end of the DAgger warm start, before PPO
METRICS = "metrics.jsonl"

# settings that change where frames are computed but not which: a run may resume under another one
RUNTIME_SETTINGS = {"collector": {"multi", "ray"}}
# a run resumes on any device and teacher inference (they change float rounding, not the method)
MACHINE_SETTINGS = ("device", "teacher_inference")


def complete_row(line: str) -> bool:
    """Whether a metrics line is a whole JSON row (a crash mid-append leaves a partial one)."""
    try:
        return isinstance(json.loads(line), dict)
    except json.JSONDecodeError:
        return False


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file (a run records the one of its initial weights)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def same_run_settings(saved: dict, current: dict) -> bool:
    """Equal training settings, except a run collected by "multi" may resume on "ray" and back, and
    on any device. Settings added after a checkpoint was written take their defaults (the behaviour
    it ran with); settings removed since are dropped where they were off
    (:meth:`TrainConfig.from_dict` refuses them otherwise)."""
    saved = TrainConfig.from_dict(saved).to_dict()
    for key, interchangeable in RUNTIME_SETTINGS.items():
        if saved.get(key) in interchangeable and current.get(key) in interchangeable:
            saved, current = {**saved, key: None}, {**current, key: None}
    for key in MACHINE_SETTINGS:
        saved, current = {**saved, key: None}, {**current, key: None}
    return saved == current


def truncate_metrics(path: Path, iteration: int) -> None:
    """Drop the metric rows after ``iteration`` (written after the checkpoint a run resumed from;
    they will be redone) and any partial row a crash left."""
    if path.exists():
        rows = [line for line in path.read_text().splitlines() if complete_row(line) and json.loads(line)["iteration"] <= iteration]
        tmp = path.with_suffix(".jsonl.tmp")
        tmp.write_text("".join(r + "\n" for r in rows))
        tmp.replace(path)
