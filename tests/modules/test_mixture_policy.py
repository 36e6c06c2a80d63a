"""The mixture policy (beyond the paper): a network whose policy is a mixture of Gaussians."""

import pytest
import torch
from tensordict import TensorDict
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.baselines import NetPolicy
from occrl.envs import Scene, make_env
from occrl.modules import GaussianMixture, MixturePolicyHead, OccNetConfig, make_occnet, with_mixture_policy
from occrl.modules.heads import PolicyHead
from occrl.modules.weights import load_weights, save_weights
from occrl.objectives import PPOHeatmapLoss, compute_advantages, imitation_nll
from occrl.planners import HybridPlanner


def observation(batch=2, seed=0):
    g = torch.Generator().manual_seed(seed)
    return TensorDict({"pixels": torch.rand(batch, 3, 64, 64, generator=g), "is_init": torch.ones(batch, 1, dtype=torch.bool)}, [batch])


def test_the_config_refuses_no_components():
    with pytest.raises(ValueError, match="policy_components must be >= 1"):
        OccNetConfig(policy_components=0)
    with pytest.raises(ValueError, match="components >= 2"):
        MixturePolicyHead(components=1)


def test_a_mixture_fits_two_plans_where_one_gaussian_learns_their_average():
    # the same belief labelled half the time "left" (-0.6) and half "right" (+0.6) in the first action dimension
    torch.manual_seed(0)
    belief = torch.zeros(64, 8)
    labels = torch.zeros(64, 4)
    labels[:, 0] = torch.where(torch.arange(64) % 2 == 0, -0.6, 0.6)
    labels[:, 1:] = 0.1

    def fit(head, mixture):
        opt = torch.optim.Adam(head.parameters(), lr=1e-2)
        for _ in range(300):
            out = head(belief)
            loc, scale = out[0], out[1].clamp_min(0.05)
            if mixture:
                nll = -GaussianMixture(loc, scale, out[2]).log_prob(labels).mean()
            else:
                nll = -torch.distributions.Normal(loc, scale).log_prob(labels).sum(-1).mean()
            opt.zero_grad()
            nll.backward()
            opt.step()
        return float(nll.detach())

    gaussian, mixture = PolicyHead(8, (32,)), MixturePolicyHead(8, (32,), components=2)
    with torch.no_grad():  # two components that differ at the start (as with_mixture_policy's offsets make them)
        mixture.net[-1].bias[0] -= 0.3
        mixture.net[-1].bias[8] += 0.3
    nll_gaussian, nll_mixture = fit(gaussian, False), fit(mixture, True)
    assert nll_mixture < nll_gaussian - 2.0
    with torch.no_grad():
        assert abs(float(gaussian(belief[:1])[0][0, 0])) < 0.1  # the average of the two plans, which neither takes
        loc, _, logits = mixture(belief[:1])
        dist = GaussianMixture(loc, torch.full_like(loc, 0.05), logits)
        assert abs(abs(float(dist.deterministic_sample[0, 0])) - 0.6) < 0.05  # one of the plans
        assert sorted(round(float(x), 1) for x in loc[0, :, 0]) == [-0.6, 0.6]


def test_a_converted_network_starts_as_the_paper_network():
    net = make_occnet("paper")
    same = with_mixture_policy(net, components=3, spread=0.0)
    td = observation()
    ref, out = net.policy(td.clone()), same.policy(td.clone())
    for k in range(3):
        assert torch.allclose(out["loc"][:, k], ref["loc"]) and torch.allclose(out["scale"][:, k], ref["scale"])
    action = torch.rand(2, 4) * 2 - 1
    gauss = torch.distributions.Normal(ref["loc"], ref["scale"]).log_prob(action).sum(-1)
    mix = GaussianMixture(out["loc"], out["scale"], out["mixture_logits"]).log_prob(action)
    assert torch.allclose(gauss, mix, atol=1e-5)
    for key in ("state_value", "heatmap"):  # everything else is the paper network's
        a = (net.value if key == "state_value" else net.heatmap)(td.clone())[key]
        b = (same.value if key == "state_value" else same.heatmap)(td.clone())[key]
        assert torch.equal(a, b)
    spread = with_mixture_policy(net, components=3, spread=0.05, seed=1)
    loc = spread.policy(td.clone())["loc"]
    assert not torch.allclose(loc[:, 0], loc[:, 1]) and (loc - ref["loc"][:, None]).abs().max() < 0.1
    assert torch.equal(loc, with_mixture_policy(net, components=3, spread=0.05, seed=1).policy(td.clone())["loc"])  # seeded
    with pytest.raises(ValueError, match="already a mixture of 3"):
        with_mixture_policy(spread)


