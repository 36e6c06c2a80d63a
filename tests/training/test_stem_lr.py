"""The fine network's stem learns at its own rate (TrainConfig.stem_lr)."""

import pytest
import torch

from occrl.modules import make_occnet, with_finer_input
from occrl.training.config import get_train_config
from occrl.training.learner import Learner


def test_the_stem_and_the_conv_it_feeds_get_their_own_learning_rate():
    net = with_finer_input(make_occnet("paper"))
    learner = Learner(net, get_train_config("tiny", optimizer="adam", lr=3e-5, stem_lr=3e-4), torch.device("cpu"))
    stem, rest = learner.optimizer.param_groups
    assert stem["lr"] == 3e-4 and rest["lr"] == 3e-5
    encoder = net.encoder.module
    assert {id(p) for p in stem["params"]} == {id(p) for layer in (encoder.stem, encoder.stage_convs[0]) for p in layer.parameters()}
    assert len(stem["params"]) + len(rest["params"]) == len(list(net.parameters()))
    # without stem_lr one group at lr, as before
    (only,) = Learner(net, get_train_config("tiny", optimizer="adam", lr=3e-5), torch.device("cpu")).optimizer.param_groups
    assert only["lr"] == 3e-5


def test_stem_lr_needs_a_network_with_a_stem():
    with pytest.raises(ValueError, match="stem_lr=0.0003 needs a network with a stem"):
        Learner(make_occnet("paper"), get_train_config("tiny", stem_lr=3e-4), torch.device("cpu"))
