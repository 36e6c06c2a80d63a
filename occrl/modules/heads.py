"""The three heads on the LSTM belief (paper Sec. VI-B): policy, value and target heat-map."""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn

__all__ = ["PolicyHead", "ValueHead", "HeatmapHead", "mlp"]

MIN_SCALE = 1e-3  # keeps log-probabilities finite when the sigmoid saturates


def mlp(in_features: int, hidden: Sequence[int], out_features: int) -> nn.Sequential:
    """Dense layers with leaky ReLU between them and a linear output.

    Examples:
        >>> import torch
        >>> from occrl.modules.heads import mlp
        >>> net = mlp(10, (32, 16), 2)  # Linear, LeakyReLU, Linear, LeakyReLU, Linear
        >>> len(net), net(torch.zeros(3, 10)).shape
        (5, torch.Size([3, 2]))
    """
    layers: list[nn.Module] = []
    f = in_features
    for h in hidden:
        layers += [nn.Linear(f, h), nn.LeakyReLU()]
        f = h
    layers.append(nn.Linear(f, out_features))
    return nn.Sequential(*layers)


class PolicyHead(nn.Module):
    """Dense (128, 128) -> 2 x action_dim: tanh means and sigmoid standard deviations.

    Examples:
        >>> import torch
        >>> from occrl.modules import PolicyHead
        >>> loc, scale = PolicyHead()(torch.zeros(5, 128))
        >>> loc.shape, bool((scale > 0).all())
        (torch.Size([5, 4]), True)
    """

    def __init__(self, in_features: int = 128, hidden: Sequence[int] = (128, 128), action_dim: int = 4) -> None:
        super().__init__()
        self.net = mlp(in_features, hidden, 2 * action_dim)

    def forward(self, belief: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        mean, std = self.net(belief).chunk(2, dim=-1)
        return torch.tanh(mean), torch.sigmoid(std) + MIN_SCALE


class ValueHead(nn.Module):
    """Dense (128, 64) -> 1, linear output: the expected return of the observation history.

    Examples:
        >>> import torch
        >>> from occrl.modules import ValueHead
        >>> ValueHead()(torch.zeros(5, 128)).shape
        torch.Size([5, 1])
    """

    def __init__(self, in_features: int = 128, hidden: Sequence[int] = (128, 64)) -> None:
        super().__init__()
        self.net = mlp(in_features, hidden, 1)

    def forward(self, belief: torch.Tensor) -> torch.Tensor:
        return self.net(belief)


class HeatmapHead(nn.Module):
    """Generative head: where the target probably is, as a 64x64 map in the input's frame.

    The belief is projected to a ``channels[0]`` x 8 x 8 grid, then ``len(channels)`` x
    [2x upsample + conv 3x3 + leaky ReLU] (paper: 8, 8, 16 filters) reach 64x64, and a final
    3x3 conv gives one logit per pixel. Returns logits; the heat-map is their sigmoid.

    Examples:
        >>> import torch
        >>> from occrl.modules import HeatmapHead
        >>> HeatmapHead()(torch.zeros(2, 128)).shape
        torch.Size([2, 1, 64, 64])
    """

    def __init__(self, in_features: int = 128, channels: Sequence[int] = (8, 8, 16), image_size: int = 64) -> None:
        super().__init__()
        self.side = image_size // 2 ** len(channels)
        self.c0 = channels[0]
        self.project = nn.Sequential(nn.Linear(in_features, self.c0 * self.side * self.side), nn.LeakyReLU())
        layers: list[nn.Module] = []
        c = self.c0
        for out in channels:
            layers += [nn.Upsample(scale_factor=2, mode="nearest"), nn.Conv2d(c, out, 3, padding=1), nn.LeakyReLU()]
            c = out
        layers.append(nn.Conv2d(c, 1, 3, padding=1))
        self.decode = nn.Sequential(*layers)

    def forward(self, belief: torch.Tensor) -> torch.Tensor:
        lead = belief.shape[:-1]
        x = self.project(belief.reshape(-1, belief.shape[-1])).reshape(-1, self.c0, self.side, self.side)
        out = self.decode(x.contiguous(memory_format=torch.channels_last))  # as in ConvEncoder: faster, same values
        return out.reshape(*lead, *out.shape[1:])
