"""The "wide" preset and with_wider_network: a trained network grown, computing the same."""

import pytest
import torch
from tensordict import TensorDict

from occrl.baselines import NetPolicy
from occrl.envs import make_env
from occrl.modules import PRESETS, make_occnet, with_wider_network
from occrl.modules.weights import load_weights, save_weights
from occrl.planners import HybridPlanner


def _trained_like(seed: int = 0):
    torch.manual_seed(seed)
    net = make_occnet("paper")
    for p in net.parameters():  # away from the initialisation, as a trained network
        p.data.add_(0.05 * torch.randn_like(p))
    return net


def _rollout(net, steps=15):
    env = make_env(batch_size=3, stage=2, seed=[5, 6, 7], heatmap_target=False).append_transform(net.make_primer())
    policy = NetPolicy(net, stochastic=True)
    policy.reseed_worlds([5, 6, 7])
    with torch.no_grad():
        return env.rollout(steps, policy, break_when_any_done=False)


def test_the_wider_network_acts_values_and_maps_as_the_trained_one():
    net = _trained_like()
    wide = with_wider_network(net)
    assert wide.config == PRESETS["wide"]
    assert wide.num_parameters() > 3 * net.num_parameters()
    a, b = _rollout(net), _rollout(wide)
    assert torch.allclose(a["action"], b["action"], atol=1e-5)
    # value and heat-map along the same observations, the recurrent state carried by each net
    obs = a.select("pixels", "is_init")
    with torch.no_grad():
        va, vb = net.value(obs.clone())["state_value"], wide.value(obs.clone())["state_value"]
        ha, hb = net.heatmap(obs.clone())["heatmap"], wide.heatmap(obs.clone())["heatmap"]
    assert torch.allclose(va, vb, atol=1e-5) and torch.allclose(ha, hb, atol=1e-5)


def test_its_new_units_learn():
    wide = with_wider_network(_trained_like())
    td = TensorDict({"pixels": torch.rand(4, 3, 64, 64), "is_init": torch.ones(4, 1, dtype=torch.bool)}, [4])
    wide.train()
    out = wide.policy(td)
    out["loc"].sum().backward()
    lstm = next(m for m in wide.modules() if isinstance(m, torch.nn.LSTM))
    first = next(m for m in wide.modules() if isinstance(m, torch.nn.Linear))  # the policy head's first layer
    assert first.weight.grad[:, 128:].abs().sum() > 0  # the zero weights on the new LSTM units get a gradient
    assert lstm.weight_ih_l0.grad is not None


def test_the_planner_and_weights_files_take_it(tmp_path):
    wide = with_wider_network(_trained_like())
    path = tmp_path / "wide.pt"
    save_weights(path, wide)
    loaded = load_weights(path)
    assert loaded.config == PRESETS["wide"]
    env = make_env(batch_size=1, stage=2, seed=3, heatmap_target=False).append_transform(loaded.make_primer())
    with torch.no_grad():
        td = env.rollout(2, HybridPlanner(loaded, m=2, h=2, seed=0))
    assert td["action"].shape == (1, 2, 4)


def test_sizes_that_do_not_grow_are_refused():
    net = make_occnet("paper")
    with pytest.raises(ValueError, match="conv_channels"):
        with_wider_network(net, conv_channels=(4, 8, 16))
    with pytest.raises(ValueError, match="lstm_hidden"):
        with_wider_network(net, lstm_hidden=64)
    with pytest.raises(ValueError, match="policy_hidden"):
        with_wider_network(net, policy_hidden=(256,))
    with pytest.raises(ValueError, match="mixture"):
        with_wider_network(make_occnet("mixture"))
