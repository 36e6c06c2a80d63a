"""PPO with the heat-map loss (paper Sec. V, DESIGN section 6).

``loss = loss_objective + loss_critic + loss_entropy + loss_heatmap`` where the first three are
TorchRL's :class:`~torchrl.objectives.ClipPPOLoss` terms (clipped policy loss, c1 x value loss,
-c2 x entropy) and ``loss_heatmap`` is c3 x the pixel-wise binary cross-entropy between the
heat-map head and the true target footprint ``("privileged", "heatmap_target")``.

The shared trunk (encoder + LSTM) runs once per batch in recurrent mode, so gradients of every
term flow back through time; the heads then read ``"belief"`` from the tensordict.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from tensordict import TensorDict, TensorDictBase
from torchrl.modules import set_recurrent_mode
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value.functional import generalized_advantage_estimate

from occrl.envs import world_constants as C
from occrl.modules.occnet import OccNet

__all__ = ["PPOHeatmapLoss", "heatmap_bce", "heatmap_loss", "compute_advantages", "imitation_nll", "belief_detached"]

HEATMAP_TARGET_KEY = ("privileged", "heatmap_target")


def heatmap_bce(logits: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Mean pixel-wise binary cross-entropy of the heat-map (computed on logits for stability).

    Examples:
        >>> import torch
        >>> from occrl.objectives import heatmap_bce
        >>> round(heatmap_bce(torch.zeros(2, 1, 4, 4), torch.full((2, 1, 4, 4), 0.5)).item(), 4)  # ln 2
        0.6931
    """
    return F.binary_cross_entropy_with_logits(logits, target)


def heatmap_loss(heatmap_head, td: TensorDictBase, fraction: float = 1.0) -> torch.Tensor:
    """BCE of the heat-map head on ``td`` (which holds ``"belief"``). With ``fraction`` < 1 only
    a random subset of the frames is decoded: an unbiased estimate at a fraction of the cost
    (the decoder is the most expensive part of the network on a CPU).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import make_occnet
        >>> from occrl.objectives import heatmap_loss
        >>> net = make_occnet("paper")
        >>> td = TensorDict({"belief": torch.zeros(4, 128),
        ...                  ("privileged", "heatmap_target"): torch.zeros(4, 1, 64, 64)}, batch_size=[4])
        >>> full, half = heatmap_loss(net.heatmap_head, td), heatmap_loss(net.heatmap_head, td, fraction=0.5)
        >>> full.shape, bool(full > 0), bool(torch.allclose(full, half))  # identical frames: same estimate
        (torch.Size([]), True, True)
    """
    flat = td.reshape(-1)
    if fraction < 1.0:
        n = flat.shape[0]
        flat = flat[torch.randperm(n)[: max(1, int(round(fraction * n)))]]
    logits = heatmap_head(flat.select("belief").copy()).get("heatmap_logits")
    return heatmap_bce(logits, flat.get(HEATMAP_TARGET_KEY))


def belief_detached(td: TensorDictBase) -> TensorDictBase:
    """A shallow copy of ``td`` whose ``"belief"`` is detached: a head trained on it leaves the
    shared trunk alone (``critic_to_trunk=False``).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.objectives import belief_detached
        >>> td = TensorDict({"belief": torch.ones(2, 3, requires_grad=True)}, batch_size=[2])
        >>> belief_detached(td)["belief"].requires_grad, td["belief"].requires_grad
        (False, True)
    """
    out = td.copy()
    out.set("belief", out.get("belief").detach())
    return out


