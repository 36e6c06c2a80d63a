"""The CPU time a run reports (model cards' ``cpu_hours``): its whole process tree, kept across a resume."""

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from occrl.training import Trainer, get_train_config
from occrl.training.cpu_time import live_descendants_cpu_seconds, tree_cpu_seconds
from tests.helpers import checkpoint_as_written_before

BUSY = "import time\nt = time.process_time()\nwhile time.process_time() - t < {cpu}: pass\ntime.sleep({rest})"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="live descendants are read from /proc (Linux)")
def test_a_child_process_counts_while_it_runs_and_after_it_ended():
    import resource

    def ended() -> float:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        return usage.ru_utime + usage.ru_stime

    live0, ended0, tree0 = live_descendants_cpu_seconds(), ended(), tree_cpu_seconds()  # other descendants only add
    child = subprocess.Popen([sys.executable, "-c", BUSY.format(cpu=0.5, rest=60)])
    try:
        deadline = time.time() + 30
        while live_descendants_cpu_seconds() - live0 < 0.5 and time.time() < deadline:
            time.sleep(0.05)
        assert live_descendants_cpu_seconds() - live0 >= 0.5  # the live child's own CPU, read from /proc
        assert tree_cpu_seconds() - tree0 >= 0.5
    finally:
        child.kill()
        child.wait()
    assert ended() - ended0 >= 0.5  # gone: counted among the ended children from now on
    assert tree_cpu_seconds() - tree0 >= 0.5


@pytest.mark.integration
def test_the_run_logs_its_cpu_time_and_keeps_it_across_a_resume(tmp_path):
    cfg = get_train_config("tiny")
    first = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    first.train(iterations=2)
    first.close()
    resumed = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert resumed.cpu_seconds == first.cpu_seconds > 0.0
    resumed.train(iterations=3)
    resumed.close()
    rows = [json.loads(line) for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    cpu = [r["cpu_hours"] for r in rows]
    assert 0.0 < cpu[0] < cpu[1] < cpu[2] == resumed.cpu_seconds / 3600


@pytest.mark.integration
def test_a_checkpoint_from_before_the_cpu_time_resumes_without_it(tmp_path):
    cfg = get_train_config("tiny")
    checkpoint_as_written_before(tmp_path, cfg, lambda ckpt: ckpt["state"].pop("cpu_seconds"))  # as written before it was measured
    resumed = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    resumed.train(iterations=2)
    resumed.close()
    rows = [json.loads(line) for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    assert resumed.cpu_seconds is None and "cpu_hours" in rows[0] and "cpu_hours" not in rows[1]
