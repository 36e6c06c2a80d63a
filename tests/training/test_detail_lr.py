"""The fine network's detail branch learns at its own rate (TrainConfig.detail_lr)."""

import pytest
import torch

from occrl.modules import make_occnet, with_finer_input
from occrl.training.presets import get_train_config
from occrl.training.learner import Learner


def test_the_detail_branch_gets_its_own_learning_rate():
    net = with_finer_input(make_occnet("paper"))
    learner = Learner(net, get_train_config("tiny", optimizer="adam", lr=3e-5, detail_lr=3e-4), torch.device("cpu"))
    detail, rest = learner.optimizer.param_groups
    assert detail["lr"] == 3e-4 and rest["lr"] == 3e-5
    assert {id(p) for p in detail["params"]} == {id(p) for p in net.encoder.module.detail.parameters()}
    assert len(detail["params"]) + len(rest["params"]) == len(list(net.parameters()))
    # without detail_lr one group at lr, as before
    (only,) = Learner(net, get_train_config("tiny", optimizer="adam", lr=3e-5), torch.device("cpu")).optimizer.param_groups
    assert only["lr"] == 3e-5


def test_detail_lr_needs_a_network_with_a_detail_branch():
    with pytest.raises(ValueError, match="detail_lr=0.0003 needs a network with a detail branch"):
        Learner(make_occnet("paper"), get_train_config("tiny", detail_lr=3e-4), torch.device("cpu"))
