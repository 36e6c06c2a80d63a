import json

import numpy as np
import pytest

from occrl.cli import main
from occrl.envs import observation_from_detections


def test_eval_writes_json(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["eval", "--method", "scripted", "--tasks", "3", "--batch", "3", "--out", str(out), "--no-progress"]) == 0
    data = json.loads(out.read_text())
    assert data["tasks"] == 3 and len(data["episodes"]) == 3 and 0 <= data["success_rate"] <= 1
    assert (data["timing"], data["batch"]) == ("episode", 3)  # each task's own episode, 3 at a time
    assert "mean time per task" in capsys.readouterr().out


@pytest.mark.integration
def test_eval_runs_any_hybrid_mxh(tmp_path, capsys):
    # beyond the papers' four: hybrid-1x1 plans one roll-out of one step per root, one world per task
    out = tmp_path / "r.json"
    assert main(["eval", "--method", "hybrid-1x1", "--tasks", "2", "--batch", "2", "--out", str(out), "--no-progress"]) == 0
    data = json.loads(out.read_text())
    assert (data["method"], data["tasks"], data["batch"], data["network"]) == ("hybrid-1x1", 2, 1, "occnet-selfimit")
    assert main(["eval", "--method", "hybrid-0x4", "--tasks", "1"]) == 2
    assert "any hybrid-MxH" in capsys.readouterr().err


def test_bad_input_is_an_error_message_not_a_traceback(tmp_path, capsys):
    assert main(["eval", "--method", "telepathy", "--tasks", "1"]) == 2
    assert "unknown method" in capsys.readouterr().err
    assert main(["train", "--preset", "huge", "--run-dir", str(tmp_path)]) == 2
    assert "unknown training preset" in capsys.readouterr().err
    assert main(["eval", "--method", "stochastic-gen", "--weights", str(tmp_path / "none.pt"), "--tasks", "1", "--no-progress"]) == 2
    assert "no checkpoint" in capsys.readouterr().err
    assert main(["train", "--preset", "tiny", "--replay-stage-workers", "-1", "--run-dir", str(tmp_path / "run")]) == 2
    assert "--replay-stage-workers: -1 is out of range; allowed: an integer >= 0" in capsys.readouterr().err
    assert main(["train", "--preset", "tiny", "--promotion-eval-tasks", "0", "--run-dir", str(tmp_path / "run")]) == 2
    assert "--promotion-eval-tasks: 0 is out of range; allowed: an integer >= 1" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["eval", "--method", "scripted", "--tasks", "0"], "--tasks: 0 is out of range; allowed: an integer >= 1"),
        (["eval", "--method", "scripted", "--tasks", "ten"], "--tasks: 'ten' is not an integer"),
        (["eval", "--method", "scripted", "--noise", "nan"], "--noise: nan is not a finite number"),
        (["eval", "--method", "scripted", "--noise", "2"], "--noise: 2 is out of range; allowed: a number in [0, 1]"),
        (["eval", "--method", "scripted", "--workers", "-3"], "--workers: -3 is out of range"),
        (["eval", "--method", "scripted", "--batch", "0"], "--batch: 0 is out of range"),
        (["eval", "--method", "scripted", "--seed", "-1"], "--seed: -1 is out of range"),
        (["eval", "--sweep", "--chunk", "0"], "--chunk: 0 is out of range"),
        (["eval", "--method", "scripted", "--objects", "5-3", "--tasks", "1"], "--objects must be a count >= 1 or a range"),
        (["eval", "--method", "scripted", "--objects", "0", "--tasks", "1"], "--objects must be a count >= 1 or a range"),
        (["demo", "--tasks", "-1"], "--tasks: -1 is out of range"),
        (["demo", "--fps", "0"], "--fps: 0 is out of range; allowed: a number > 0"),
        (["train", "--preset", "tiny", "--run-dir", "x", "--num-envs", "0"], "--num-envs: 0 is out of range"),
        (["train", "--preset", "tiny", "--run-dir", "x", "--max-hours", "-1"], "--max-hours: -1 is out of range"),
        (["train", "--preset", "tiny", "--run-dir", "x", "--checkpoint-every", "inf"], "--checkpoint-every: inf is not a finite number"),
    ],
)
def test_bad_numbers_get_one_line_errors(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("method", ["scripted", "clearing"])
def test_demo_writes_summary_gif_and_strip(tmp_path, method):
    assert main(["demo", "--method", method, "--tasks", "1", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "demo_summary.json").read_text())
    assert len(summary["tasks"]) == 1
    assert (tmp_path / "demo.gif").stat().st_size > 1000 and (tmp_path / "demo_strip.png").stat().st_size > 1000


@pytest.mark.parametrize(
    "detections, message",
    [
        ([{"type_id": 2, "pose": (0.0, 0.1, float("nan")), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]}], "finite"),
        ([{"type_id": 2, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0]]}], "vertices"),
        ([{"type_id": k, "pose": (0.0, 0.1, 0.0), "vertices": [[0, 0], [0.02, 0], [0, 0.02]]} for k in range(11)], "at most 10"),
    ],
)
def test_malformed_detections_are_rejected(detections, message):
    with pytest.raises(ValueError, match=message):
        observation_from_detections(
            (0.0, -0.1, 0.0), 0.085, detections, target_type=1, target_vertices=np.array([[0, 0], [0.02, 0], [0, 0.02]])
        )


