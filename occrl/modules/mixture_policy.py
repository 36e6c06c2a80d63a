"""A policy head with several modes: a mixture of K diagonal Gaussians over the action.

Beyond the paper (whose policy is one diagonal Gaussian, :class:`~occrl.modules.PolicyHead`).
A teacher that rearranges clutter chooses among several plans (which blocker to carry where, which
side to pass) that look alike in the 64 x 64 image; one Gaussian fitted to such labels learns their
average, an action none of the plans takes (docs/decisions.md, "the network cannot tell which
blocker the teacher will carry where, and learns an average of its plans"). A mixture can put one
component on each plan and pick among them.

* :class:`MixturePolicyHead`: belief -> ``loc`` (..., K, A), ``scale`` (..., K, A) and
  ``mixture_logits`` (..., K); the means through tanh and the standard deviations through a
  sigmoid, as the paper's head.
* :class:`GaussianMixture`: the distribution TorchRL's ``ProbabilisticActor`` builds from them;
  its deterministic action is the mean of the most probable component.
* :func:`mixture_action`: an action from given noise (a uniform per world picks the component,
  a standard normal draw per dimension samples it), so samplers with their own generators
  (:class:`~occrl.baselines.NetPolicy`) stay reproducible.
* :func:`with_mixture_policy`: a trained paper network turned into one with K components that
  starts as it (every component a copy of its Gaussian, the means moved apart by a little noise so
  that training can separate them).

``OccNetConfig(policy_components=K)`` (K > 1) builds such a network; ``PRESETS["mixture"]`` is K = 4.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import torch
from torch import nn

from occrl.modules.heads import MIN_SCALE, mlp

__all__ = ["MixturePolicyHead", "GaussianMixture", "mixture_action", "with_mixture_policy"]


class MixturePolicyHead(nn.Module):
    """Dense (128, 128) -> K x (2 x action_dim) + K: tanh means, sigmoid standard deviations and
    the components' logits.

    Examples:
        >>> import torch
        >>> from occrl.modules.mixture_policy import MixturePolicyHead
        >>> loc, scale, logits = MixturePolicyHead(components=3)(torch.zeros(5, 128))
        >>> loc.shape, scale.shape, logits.shape
        (torch.Size([5, 3, 4]), torch.Size([5, 3, 4]), torch.Size([5, 3]))
    """

    def __init__(self, in_features: int = 128, hidden: Sequence[int] = (128, 128), action_dim: int = 4, components: int = 4) -> None:
        super().__init__()
        if components < 2:
            raise ValueError(f"a mixture needs components >= 2, got {components} (1 is the paper's PolicyHead)")
        self.components, self.action_dim = int(components), int(action_dim)
        self.net = mlp(in_features, hidden, self.components * (2 * action_dim + 1))

    def forward(self, belief: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        out = self.net(belief)
        K, A = self.components, self.action_dim
        params, logits = out[..., : K * 2 * A], out[..., K * 2 * A :]
        mean, std = params.reshape(*out.shape[:-1], K, 2 * A).chunk(2, dim=-1)
        return torch.tanh(mean), torch.sigmoid(std) + MIN_SCALE, logits


class GaussianMixture(torch.distributions.MixtureSameFamily):
    """A mixture of diagonal Gaussians over the action, built from the head's outputs.

    Examples:
        >>> import torch
        >>> from occrl.modules.mixture_policy import GaussianMixture
        >>> loc = torch.tensor([[[-0.5, 0.0], [0.5, 0.0]]])  # one state, two components in 2-D
        >>> dist = GaussianMixture(loc, torch.full_like(loc, 0.1), torch.tensor([[0.0, 2.0]]))
        >>> dist.deterministic_sample.tolist(), dist.sample().shape
        ([[0.5, 0.0]], torch.Size([1, 2]))
        >>> bool(dist.log_prob(torch.tensor([[0.5, 0.0]])) > dist.log_prob(torch.tensor([[0.0, 0.0]])))
        True
    """

    def __init__(self, loc: torch.Tensor, scale: torch.Tensor, mixture_logits: torch.Tensor) -> None:
        components = torch.distributions.Independent(torch.distributions.Normal(loc, scale), 1)
        super().__init__(torch.distributions.Categorical(logits=mixture_logits), components, validate_args=False)

    @property
    def deterministic_sample(self) -> torch.Tensor:
        """The mean of the most probable component (TorchRL's deterministic exploration)."""
        best = self.mixture_distribution.logits.argmax(-1)
        loc = self.component_distribution.base_dist.loc
        return torch.gather(loc, -2, best[..., None, None].expand(*best.shape, 1, loc.shape[-1])).squeeze(-2)

    @property
    def mode(self) -> torch.Tensor:
        return self.deterministic_sample


def mixture_action(loc: torch.Tensor, scale: torch.Tensor, logits: torch.Tensor, uniform: torch.Tensor, eps: torch.Tensor) -> torch.Tensor:
    """An action of the mixture from given noise: ``uniform`` (...,) in [0, 1) picks the component
    by the inverse of its cumulative probabilities, ``eps`` (..., A) standard normal draws sample it.

    Examples:
        >>> import torch
        >>> from occrl.modules.mixture_policy import mixture_action
        >>> loc = torch.tensor([[[-0.5], [0.5]]]); scale = torch.full_like(loc, 0.1)
        >>> logits = torch.zeros(1, 2)  # equally likely
        >>> mixture_action(loc, scale, logits, torch.tensor([0.2]), torch.tensor([[1.0]])).tolist()
        [[-0.4000000059604645]]
        >>> mixture_action(loc, scale, logits, torch.tensor([0.7]), torch.tensor([[0.0]])).tolist()
        [[0.5]]
    """
    cumulative = torch.softmax(logits, -1).cumsum(-1)
    index = (cumulative < uniform[..., None].to(cumulative.dtype)).sum(-1).clamp(max=logits.shape[-1] - 1)
    gather = index[..., None, None].expand(*index.shape, 1, loc.shape[-1])
    chosen_loc = torch.gather(loc, -2, gather).squeeze(-2)
    chosen_scale = torch.gather(scale, -2, gather).squeeze(-2)
    return chosen_loc + chosen_scale * eps.to(loc.dtype)


@torch.no_grad()
def with_mixture_policy(net, components: int = 4, spread: float = 0.05, seed: int = 0):
    """A network whose policy is a mixture of ``components`` Gaussians and that starts as ``net``.

    Every weight but the policy head's last layer is ``net``'s. Each component's mean and
    standard deviation rows are copies of the Gaussian head's, the components' logits are zero
    (equally likely), and each component's mean bias moves by ``spread`` times a standard normal
    draw (before the tanh) so that the components differ and training can pull them apart; the
    start is then ``net``'s policy blurred by about ``spread`` per action dimension.

    Args:
        net: a network with the paper's Gaussian policy head (``config.policy_components == 1``).
        components: K >= 2.
        spread: the standard deviation of the mean biases' offsets (0: K identical components).
        seed: draws the offsets: the same network and seed give the same result.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import make_occnet
        >>> from occrl.modules.mixture_policy import with_mixture_policy
        >>> net = make_occnet("paper")
        >>> mix = with_mixture_policy(net, components=3, spread=0.0)
        >>> td = lambda: TensorDict({"pixels": torch.rand(2, 3, 64, 64), "is_init": torch.ones(2, 1, dtype=torch.bool)}, [2])
        >>> a = td()
        >>> out, ref = mix.policy(a.clone()), net.policy(a.clone())
        >>> out["loc"].shape, torch.allclose(out["loc"][:, 0], ref["loc"]), torch.allclose(out["loc"][:, 2], ref["loc"])
        (torch.Size([2, 3, 4]), True, True)
    """
    from occrl.modules.occnet import OccNet

    if net.config.policy_components != 1:
        raise ValueError(f"the network's policy is already a mixture of {net.config.policy_components}; give one with the paper's head")
    if components < 2:
        raise ValueError(f"components must be >= 2, got {components}")
    if spread < 0:
        raise ValueError(f"spread must be >= 0, got {spread}")
    mix = OccNet(replace(net.config, policy_components=int(components)))
    head_old = net.actor.module[0].module.net[-1]
    head_new = mix.actor.module[0].module.net[-1]
    own = net.state_dict()
    state = mix.state_dict()
    differ = [k for k, v in state.items() if k not in own or own[k].shape != v.shape]
    last = {id(head_new.weight), id(head_new.bias)}
    params = dict(mix.named_parameters(remove_duplicate=False))
    if any(k not in params or id(params[k]) not in last for k in differ):  # pragma: no cover - a programming error
        raise RuntimeError(f"the paper network's weights do not map onto the mixture: {differ}")
    mix.load_state_dict({k: (state[k] if k in differ else own[k]) for k in state})
    A, K = net.config.action_dim, int(components)
    # rows of the new layer: per component A means and A standard deviations (the old layer's rows), then K logits (zero)
    head_new.weight.zero_()
    head_new.bias.zero_()
    head_new.weight[: K * 2 * A] = head_old.weight.repeat(K, 1)
    head_new.bias[: K * 2 * A] = head_old.bias.repeat(K)
    generator = torch.Generator().manual_seed(int(seed))
    head_new.bias[: K * 2 * A].view(K, 2 * A)[:, :A] += spread * torch.randn(K, A, generator=generator)
    return mix.eval()
