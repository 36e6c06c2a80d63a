"""Training on a device: the network and loss where TrainConfig.device says, collectors on the CPU."""

import pytest
import torch

from occrl.cli import main
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner
from occrl.training import Trainer, get_train_config
from occrl.training.config import training_device

NO_CUDA = not torch.cuda.is_available()


def test_device_names_are_checked():
    assert training_device("cpu") == torch.device("cpu")
    for bad in ("tpu", "gpu", "cuda:x", ""):
        with pytest.raises(ValueError, match="device must be 'cpu', 'cuda' or 'cuda:N'"):
            training_device(bad)


@pytest.mark.skipif(not NO_CUDA, reason="a machine with CUDA accepts it")
def test_asking_for_cuda_without_one_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(ValueError, match="no CUDA device is available here"):
        training_device("cuda")
    with pytest.raises(ValueError, match="no CUDA device"):
        Trainer(get_train_config("tiny", device="cuda"), tmp_path / "a", seed=0, progress=False, tensorboard=False)
    assert not (tmp_path / "a" / "checkpoint.pt").exists()
    assert main(["train", "--preset", "tiny", "--run-dir", str(tmp_path / "b"), "--device", "cuda", "--no-progress"]) == 2
    assert "--device: device 'cuda': no CUDA device is available here" in capsys.readouterr().err


def test_an_explicit_cpu_device_trains_and_a_run_resumes_on_any_device(tmp_path):
    cfg = get_train_config("tiny", device="cpu")
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert tr.device == torch.device("cpu") and tr.acting_net is tr.net  # one network on a CPU run
    tr.train(iterations=2)
    tr.close()
    weights = [p.detach().clone() for p in tr.net.parameters()]
    # the same run folder resumes under another device setting (a machine setting, not a training one)
    from occrl.training.config import same_run_settings

    assert same_run_settings(cfg.to_dict(), get_train_config("tiny", device="cuda:0").to_dict())
    assert not same_run_settings(cfg.to_dict(), get_train_config("tiny", lr=1.0).to_dict())
    again = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert again.iteration == 2 and all(torch.equal(a, b) for a, b in zip(weights, again.net.parameters()))
    again.close()


@pytest.mark.skipif(NO_CUDA, reason="needs a CUDA device")
def test_cuda_training_keeps_the_acting_copy_in_step(tmp_path):  # pragma: no cover - runs on GPU machines
    tr = Trainer(get_train_config("tiny", device="cuda"), tmp_path, seed=0, progress=False, tensorboard=False)
    assert next(tr.net.parameters()).is_cuda and not next(tr.acting_net.parameters()).is_cuda
    tr.train(iterations=2)
    tr.close()
    for a, b in zip(tr.net.state_dict().values(), tr.acting_net.state_dict().values()):
        assert torch.equal(a.cpu(), b)


def test_the_planner_refuses_a_network_off_the_cpu():
    net = make_occnet("paper").to("meta")
    with pytest.raises(ValueError, match="runs its network on the CPU"):
        HybridPlanner(net)


def test_the_update_runs_the_recurrent_layers_in_training_mode_and_restores_them():
    # cuDNN has no LSTM backward in eval mode; the update switches the LSTM alone and switches it back
    from occrl.training.learner import recurrent_layers_training

    net = make_occnet("paper")
    lstm = net.lstm.lstm
    with pytest.raises(RuntimeError, match="inside"):
        with recurrent_layers_training(net):
            assert lstm.training and not net.encoder.training and not net.critic.training
            raise RuntimeError("inside")
    assert not lstm.training and not net.training
    lstm.dropout = 0.1
    with pytest.raises(ValueError, match="without dropout, got dropout=0.1"):
        with recurrent_layers_training(net):
            pass
    assert not lstm.training