def assert_eval_refuses(bad: list[str], message: str, tmp_path, capsys) -> None:
    """``occrl eval`` with the arguments ``bad`` exits with status 2, says ``message`` and writes no result."""
    capsys.readouterr()
    assert main(["eval", *bad, "--tasks", "1", "--no-progress", "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.integration
def test_eval_inference_backend_is_recorded_and_checked(tmp_path, capsys):
    pytest.importorskip("onnxruntime")
    out = tmp_path / "onnx.json"
    args = ["eval", "--method", "hybrid-2x2", "--stage", "1", "--objects", "1-1", "--tasks", "1", "--no-progress"]
    assert main([*args, "--inference", "onnxruntime", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["inference"] == "onnxruntime"
    for bad, message in (
        (["--method", "scripted", "--inference", "onnxruntime"], "applies to a single hybrid method"),
        (["--method", "hybrid-4x4", "--inference", "tensorrt"], "invalid choice: 'tensorrt'"),
    ):
        assert_eval_refuses(bad, message, tmp_path, capsys)


def test_version(capsys):
    import occrl

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"occrl {occrl.__version__}"


@pytest.mark.parametrize("fmt, head", [("markdown", "| method | network |"), ("csv", "method,network,world,stage")])
def test_eval_prints_a_table(fmt, head, capsys):
    assert main(["eval", "--method", "scripted", "--tasks", "2", "--batch", "2", "--no-progress", "--format", fmt]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out[0].startswith(head) and "scripted" in out[-1]
    assert len(out) == (3 if fmt == "markdown" else 2)


def test_bench_names_the_available_benchmarks(capsys):
    assert main(["bench", "no_such_benchmark"]) == 2
    err = capsys.readouterr().err
    assert "no benchmark 'no_such_benchmark'" in err and "env_throughput" in err


@pytest.mark.integration
def test_train_ends_with_a_one_screen_summary(tmp_path, capsys):
    assert main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "run"), "--iterations", "2", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert f"run {tmp_path / 'run'} (preset tiny, seed 0): 2 iterations, 64 frames" in out
    assert "curriculum: stage 1" in out and "(run the same command to resume)" in out


def test_sweep_shows_one_bar_and_ends_with_its_tables(tmp_path, capsys):
    from occrl.eval.sweep import run_sweep, summarize_sweep, sweep_tables

    run_sweep(["scripted"], tmp_path, tasks=2, sweeps=("clutter",), values={"clutter": [1.0, 2.0]}, progress=True)
    err = capsys.readouterr().err
    assert "sweep (2 points)" in err and "4/4" in err  # one bar over every task of every point
    assert "scripted stage" not in err  # no bar per point
    table = sweep_tables(summarize_sweep(tmp_path))
    assert table.startswith("success (%) against clutter (2 tasks per point):") and "| scripted |" in table


def test_every_training_setting_is_documented_and_settable_from_the_command_line():

    from occrl.cli import make_parser
    from occrl.training import TrainConfig

    docs = TrainConfig.field_docs()
    kinds = TrainConfig.setting_types()  # the flat settings, one option each (TrainConfig.flat_settings)
    assert set(docs) == set(kinds) and all(len(d) > 5 for d in docs.values())  # a docstring per setting
    samples = {bool: ("--no-{}", False), int: ("--{}", "3"), float: ("--{}", "0.5"), str: ("--{}", None)}
    from occrl.modules import PRESETS
    from occrl.training.config import SETTING_CHOICES

    for name, type_name in kinds.items():
        if name == "preset":
            continue
        kind = {"bool": bool, "int": int, "float": float, "str": str}[type_name]
        flag, value = samples[kind]
        flag = flag.format(name.replace("_", "-"))
        if kind is str:
            value = (list(PRESETS) if name == "net_preset" else SETTING_CHOICES.get(name, ("cpu",)))[-1]
        argv = ["train", "--run-dir", "x", flag] + ([] if kind is bool else [value])
        args = make_parser().parse_args(argv)
        expected = {bool: False, int: 3, float: 0.5, str: value}[kind]
        assert getattr(args, name) == expected, name


@pytest.mark.integration
def test_train_options_reach_the_config(tmp_path, capsys):
    assert main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "r"), "--iterations", "1", "--lr", "0.002",
                 "--no-heatmap", "--num-envs", "2", "--no-progress"]) == 0  # fmt: skip
    from occrl.training.checkpoint import load_checkpoint

    cfg = load_checkpoint(tmp_path / "r" / "checkpoint.pt")["train_config"]
    assert cfg["lr"] == 0.002 and cfg["heatmap"] is False and cfg["num_envs"] == 2 and cfg["preset"] == "tiny"
    assert main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "s"), "--gamma", "0"]) == 2
    assert "--gamma: 0 is out of range; allowed: a number in (0, 1]" in capsys.readouterr().err


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--world", "mujoco"], "--world mujoco"),
        (["--stage", "3"], "--stage"),
        (["--objects", "5"], "--objects"),
        (["--method", "greedy"], "--method"),
    ],
)
def test_a_sweep_refuses_the_flags_it_would_ignore(tmp_path, capsys, flags, named):
    assert main(["eval", "--sweep", "--methods", "scripted", "--out", str(tmp_path / "out"), *flags]) == 2
    assert f"drop {named}" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # nothing run, nothing written