def test_weights_files_keep_the_components(tmp_path):
    net = with_mixture_policy(make_occnet("paper"), components=4, spread=0.05)
    save_weights(tmp_path / "w.pt", net)
    loaded = load_weights(tmp_path / "w.pt")
    assert loaded.config == make_occnet("mixture").config
    td = observation()
    assert torch.equal(net.policy(td.clone())["loc"], loaded.policy(td.clone())["loc"])


def test_the_mixture_trains_with_ppo_and_imitation():
    torch.manual_seed(0)
    net = make_occnet("mixture").eval()
    env = make_env(batch_size=2, seed=0).append_transform(net.make_primer())
    with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
        data = env.rollout(4, net.policy, break_when_any_done=False)
    assert data["action"].shape == (2, 4, 4) and data["action_log_prob"].isfinite().all()
    data = compute_advantages(net, data)
    losses = PPOHeatmapLoss(net)(data)
    total = sum(v for k, v in losses.items() if k.startswith("loss_"))
    total.backward()
    head = net.actor.module[0].module.net[-1]
    assert head.weight.grad is not None and head.weight.grad.abs().sum() > 0
    td = TensorDict({"belief": torch.zeros(4, 128), "expert_action": torch.zeros(4, 4)}, batch_size=[4])
    nll = imitation_nll(net, td)
    assert nll.isfinite() and nll.requires_grad


def test_net_policy_samples_a_mixture_reproducibly_and_takes_the_likeliest_mean():
    net = with_mixture_policy(make_occnet("paper", heatmap=False), components=4, spread=0.2)

    def actions(seeds, stochastic):
        env = make_env(batch_size=len(seeds), scenes=[Scene.sample(2, seed=s) for s in seeds]).append_transform(net.make_primer())
        policy = NetPolicy(net, stochastic=stochastic)
        policy.reseed_worlds(seeds)
        with torch.no_grad():
            return env.rollout(3, policy, break_when_any_done=False)

    a, b = actions([5, 6], True)["action"], actions([6], True)["action"]
    assert torch.allclose(a[1], b[0], atol=1e-6)  # world 6's actions whatever shares its batch
    greedy = actions([5], False)
    dist = GaussianMixture(greedy["loc"], greedy["scale"], greedy["mixture_logits"])
    assert torch.allclose(greedy["action"], dist.deterministic_sample)


def test_the_planner_rolls_out_a_mixture_policy_the_same_batched_sequential_and_on_onnx():
    net = with_mixture_policy(make_occnet("paper"), components=4, spread=0.2)
    env = make_env(batch_size=1, scenes=[Scene.sample(2, seed=3)], heatmap_target=False).append_transform(net.make_primer())
    td = env.reset()
    actions = []
    for kwargs in ({}, {"batched": False}, {"inference": "onnxruntime"}):
        planner = HybridPlanner(net, m=2, h=2, seed=0, **kwargs)
        actions.append(planner(td.clone())["action"])
    assert torch.allclose(actions[0], actions[1], atol=1e-5) and torch.allclose(actions[0], actions[2], atol=1e-4)
    from occrl.planners import rhp_batched

    with pytest.raises(ValueError, match=r"noise must be \(roots, m, h, 5\)"):
        rhp_batched(net, [], (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128)), torch.zeros(1, 2, 2, 4))
