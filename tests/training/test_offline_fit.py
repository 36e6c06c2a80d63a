"""occrl.training.offline_fit (``occrl fit``): fits the data runs' labels, resumes to the same weights,
logs its cost, and refuses data runs it cannot use."""

import json
from pathlib import Path

import pytest
import torch

from occrl.cli import main
from occrl.training.offline_fit import FitConfig, fit_offline


def _data_run(run: Path, buffer_iters: int, *extra: str) -> None:
    """A seconds-long data run of the scripted teacher (it labels every frame)."""
    argv = ["train", "--preset", "tiny", "--imitation-iters", "3", "--iterations", "2", "--lr", "0", "--no-progress"]
    assert main([*argv, "--imitation-buffer-iters", str(buffer_iters), "--run-dir", str(run), *extra]) == 0


def _model(path: Path) -> dict:
    return torch.load(path, weights_only=False)["model"]


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("data") / "data"
    _data_run(run, buffer_iters=10)
    return run


@pytest.mark.integration
def test_fit_lowers_the_validation_nll_resumes_exactly_and_logs_its_cost(data, tmp_path):
    fit_config = dict(data=(str(data),), init_weights=str(data / "weights.pt"), save_every=3, log_every=2)
    straight = fit_offline(FitConfig(**fit_config, steps=6, out=str(tmp_path / "straight")), progress=False)
    assert straight["step"] == 6 and straight["sequences"] == 8  # every frame labelled (scripted): 2 iterations x 4 worlds
    fit_offline(FitConfig(**fit_config, steps=3, out=str(tmp_path / "resumed")), progress=False)
    resumed = fit_offline(FitConfig(**fit_config, steps=6, out=str(tmp_path / "resumed")), progress=False)
    rows = [json.loads(line) for line in (tmp_path / "straight" / "metrics.jsonl").read_text().splitlines()]
    assert [r["step"] for r in rows] == [0, 2, 4, 6] and rows[-1]["validation_nll"] < rows[0]["validation_nll"]
    cost = ("cpu_hours", "wall_hours")
    resumed_rows = [json.loads(line) for line in (tmp_path / "resumed" / "metrics.jsonl").read_text().splitlines()]
    assert [{k: v for k, v in r.items() if k not in cost} for r in resumed_rows] == [
        {k: v for k, v in r.items() if k not in cost} for r in rows
    ]
    assert all(0 < r["cpu_hours"] and 0 < r["wall_hours"] for r in rows[1:] + resumed_rows[1:])
    assert resumed["cpu_hours"] > resumed_rows[1]["cpu_hours"]  # the resumed fit adds to the first part's total
    assert torch.load(tmp_path / "straight" / "weights.pt", weights_only=False)["meta"]["cpu_hours"] == straight["cpu_hours"]
    a, b, start = _model(tmp_path / "straight" / "weights.pt"), _model(tmp_path / "resumed" / "weights.pt"), _model(data / "weights.pt")
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], start[k]) for k in a)  # it learnt
    # a save at step N is the network of a fit of N steps: the total count changes nothing before it
    three = _model(tmp_path / "straight" / "weights_step3.pt")
    assert all(torch.equal(three[k], v) for k, v in _model(tmp_path / "resumed" / "weights_step3.pt").items())
    with pytest.raises(ValueError, match="other settings"):
        fit_offline(FitConfig(**fit_config, steps=7, lr=3e-4, out=str(tmp_path / "straight")), progress=False)


@pytest.mark.integration
def test_the_cli_writes_weights_that_train_starts_from(data, tmp_path, capsys):
    fit = tmp_path / "fit"
    argv = ["fit", "--data", str(data), "--init-weights", str(data / "weights.pt"), "--steps", "2", "--no-progress", "--out", str(fit)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "2 steps on 8 labelled sequences" in printed and " CPU hours; wrote " in printed
    assert main(["fit", "--data", str(data), "--validation-fraction", "1", "--out", str(tmp_path / "bad")]) == 2
    assert "validation_fraction must lie in (0, 1)" in capsys.readouterr().err
    run = tmp_path / "next"
    assert (
        main(
            [
                "train",
                "--preset",
                "tiny",
                "--iterations",
                "1",
                "--no-progress",
                "--init-weights",
                str(fit / "weights.pt"),
                "--run-dir",
                str(run),
            ]
        )
        == 0
    )


@pytest.mark.integration
def test_data_runs_fitted_together_must_share_their_label_settings_and_keep_every_iteration(data, tmp_path):
    second, other, short = tmp_path / "second", tmp_path / "other", tmp_path / "short"
    _data_run(second, 10, "--seed", "8", "--iterations", "1", "--num-envs", "2", "--minibatch-envs", "2")  # num_envs: not a label setting
    out = fit_offline(FitConfig(data=(str(data), str(second)), init_weights=str(data / "weights.pt"), steps=2, out=str(tmp_path / "fit")))
    assert out["sequences"] == 8 + 2
    assert f"on {data}, {second}" in torch.load(tmp_path / "fit" / "weights.pt", weights_only=False)["meta"]["note"]
    _data_run(other, 10, "--heatmap-coeff", "0", "--iterations", "1")
    with pytest.raises(ValueError, match="collected with other settings.*heatmap_coeff"):
        fit_offline(FitConfig(data=(str(data), str(other)), steps=2, out=str(tmp_path / "o")))
    _data_run(short, buffer_iters=1)
    with pytest.raises(ValueError, match="holds 1 of the run's 2 iterations"):
        fit_offline(FitConfig(data=(str(short),), steps=2, out=str(tmp_path / "o")))