def test_a_stop_signal_that_a_library_turns_into_another_error_still_stops_cleanly(tmp_path, capsys, monkeypatch):
    """SIGTERM landing while TorchRL's multi-process collector starts its workers comes out of it
    as a RuntimeError, not the KeyboardInterrupt the signal handler raised: still a clean stop."""
    import os
    import signal

    from occrl.training import Trainer

    def train_then_signal_inside_a_library(self, iterations=None, max_seconds=None):
        try:
            self.save()  # the checkpoint a resumed run starts from
            os.kill(os.getpid(), signal.SIGTERM)  # the handler raises KeyboardInterrupt here
        except KeyboardInterrupt:
            raise RuntimeError("Converting a tensordict to boolean value is not permitted") from None

    def train_with_a_real_error(self, iterations=None, max_seconds=None):
        raise RuntimeError("a genuine failure")

    def signal_then_fail_to_save(self, iterations=None, max_seconds=None):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
        finally:
            raise OSError("No space left on device")  # the checkpoint could not be written: not a clean stop

    handlers = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    try:
        monkeypatch.setattr(Trainer, "train", train_then_signal_inside_a_library)
        assert main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "run"), "--no-progress"]) == 130
        err = capsys.readouterr().err
        assert "stopped (SIGTERM); checkpoint of iteration 0 on disk" in err and "RuntimeError from a library while stopping" in err
        monkeypatch.setattr(Trainer, "train", train_with_a_real_error)  # no signal: the error is the error
        with pytest.raises(RuntimeError, match="a genuine failure"):
            main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "run2"), "--no-progress"])
        monkeypatch.setattr(Trainer, "train", signal_then_fail_to_save)
        with pytest.raises(OSError, match="No space left"):
            main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "run3"), "--no-progress"])
    finally:
        signal.signal(signal.SIGTERM, handlers[0])
        signal.signal(signal.SIGINT, handlers[1])
