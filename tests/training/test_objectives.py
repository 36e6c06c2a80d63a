import pytest
import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.objectives import PPOHeatmapLoss, compute_advantages, heatmap_bce


@pytest.fixture(scope="module")
def batch():
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    env = make_env(batch_size=3, stage=2, seed=1).append_transform(net.make_primer())
    with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
        data = env.rollout(6, net.policy, break_when_any_done=False)
    return net, compute_advantages(net, data)


def test_loss_terms_and_their_coefficients(batch):
    net, data = batch
    full = PPOHeatmapLoss(net)(data.copy())
    assert set(k for k in full.keys() if k.startswith("loss_")) == {"loss_objective", "loss_critic", "loss_entropy", "loss_heatmap"}
    double = PPOHeatmapLoss(net, heatmap_coeff=2.0, critic_coeff=1.0, entropy_coeff=0.02)(data.copy())
    for key in ("loss_heatmap", "loss_critic", "loss_entropy"):
        assert double[key].item() == pytest.approx(2 * full[key].item(), rel=1e-5)
    # the heat-map term is c3 x the pixel-wise BCE against the privileged label
    with torch.no_grad():
        td = data.copy()
        from torchrl.modules import set_recurrent_mode

        with set_recurrent_mode(True):
            td = net.trunk(td)
        bce = heatmap_bce(net.heatmap_head(td)["heatmap_logits"], td["privileged", "heatmap_target"])
    assert full["loss_heatmap"].item() == pytest.approx(bce.item(), rel=1e-5)
    # at the collecting policy the ratio is 1: the clipped objective is minus the mean normalised advantage (0)
    assert abs(full["loss_objective"].item()) < 1e-4


def test_gradients_flow_through_time_in_the_lstm(batch):
    net, data = batch
    loss = PPOHeatmapLoss(net)
    net.zero_grad()
    # a loss on the last step only: its gradient reaches the first step's input through the recurrence
    td = data.copy()
    td["pixels"] = td["pixels"].clone().requires_grad_(True)
    from torchrl.modules import set_recurrent_mode

    with set_recurrent_mode(True):
        out = net.trunk(td)
    out["belief"][:, -1].sum().backward()
    assert td["pixels"].grad[:, 0].abs().sum() > 0  # first step influences the last belief
    assert net.lstm.lstm.weight_hh_l0.grad.abs().sum() > 0
    net.zero_grad()
    losses = loss(data.copy())
    sum(v for k, v in losses.items() if k.startswith("loss_")).backward()
    for name, p in net.named_parameters():
        assert p.grad is not None and torch.isfinite(p.grad).all(), name


def test_advantages_use_exact_next_values(batch):
    net, data = batch
    assert data["advantage"].shape == data["state_value"].shape == (3, 6, 1)
    # where no episode ended, next value at t equals the value at t + 1
    done = data["next", "done"].squeeze(-1)
    value = data["state_value"]
    target = data["value_target"]
    adv = data["advantage"]
    assert torch.allclose(target, adv + value, atol=1e-5)
    assert not done[:, :-1].all()


def test_advantages_reuse_embeddings_exactly_across_episode_ends():
    """compute_advantages encodes only the next observations that are not the following step's
    observation; the result equals encoding every next observation."""
    from torchrl.envs.utils import ExplorationType, set_exploration_type
    from torchrl.modules import set_recurrent_mode
    from torchrl.objectives.value.functional import generalized_advantage_estimate

    from occrl.envs import make_env
    from occrl.modules import make_occnet

    torch.manual_seed(0)
    net = make_occnet("paper")
    env = make_env(batch_size=3, stage=1, seed=0, max_steps=4).append_transform(net.make_primer())
    with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
        data = env.rollout(10, net.policy, break_when_any_done=False)
    assert data["next", "done"][:, :-1].sum() >= 3  # episodes end inside the batch
    got = compute_advantages(net, data.clone())
    B, T = data.shape
    with torch.no_grad():
        nxt = data.get("next").reshape(-1).copy()
        nxt.set("is_init", torch.zeros_like(nxt.get("is_init")))
        with set_recurrent_mode(False):
            next_value = net.critic(net.trunk(nxt)).get("state_value").reshape(B, T, 1)
        with set_recurrent_mode(True):
            value = net.critic(net.trunk(data.copy())).get("state_value")
    adv, target = generalized_advantage_estimate(
        0.995, 0.95, value, next_value, data["next", "reward"], data["next", "done"], data["next", "terminated"]
    )
    torch.testing.assert_close(got["advantage"], adv, rtol=0, atol=1e-6)
    torch.testing.assert_close(got["value_target"], target, rtol=0, atol=1e-6)


@pytest.mark.parametrize("to_trunk", [True, False])
def test_critic_to_trunk_decides_whether_the_value_loss_trains_the_trunk(batch, to_trunk):
    """critic_to_trunk=False: the value loss trains the value head alone and leaves its value
    unchanged; the trainer's imitation update trains the trunk with it (the paper)."""
    from occrl.training import get_train_config
    from occrl.training.learner import Learner

    net, data = batch
    encoder = list(net.encoder.parameters())
    head = list(net.critic.parameters())

    def grads(loss):
        net.zero_grad()
        loss.backward()
        return [p.grad is not None and bool(p.grad.abs().sum() > 0) for p in (encoder[0], head[0])]

    loss = PPOHeatmapLoss(net, critic_to_trunk=to_trunk)
    ppo = loss(data.copy())
    assert grads(ppo["loss_critic"]) == [to_trunk, True]
    if not to_trunk:  # the same value either way
        assert ppo["loss_critic"].item() == pytest.approx(PPOHeatmapLoss(net)(data.copy())["loss_critic"].item(), rel=1e-6)
    learner = Learner(net, get_train_config("tiny"), torch.device("cpu"))
    terms = learner.imitation_terms(data.copy().set("expert_action", data["action"]))
    assert grads(terms["loss_critic"]) == [True, True]
    net.zero_grad()
