"""A training run killed with SIGKILL at any moment, even in the middle of writing its checkpoint,
resumes from the last complete checkpoint and ends bit-identical to a run never interrupted."""

import json
import os
import random
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from occrl.eval.sweep_store import sweep_points

# Runs `occrl train` in a child process; with a fault injected, the child SIGKILLs itself during its
# k-th file write: "write-K" leaves a half-written file at the temporary name, "rename-K" a complete
# temporary file that was never renamed into place.
CHILD = r"""
import os, signal, sys
import torch
mode, argv = sys.argv[1], sys.argv[2:]
if mode != "plain":
    kind, k = mode.split("-")
    k, calls = int(k), [0]
    real_save, real_replace = torch.save, os.replace
    def save(obj, f, *a, **kw):
        calls[0] += kind == "write"
        if calls[0] == k:
            real_save(obj, f, *a, **kw)
            with open(f, "r+b") as fh:
                fh.truncate(max(1, os.path.getsize(f) // 2))
            os.kill(os.getpid(), signal.SIGKILL)
        return real_save(obj, f, *a, **kw)
    def replace(src, dst, *a, **kw):
        calls[0] += kind == "rename"
        if calls[0] == k:
            os.kill(os.getpid(), signal.SIGKILL)
        return real_replace(src, dst, *a, **kw)
    torch.save, os.replace = save, replace
from occrl.cli import main
sys.exit(main(argv))
"""

ITERATIONS = 6
TIMING = ("fps", "collect_fps", "train_hours", "cpu_hours")


def _train(run: Path, mode: str = "plain", kill_after: float | None = None) -> int:
    argv = [
        "train",
        "--preset",
        "tiny",
        "--imitation-iters",
        "3",
        "--iterations",
        str(ITERATIONS),
        "--seed",
        "3",
        "--checkpoint-every",
        "1e-9",
        "--no-progress",
        "--run-dir",
        str(run),
    ]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-c", CHILD, mode, *argv], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    if kill_after is not None:
        try:
            proc.wait(timeout=kill_after)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=600)
    return proc.returncode


def _metrics(run: Path) -> list[dict]:
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    return [{k: v for k, v in r.items() if k not in TIMING} for r in rows]


def _iteration(run: Path) -> int:
    if not (run / "checkpoint.pt").exists():
        return 0
    return torch.load(run / "checkpoint.pt", weights_only=True)["state"]["iteration"]


@pytest.mark.integration
def test_sigkill_at_any_moment_resumes_exactly(tmp_path):
    assert _train(tmp_path / "straight") == 0
    rng = random.Random(0)
    run = tmp_path / "killed"
    # a half-written file during the 2nd write (the first checkpoint), a kill before the 5th rename
    # (iteration 2's DAgger data set is on disk, its checkpoint not yet: 0.1.0 wrote the checkpoint
    # first and resumed with the data set of the iteration before), then kills at random moments
    faults = [("write-2", None), ("rename-5", None), ("plain", rng.uniform(4.0, 9.0)), ("write-9", None), ("plain", rng.uniform(4.0, 9.0))]
    progress = []
    for mode, after in faults:
        code = _train(run, mode, after)
        assert code in (-signal.SIGKILL, 0)
        progress.append(_iteration(run))
    assert _train(run) == 0  # finish
    assert _iteration(run) == ITERATIONS
    assert any(0 < p < ITERATIONS for p in progress), progress  # some kill did land between checkpoints
    a = torch.load(tmp_path / "straight" / "weights.pt", weights_only=True)["model"]
    b = torch.load(run / "weights.pt", weights_only=True)["model"]
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert _metrics(run) == _metrics(tmp_path / "straight")  # every iteration logged once
    assert not list(run.glob("*.tmp")) and not list(run.glob("dagger_buffer*"))


@pytest.mark.integration
def test_an_evaluation_killed_while_writing_leaves_no_partial_result(tmp_path):
    out = tmp_path / "r.json"
    argv = ["eval", "--method", "scripted", "--tasks", "2", "--no-progress", "--out", str(out)]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    killed = subprocess.run([sys.executable, "-c", CHILD, "rename-1", *argv], env=env, capture_output=True)
    assert killed.returncode == -signal.SIGKILL
    assert not out.exists()  # the result is written whole or not at all
    assert subprocess.run([sys.executable, "-c", CHILD, "plain", *argv], env=env, capture_output=True).returncode == 0
    assert json.loads(out.read_text())["tasks"] == 2 and not list(tmp_path.glob("*.tmp"))


def _points(folder: Path) -> dict:
    out = {}
    for point in sweep_points(folder):
        out[point["method"], point["sweep"], point["value"]] = [{k: v for k, v in e.items() if k != "seconds"} for e in point["episodes"]]
    return out


@pytest.mark.slow
def test_a_sweep_killed_at_any_moment_resumes_without_partial_or_duplicated_tasks(tmp_path):
    argv = ["eval", "--sweep", "--methods", "scripted", "--tasks", "2", "--chunk", "1", "--no-progress"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}

    def sweep(out: Path, mode: str = "plain", kill_after: float | None = None) -> None:
        proc = subprocess.Popen(
            [sys.executable, "-c", CHILD, mode, *argv, "--out", str(out)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        try:
            proc.wait(timeout=kill_after)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
            proc.wait()

    sweep(tmp_path / "straight")
    killed = tmp_path / "killed"
    sweep(killed, "rename-7")  # in the middle of the first round, before a point's rename
    partial = _points(killed)
    assert 0 < len(partial) < 16 and all(len(v) == 1 for v in partial.values())
    sweep(killed, "plain", kill_after=random.Random(1).uniform(3.0, 8.0))
    sweep(killed)
    assert _points(killed) == _points(tmp_path / "straight")  # every task once, the same outcomes
    assert not list((killed / "points").glob("*.tmp")) and not list(killed.glob("*.tmp"))