class PPOHeatmapLoss(ClipPPOLoss):
    """ClipPPOLoss on an :class:`~occrl.modules.OccNet` plus the c3-weighted heat-map BCE.

    Args:
        net: the network; its trunk, actor, critic and heat-map head are trained together.
        clip_epsilon, entropy_coeff (c2), critic_coeff (c1): PPO settings (paper: 0.2, 0.01, 0.5).
        heatmap_coeff: c3 (paper 1.0); ignored for a net without heat-map head.
        gamma: discount (paper 0.995).
        heatmap_fraction: share of frames whose heat-map is decoded for the loss (1.0 = all).
        loss_critic_type: ``"smooth_l1"`` (default; returns reach -100, and an L2 value loss
            would dominate the clipped gradient) or ``"l2"`` (the paper's squared error).
        critic_to_trunk: whether the value loss's gradient reaches the shared trunk (the
            paper: True). False: the value head learns on the trunk's ``"belief"`` detached.

    The input tensordict has batch dims [B, T] (B sequences of T steps) and carries
    ``"advantage"`` and ``"value_target"`` (see :func:`compute_advantages`).

    Examples:
        >>> import torch
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.objectives import PPOHeatmapLoss, compute_advantages
        >>> from torchrl.envs.utils import ExplorationType, set_exploration_type
        >>> net = make_occnet("paper").eval()
        >>> env = make_env(batch_size=2, seed=0).append_transform(net.make_primer())
        >>> with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
        ...     data = env.rollout(4, net.policy, break_when_any_done=False)
        >>> data = compute_advantages(net, data)
        >>> losses = PPOHeatmapLoss(net)(data)
        >>> sorted(k for k in losses.keys() if k.startswith("loss_"))
        ['loss_critic', 'loss_entropy', 'loss_heatmap', 'loss_objective']
    """

    def __init__(
        self,
        net: OccNet,
        clip_epsilon: float = 0.2,
        entropy_coeff: float = 0.01,
        critic_coeff: float = 0.5,
        heatmap_coeff: float = 1.0,
        gamma: float = C.GAMMA,
        normalize_advantage: bool = True,
        heatmap_fraction: float = 1.0,
        loss_critic_type: str = "smooth_l1",
        critic_to_trunk: bool = True,
    ) -> None:
        super().__init__(
            actor_network=net.actor,
            critic_network=net.critic,
            clip_epsilon=clip_epsilon,
            entropy_coeff=entropy_coeff,
            critic_coeff=critic_coeff,
            loss_critic_type=loss_critic_type,
            normalize_advantage=normalize_advantage,
        )
        self.gamma = gamma  # advantages are computed before the loss (compute_advantages)
        # set after ClipPPOLoss.__init__: plain submodules, trained through "belief"
        self.trunk = net.trunk
        self.heatmap_head = net.heatmap_head
        self.heatmap_coeff = heatmap_coeff
        self.heatmap_fraction = heatmap_fraction
        self.critic_to_trunk = critic_to_trunk

    def loss_critic(self, tensordict: TensorDictBase):
        if not self.critic_to_trunk:  # the value head alone: the trunk's features as they are
            tensordict = belief_detached(tensordict)
        return super().loss_critic(tensordict)

    def forward(self, tensordict: TensorDictBase) -> TensorDict:
        td = tensordict.copy()
        with set_recurrent_mode(True):
            td = self.trunk(td)
        out = super().forward(td)
        if self.heatmap_head is not None and self.heatmap_coeff > 0:
            out.set("loss_heatmap", self.heatmap_coeff * heatmap_loss(self.heatmap_head, td, self.heatmap_fraction))
        return out


def _expert_nll(policy_head, tensordict: TensorDictBase, min_scale: float) -> torch.Tensor:
    td = policy_head(tensordict.select("belief").copy())
    loc, scale = td.get("loc"), td.get("scale").clamp_min(min_scale)
    expert = tensordict.get("expert_action")
    nll = -torch.distributions.Normal(loc, scale).log_prob(expert).sum(-1)
    if "expert_weight" not in tensordict.keys():
        return nll.mean()
    weight = tensordict.get("expert_weight").reshape(nll.shape).to(nll.dtype)
    # divided by the number of weighted frames, not the weights' sum: with weights of 0 or 1 the
    # two agree; with graded ones (success_weighting "task") a minibatch of low-weight frames then
    # takes a smaller step, so the weights count across minibatches, not only within one
    return (weight * nll).sum() / (weight > 0).sum().to(nll.dtype).clamp_min(1.0)


