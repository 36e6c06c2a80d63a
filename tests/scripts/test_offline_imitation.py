"""scripts/offline_imitation.py: fits the data run's labels, resumes to the same weights, refuses a data run it cannot use."""

import pytest
import json
import subprocess
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]


def _run(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, check=check, cwd=ROOT)


def _data_run(run: Path, buffer_iters: int, *extra: str) -> None:
    _run(
        "-m", "occrl.cli", "train", "--preset", "tiny", "--imitation-iters", "3", "--iterations", "2", "--lr", "0",
        "--imitation-buffer-iters", str(buffer_iters), "--no-progress", "--run-dir", str(run), *extra,
    )  # fmt: skip


def _fit(data: Path, out: Path, steps: int) -> str:
    args = ["--data", str(data), "--init-weights", str(data / "weights.pt"), "--steps", str(steps), "--save-every", "3", "--log-every", "2"]
    return _run("scripts/offline_imitation.py", *args, "--out", str(out)).stdout


@pytest.mark.integration
def test_fit_lowers_the_validation_nll_and_resumes_exactly(tmp_path):
    data = tmp_path / "data"
    _data_run(data, buffer_iters=10)
    straight, resumed = tmp_path / "straight", tmp_path / "resumed"
    out = _fit(data, straight, 6)
    assert (
        "2 iterations, 0 episodes, no episode finished" in out and "8 labelled sequences, 64 labelled frames" in out
    )  # every frame labelled (scripted)
    assert "7 sequences to fit, 1 held out" in out
    _fit(data, resumed, 3)
    assert "resumed" in _fit(data, resumed, 6)
    rows = [json.loads(line) for line in (straight / "metrics.jsonl").read_text().splitlines()]
    assert [r["step"] for r in rows] == [0, 2, 4, 6]
    assert rows[-1]["validation_nll"] < rows[0]["validation_nll"]
    # the same fit either way; its cost (CPU and wall hours, totalled over the resume) is logged beside it
    cost = ("cpu_hours", "wall_hours")
    resumed_rows = [json.loads(line) for line in (resumed / "metrics.jsonl").read_text().splitlines()]
    assert [{k: v for k, v in r.items() if k not in cost} for r in resumed_rows] == [
        {k: v for k, v in r.items() if k not in cost} for r in rows
    ]
    assert all(0 < r["cpu_hours"] and 0 < r["wall_hours"] for r in rows[1:] + resumed_rows[1:])
    assert resumed_rows[-1]["cpu_hours"] > resumed_rows[1]["cpu_hours"]  # the resumed fit adds to the first part's total
    assert torch.load(straight / "weights.pt", weights_only=False)["meta"]["cpu_hours"] >= rows[-1]["cpu_hours"]
    a = torch.load(straight / "weights.pt", weights_only=False)["model"]
    b = torch.load(resumed / "weights.pt", weights_only=False)["model"]
    start = torch.load(data / "weights.pt", weights_only=False)["model"]
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], start[k]) for k in a)  # it learnt
    assert (straight / "weights_step3.pt").exists() and (straight / "weights_step6.pt").exists()
    table = _run(
        "scripts/offline_imitation.py", "--data", str(data), "--assess", str(data / "weights.pt"), str(straight / "weights.pt")
    ).stdout
    rows = [line.split("|")[2:7] for line in table.splitlines() if line.startswith(f"| {tmp_path}")]
    assert len(rows) == 2 and "held out" not in table  # the whole data set, no split
    errors = [[float(cell.strip().rstrip(" %")) for cell in row] for row in rows]
    assert errors[1][:3] != errors[0][:3] and all(0 <= e[3] <= 100 for e in errors)
    evaluation = straight / "stochastic-gen_s2_step6.json"
    _run("-m", "occrl.cli", "eval", "--method", "stochastic-gen", "--stage", "2", "--tasks", "2", "--workers", "1", "--no-progress",
         "--weights", str(straight / "weights_step6.pt"), "--out", str(evaluation))  # fmt: skip
    out = _run("scripts/offline_imitation.py", "--plot", str(tmp_path / "curves.png"), str(straight), str(resumed)).stdout
    assert "wrote" in out and (tmp_path / "curves.png").stat().st_size > 10_000
    saves = [straight / "weights_step3.pt", straight / "weights_step6.pt"]
    _run("scripts/offline_imitation.py", "--average", str(tmp_path / "average.pt"), *map(str, saves))
    average = torch.load(tmp_path / "average.pt", weights_only=False)["model"]
    three, six = (torch.load(f, weights_only=False)["model"] for f in saves)
    moved = [k for k in average if three[k].is_floating_point() and not torch.equal(three[k], six[k])]
    assert moved and all(torch.allclose(average[k], (three[k] + six[k]) / 2) for k in moved)


