"""`scripts/merge_eval_results.py`: chunks of an evaluation merge into what one run over all their
seeds writes (per-task times aside); runs of other settings or on shared seeds are refused."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _eval(tmp_path, name, seed, tasks, method="scripted"):
    out = tmp_path / f"{name}.json"
    args = ["eval", "--method", method, "--stage", "1", "--seed", str(seed), "--tasks", str(tasks), "--no-progress", "--out", str(out)]
    subprocess.run([sys.executable, "-m", "occrl.cli", *args], check=True, cwd=ROOT, capture_output=True)
    return out


def _merge(*paths):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        from merge_eval_results import merge
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    return merge([json.loads(Path(p).read_text()) for p in paths])


def test_chunks_merge_into_the_single_run(tmp_path):
    whole = json.loads(_eval(tmp_path, "whole", 500, 4).read_text())
    merged = _merge(_eval(tmp_path, "b", 502, 2), _eval(tmp_path, "a", 500, 2))
    drop = lambda d: {k: v for k, v in d.items() if k not in ("mean_seconds", "episodes")}  # noqa: E731
    assert drop(merged) == drop(whole)
    assert [{k: v for k, v in e.items() if k != "seconds"} for e in merged["episodes"]] == [
        {k: v for k, v in e.items() if k != "seconds"} for e in whole["episodes"]
    ]
    with pytest.raises(ValueError, match="share task seeds"):
        _merge(tmp_path / "a.json", tmp_path / "whole.json")
    with pytest.raises(ValueError, match=r"differ in \['method'"):
        _merge(tmp_path / "a.json", _eval(tmp_path, "c", 504, 1, method="greedy"))