def imitation_nll(net: OccNet, tensordict: TensorDictBase, min_scale: float = 0.1) -> torch.Tensor:
    """Negative log-likelihood of ``"expert_action"`` under the policy (DAgger warm start).

    The trunk must already have written ``"belief"`` (with gradients). The standard deviation is
    floored at ``min_scale`` in this loss so imitation does not collapse exploration for PPO.
    With an ``"expert_weight"`` entry (per frame: 0 where there is no label, 1 where there is, or
    a graded weight such as ``TrainConfig.success_weighting="task"``'s) the loss is the weighted
    sum over the frames with a weight above 0, divided by their number.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import make_occnet
        >>> from occrl.objectives import imitation_nll
        >>> net = make_occnet("paper")
        >>> td = TensorDict({"belief": torch.zeros(4, 128), "expert_action": torch.zeros(4, 4)}, batch_size=[4])
        >>> nll = imitation_nll(net, td)
        >>> nll.shape, bool(nll.isfinite()), nll.requires_grad
        (torch.Size([]), True, True)
    """
    return _expert_nll(net.actor.module[0], tensordict, min_scale)


@torch.no_grad()
def compute_advantages(net: OccNet, data: TensorDictBase, gamma: float = C.GAMMA, lmbda: float = 0.95) -> TensorDictBase:
    """Write ``"state_value"``, ``"advantage"`` and ``"value_target"`` into a [B, T] batch.

    Values come from the current net. The value of each ``"next"`` observation is exact: one LSTM
    step from the recurrent state stored after the step (``("next", "recurrent_state_*")``), so
    truncated episodes and batch ends are bootstrapped correctly.

    Examples:
        >>> import torch
        >>> from torchrl.envs.utils import ExplorationType, set_exploration_type
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.objectives import compute_advantages
        >>> net = make_occnet("paper")
        >>> env = make_env(batch_size=1, seed=0).append_transform(net.make_primer())
        >>> with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
        ...     data = env.rollout(3, net.policy, break_when_any_done=False)
        >>> data = compute_advantages(net, data)
        >>> data["advantage"].shape, data["value_target"].shape
        (torch.Size([1, 3, 1]), torch.Size([1, 3, 1]))
    """
    B, T = data.shape
    encoder, lstm = net.trunk[0], net.trunk[1]
    with set_recurrent_mode(True):
        td = net.trunk(data.copy())
    value = net.critic(td).get("state_value")
    # the next observation of step t is step t + 1's observation unless the episode ended at t
    # (or t is the batch's last step): reuse those embeddings, encode only the others
    embed = td.get("embed")
    fresh = data.get(("next", "done")).reshape(B, T).clone()
    fresh[:, -1] = True
    next_embed = torch.empty_like(embed)
    next_embed[:, :-1] = embed[:, 1:]
    next_embed[fresh] = encoder(data.get("next")[fresh].select(*encoder.in_keys).copy()).get("embed")
    nxt = data.get("next").reshape(-1).select("recurrent_state_h", "recurrent_state_c", "is_init").copy()
    nxt.set("is_init", torch.zeros_like(nxt.get("is_init")))
    nxt.set("embed", next_embed.reshape(B * T, -1))
    with set_recurrent_mode(False):
        next_value = net.critic(lstm(nxt)).get("state_value").reshape(B, T, 1)
    adv, target = generalized_advantage_estimate(
        gamma,
        lmbda,
        value,
        next_value,
        data.get(("next", "reward")),
        data.get(("next", "done")),
        data.get(("next", "terminated")),
    )
    data.set("state_value", value)
    data.set("advantage", adv)
    data.set("value_target", target)
    return data
