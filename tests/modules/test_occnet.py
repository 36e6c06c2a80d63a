import pytest
import torch
from torch import nn

from occrl.envs import make_env
from occrl.modules import ConvEncoder, HeatmapHead, PolicyHead, ValueHead, make_occnet

# Paper Sec. VI-B, layer by layer (biases included):
ENCODER = (3 * 8 * 9 + 8) + 2 * 8 + (8 * 8 * 9 + 8) + 2 * 8 + (8 * 16 * 9 + 16) + 2 * 16  # convs + batch norms
LSTM = 4 * 128 * (1024 + 128) + 2 * 4 * 128
POLICY = (128 * 128 + 128) + (128 * 128 + 128) + (128 * 8 + 8)
VALUE = (128 * 128 + 128) + (128 * 64 + 64) + (64 + 1)
HEATMAP = (128 * 8 * 8 * 8 + 8 * 8 * 8) + (8 * 8 * 9 + 8) + (8 * 8 * 9 + 8) + (8 * 16 * 9 + 16) + (16 * 1 * 9 + 1)
PAPER_TOTAL = ENCODER + LSTM + POLICY + VALUE + HEATMAP


def test_paper_preset_parameter_count_and_layers():
    net = make_occnet("paper")
    assert net.num_parameters() == PAPER_TOTAL == 720306
    assert make_occnet("paper", heatmap=False).num_parameters() == PAPER_TOTAL - HEATMAP
    convs = [m for m in net.encoder.module.modules() if isinstance(m, nn.Conv2d)]
    assert [c.out_channels for c in convs] == [8, 8, 16] and all(c.kernel_size == (3, 3) for c in convs)
    assert sum(isinstance(m, nn.BatchNorm2d) for m in net.encoder.module.modules()) == 3
    assert net.lstm.lstm.hidden_size == 128 and net.lstm.lstm.input_size == 1024


def test_module_shapes():
    assert ConvEncoder()(torch.zeros(5, 3, 64, 64)).shape == (5, 1024)
    loc, scale = PolicyHead()(torch.randn(7, 128) * 10)
    assert loc.shape == scale.shape == (7, 4)
    assert loc.abs().max() <= 1 and (scale > 0).all() and (scale <= 1.001 + 1e-6).all()
    assert ValueHead()(torch.zeros(3, 128)).shape == (3, 1)
    assert HeatmapHead()(torch.zeros(2, 6, 128)).shape == (2, 6, 1, 64, 64)


def test_policy_value_and_heatmap_on_env_tensordicts():
    net = make_occnet("paper").eval()
    env = make_env(batch_size=3, seed=0).append_transform(net.make_primer())
    td = env.reset()
    out = net.policy(td.copy())
    assert out["action"].shape == (3, 4) and out["action_log_prob"].shape == (3,)
    assert ("next", "recurrent_state_h") in out.keys(True)
    assert net.value(td.copy())["state_value"].shape == (3, 1)
    heat = net.heatmap(td.copy())["heatmap"]
    assert heat.shape == (3, 1, 64, 64) and 0 <= heat.min() and heat.max() <= 1


def test_unknown_preset():
    with pytest.raises(ValueError, match="unknown preset"):
        make_occnet("huge")


def test_the_encoder_can_be_swapped():
    from tensordict.nn import TensorDictModule

    net = make_occnet("paper")
    tiny = TensorDictModule(nn.Sequential(nn.Flatten(-3), nn.LazyLinear(1024)), in_keys=["pixels"], out_keys=["embed"])
    net.trunk[0] = tiny  # the LSTM and the heads keep working
    env = make_env(batch_size=2, seed=0).append_transform(net.make_primer())
    assert net.policy(env.reset())["action"].shape == (2, 4)