@pytest.mark.integration
def test_a_data_run_that_dropped_iterations_is_refused(tmp_path):
    data = tmp_path / "data"
    _data_run(data, buffer_iters=1)
    bad = _run("scripts/offline_imitation.py", "--data", str(data), "--out", str(tmp_path / "o"), check=False)
    assert bad.returncode != 0 and "holds 1 of the run's 2 iterations" in bad.stderr


@pytest.mark.integration
def test_first_iterations_reads_the_start_of_a_data_run_and_refuses_more_than_it_has(tmp_path):
    data = tmp_path / "data"
    _data_run(data, buffer_iters=10)
    whole = _run("scripts/offline_imitation.py", "--data", str(data), "--summary").stdout
    first = _run("scripts/offline_imitation.py", "--data", str(data), "--summary", "--first-iterations", "1").stdout
    assert "2 iterations" in whole and "8 labelled sequences, 64 labelled frames" in whole
    assert "1 iterations" in first and "4 labelled sequences, 32 labelled frames" in first
    bad = _run("scripts/offline_imitation.py", "--data", str(data), "--summary", "--first-iterations", "3", check=False)
    assert bad.returncode != 0 and "has collected only 2 iterations" in bad.stderr


@pytest.mark.integration
def test_data_runs_of_the_same_settings_are_fitted_together_and_others_refused(tmp_path):
    first, second, other = tmp_path / "first", tmp_path / "second", tmp_path / "other"
    _data_run(first, 10)
    _data_run(second, 10, "--seed", "8", "--iterations", "1")
    out = _run("scripts/offline_imitation.py", "--data", str(first), str(second), "--summary").stdout
    lines = out.splitlines()
    assert lines[0].startswith(f"{first}: 2 iterations") and "8 labelled sequences" in lines[0]
    assert lines[1].startswith(f"{second}: 1 iterations") and "4 labelled sequences" in lines[1]
    assert lines[2] == "together: 12 labelled sequences, 96 labelled frames"
    fitted = _run(
        "scripts/offline_imitation.py", "--data", str(first), str(second), "--init-weights", str(first / "weights.pt"),
        "--steps", "2", "--save-every", "2", "--log-every", "2", "--out", str(tmp_path / "fit"),
    ).stdout  # fmt: skip
    assert "11 sequences to fit, 1 held out" in fitted
    note = torch.load(tmp_path / "fit" / "weights.pt", weights_only=False)["meta"]["note"]
    assert f"on {first}, {second}" in note
    # the same teacher's labels whether its motion was disturbed (DART) or not
    teacher = ("--imitation-teacher", "clearing-observed", "--collector", "single", "--imitation-beta-min", "1",
               "--imitation-beta-iters", "0", "--iterations", "1")  # fmt: skip
    plain, disturbed = tmp_path / "plain", tmp_path / "disturbed"
    _data_run(plain, 10, *teacher)
    _data_run(disturbed, 10, *teacher, "--teacher-action-noise", "0.1")
    mixed = _run("scripts/offline_imitation.py", "--data", str(plain), str(disturbed), "--summary", check=False)
    assert mixed.returncode == 0 and "together:" in mixed.stdout, mixed.stderr
    takeover = _run("scripts/offline_imitation.py", "--data", str(disturbed), "--takeover").stdout
    assert "| learner's steps before the teacher | demonstrations |" in takeover
    _data_run(other, 10, "--heatmap-coeff", "0", "--iterations", "1")
    bad = _run("scripts/offline_imitation.py", "--data", str(first), str(other), "--summary", check=False)
    assert bad.returncode != 0 and "collected with other settings" in bad.stderr and "heatmap_coeff" in bad.stderr


