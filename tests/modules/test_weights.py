"""Weights files that store network settings occrl no longer has: read at the paper's value, refused otherwise."""

import pytest
import torch

from occrl.modules import make_occnet
from occrl.modules.weights import REMOVED_NET_SETTINGS, CheckpointError, check_architecture, load_weights, save_weights
from occrl.pretrained import available, load_pretrained


def _stored_with(path, **settings):
    torch.manual_seed(3)
    net = make_occnet("paper")
    save_weights(path, net)
    obj = torch.load(path, weights_only=True)
    obj["net_config"].update(settings)
    torch.save(obj, path)
    return net


def test_removed_settings_at_the_papers_value_load_the_same_network(tmp_path):
    path = tmp_path / "old.pt"
    net = _stored_with(path, **REMOVED_NET_SETTINGS)
    loaded = load_weights(path)
    assert loaded.config == net.config
    assert all(torch.equal(a, b) for a, b in zip(net.state_dict().values(), loaded.state_dict().values()))
    check_architecture(net, torch.load(path, weights_only=True)["net_config"], path)  # what resuming a checkpoint checks


@pytest.mark.parametrize("setting,value", [("policy_components", 4), ("detail_channels", 8)])
def test_a_removed_setting_at_another_value_is_refused_naming_the_commit(tmp_path, setting, value):
    path = tmp_path / "experiment.pt"
    net = _stored_with(path, **{setting: value})
    with pytest.raises(CheckpointError, match=f"{setting}={value}.*git checkout 53b1240"):
        load_weights(path)
    with pytest.raises(CheckpointError, match="git checkout 53b1240"):
        load_weights(path, make_occnet("paper"))
    with pytest.raises(CheckpointError, match="git checkout 53b1240"):
        check_architecture(net, torch.load(path, weights_only=True)["net_config"], path)


def test_an_unknown_setting_is_still_refused(tmp_path):
    path = tmp_path / "future.pt"
    _stored_with(path, attention_heads=2)
    with pytest.raises(CheckpointError, match="unknown network settings"):
        load_weights(path)


def test_every_shipped_network_loads():
    for name in available():
        assert load_pretrained(name).config.image_size == 64, name
