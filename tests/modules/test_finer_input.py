"""The "fine" preset (128 x 128 over the same window) and the conversion of a trained paper network."""

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from occrl.envs import make_env
from occrl.eval.methods import make_method
from occrl.eval.runner import rollout_tasks
from occrl.modules import OccNetConfig, make_occnet, with_finer_input
from occrl.modules.weights import load_weights, save_weights
from occrl.planners import HybridPlanner, render_pixels


def _repeat(x: torch.Tensor) -> torch.Tensor:
    return x.repeat_interleave(2, -1).repeat_interleave(2, -2)


def _inputs(pixels: torch.Tensor) -> TensorDict:
    return TensorDict({"pixels": pixels, "is_init": torch.ones(len(pixels), 1, dtype=torch.bool)}, [len(pixels)])


def test_the_converted_network_computes_the_same_on_the_even_pixels():
    torch.manual_seed(0)
    net = make_occnet("paper")
    for p in net.parameters():  # away from the initialisation, as a trained network
        p.data.add_(0.05 * torch.randn_like(p))
    fine = with_finer_input(net)
    assert fine.config.image_size == 128 and fine.config.detail_channels == 8
    x = torch.rand(4, 3, 128, 128)
    coarse = x[..., ::2, ::2]
    a, b = net.policy(_inputs(coarse)), fine.policy(_inputs(x))
    for key in ("belief", "loc", "scale"):
        assert torch.equal(a[key], b[key])
    assert torch.equal(net.value(_inputs(coarse))["state_value"], fine.value(_inputs(x))["state_value"])
    heat64, heat128 = net.heatmap(_inputs(coarse))["heatmap"], fine.heatmap(_inputs(x))["heatmap"]
    assert heat128.shape[-2:] == (128, 128) and torch.equal(heat128, _repeat(heat64))


def test_the_detail_branch_learns_from_the_first_gradient():
    fine = with_finer_input(make_occnet("paper")).train()
    fine.value(_inputs(torch.rand(4, 3, 128, 128)))["state_value"].sum().backward()
    last = fine.encoder.module.detail[2]  # starts at zero, so the branch adds nothing yet
    assert (last.weight == 0).all() and last.weight.grad.abs().sum() > 0
    # once it has moved, the network reads the odd pixels too
    last.weight.data.normal_(0.0, 0.1)
    y = torch.rand(4, 3, 128, 128)
    with torch.no_grad():
        assert not torch.equal(fine.eval().value(_inputs(y))["state_value"], fine.value(_inputs(_repeat(y[..., ::2, ::2])))["state_value"])


def test_the_conversion_is_reproducible():
    net = make_occnet("paper")
    a, b, c = with_finer_input(net, seed=0), with_finer_input(net, seed=0), with_finer_input(net, seed=1)
    assert all(torch.equal(x, y) for x, y in zip(a.state_dict().values(), b.state_dict().values()))
    assert not torch.equal(a.encoder.module.detail[0].weight, c.encoder.module.detail[0].weight)


def test_conversion_errors_name_the_problem():
    with pytest.raises(ValueError, match="already has a detail branch of 8 channels"):
        with_finer_input(make_occnet("fine"))
    with pytest.raises(ValueError, match="detail_channels must be >= 1"):
        with_finer_input(make_occnet("paper"), detail_channels=0)
    with pytest.raises(ValueError, match="image_size must be a multiple of 16"):
        OccNetConfig(image_size=120, detail_channels=8)
    with pytest.raises(ValueError, match="detail_channels must be >= 0"):
        OccNetConfig(detail_channels=-1)


def test_a_fine_network_runs_in_the_env_the_planner_and_the_evaluation(tmp_path):
    path = tmp_path / "fine.pt"
    save_weights(path, with_finer_input(make_occnet("paper")))
    net = load_weights(path)
    # the planner's imagined image is the env's, at the network's size
    env = make_env(batch_size=2, stage=2, seed=0, heatmap_target=False, size=net.config.image_size)
    td = env.reset()
    assert td["pixels"].shape == (2, 3, 128, 128)
    assert torch.equal(render_pixels(env.base_env.worlds, 128), td["pixels"])
    planner = HybridPlanner(net, m=2, h=2, seed=0)
    out = planner(env.append_transform(net.make_primer()).reset())
    assert out["action"].shape == (2, 4)
    # an evaluation builds the env at the method's size
    method = make_method("stochastic-gen", path)
    assert method.image_size == 128 and make_method("stochastic-gen").image_size == 64
    rollout = rollout_tasks(method, 2, [10_000_000], steps=3)
    assert rollout["pixels"].shape[-2:] == (128, 128) and np.isfinite(rollout["action"].numpy()).all()