def test_takeover_table_counts_each_demonstration_by_the_teachers_first_frame():
    """--takeover's table: a demonstration is a labelled episode; it is counted in the band of its
    first labelled frame's step, with the teacher's first three forward commands from there."""
    import sys

    from tensordict import TensorDict

    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        from offline_imitation import takeover_table
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    is_init, weight, action = torch.zeros(2, 20, 1, dtype=torch.bool), torch.zeros(2, 20), torch.zeros(2, 20, 4)
    is_init[0, 0] = is_init[0, 10] = is_init[1, 0] = True
    weight[0, 0:8] = 1.0  # episode 1: the teacher from its start, moving forward
    action[0, 0:3, 0] = 0.5
    weight[0, 17:20] = 1.0  # episode 2: the learner for 7 steps first, then the teacher backing out twice
    action[0, 17:20, 0] = torch.tensor([-1.0, -0.5, 0.0])
    # world 1: an episode the teacher never labelled (not counted)
    data = TensorDict({"is_init": is_init, "expert_weight": weight, "expert_action": action}, batch_size=[2, 20])
    lines = takeover_table(data).splitlines()
    assert lines[2] == "| 0 | 1 | 0.0 % | +0.50 |"
    assert lines[3] == "| 6-10 | 1 | 66.7 % | -0.50 |"
    assert len(lines) == 5 and lines[4].startswith("(0 labelled episodes began before")


@pytest.mark.integration
def test_heatmap_coeff_trains_the_heatmap_head_on_the_stored_targets_and_old_fits_resume(tmp_path):
    data = tmp_path / "data"
    _data_run(data, 10, "--heatmap-coeff", "0")  # as the demonstrations' data runs: no heat-map term
    start = torch.load(data / "weights.pt", weights_only=False)["model"]
    fit = ["scripts/offline_imitation.py", "--data", str(data), "--init-weights", str(data / "weights.pt"), "--steps", "2"]
    fit += ["--save-every", "2", "--log-every", "2"]
    _run(*fit, "--out", str(tmp_path / "off"))
    _run(*fit, "--heatmap-coeff", "1", "--out", str(tmp_path / "on"))
    off = torch.load(tmp_path / "off" / "weights.pt", weights_only=False)["model"]
    on = torch.load(tmp_path / "on" / "weights.pt", weights_only=False)["model"]
    head = [k for k in start if k.startswith("heatmap_head.")]  # the head proper ("heatmap." includes the shared trunk)
    assert head and all(torch.equal(off[k], start[k]) for k in head)  # the data run's 0: the head untouched
    assert not all(torch.equal(on[k], start[k]) for k in head)  # the stored target maps train it
    bad = _run(*fit, "--heatmap-coeff", "-0.5", "--out", str(tmp_path / "bad"), check=False)
    assert bad.returncode != 0 and "--heatmap-coeff must be >= 0, or -1" in bad.stderr
    # a fit checkpointed before the setting existed resumes while the setting keeps its default
    checkpoint = torch.load(tmp_path / "off" / "checkpoint.pt", weights_only=False)
    del checkpoint["state"]["settings"]["heatmap_coeff"]
    torch.save(checkpoint, tmp_path / "off" / "checkpoint.pt")
    assert "resumed" in _run(*fit[:-4], "--steps", "3", "--save-every", "3", "--log-every", "3", "--out", str(tmp_path / "off")).stdout
    assert _run(*fit, "--heatmap-coeff", "1", "--steps", "3", "--out", str(tmp_path / "off"), check=False).returncode != 0
