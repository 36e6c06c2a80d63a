import pytest
import torch

from occrl.baselines import NetPolicy
from occrl.envs import make_env
from occrl.modules import make_occnet


def _rollout(policy, net, seeds, steps=4):
    env = make_env(batch_size=len(seeds), seed=seeds).append_transform(net.make_primer())
    policy.reseed_worlds(seeds)
    with torch.no_grad():
        return env.rollout(steps, policy)


def test_greedy_takes_the_mean_and_stochastic_samples_around_it():
    torch.manual_seed(0)
    net = make_occnet("paper", heatmap=False).eval()
    greedy = _rollout(NetPolicy(net, stochastic=False), net, [1, 2])
    assert torch.equal(greedy["action"], greedy["loc"])
    again = _rollout(NetPolicy(net, stochastic=False), net, [1, 2])
    assert torch.equal(greedy["action"], again["action"])  # deterministic
    sampled = _rollout(NetPolicy(net, stochastic=True), net, [1, 2])
    assert not torch.allclose(sampled["action"][:, 0], sampled["loc"][:, 0])
    z = (sampled["action"] - sampled["loc"]) / sampled["scale"]
    assert z.abs().max() < 6  # draws of the policy's Normal


@pytest.mark.integration
def test_stochastic_episodes_follow_their_task_seed():
    torch.manual_seed(0)
    net = make_occnet("paper", heatmap=False).eval()
    policy = NetPolicy(net, stochastic=True)
    a = _rollout(policy, net, [7, 8, 9])
    b = _rollout(policy, net, [9, 3])
    c = _rollout(policy, net, [8])
    assert torch.allclose(a["action"][2], b["action"][0], atol=1e-6)
    assert torch.allclose(a["action"][1], c["action"][0], atol=1e-6)
    assert not torch.allclose(a["action"][0], a["action"][1])


@pytest.mark.integration
def test_spread_scales_the_draws_and_zero_gives_the_mean():
    torch.manual_seed(0)
    net = make_occnet("paper", heatmap=False).eval()
    own = _rollout(NetPolicy(net, stochastic=True), net, [1, 2], steps=1)
    wide = _rollout(NetPolicy(net, stochastic=True, spread=2.0), net, [1, 2], steps=1)
    mean = _rollout(NetPolicy(net, stochastic=True, spread=0.0), net, [1, 2], steps=1)
    greedy = _rollout(NetPolicy(net, stochastic=False), net, [1, 2], steps=1)
    # the same draws (per-task generators), twice as far from the same mean
    assert torch.allclose(wide["action"] - wide["loc"], 2 * (own["action"] - own["loc"]), atol=1e-6)
    assert torch.equal(mean["action"], greedy["action"])


def test_spread_must_be_a_finite_non_negative_number_for_sampled_actions():
    net = make_occnet("paper", heatmap=False).eval()
    for bad in (-0.5, float("nan"), float("inf"), True, "2"):
        with pytest.raises(ValueError, match="spread must be a finite number >= 0"):
            NetPolicy(net, stochastic=True, spread=bad)
    with pytest.raises(ValueError, match="sampled actions only"):
        NetPolicy(net, stochastic=False, spread=2.0)
