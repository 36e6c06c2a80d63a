"""Convolutional encoder of the 3x64x64 abstract observation (paper Sec. VI-B)."""

from __future__ import annotations

from typing import Sequence

import torch
from torch import nn

__all__ = ["ConvEncoder"]


class ConvEncoder(nn.Module):
    """``len(channels)`` x [conv 3x3 (padding 1) + batch norm + leaky ReLU + 2x2 max-pool], flattened.

    The paper preset is ``channels=(8, 8, 16)`` on 64x64 inputs: 64 -> 32 -> 16 -> 8, so the
    output has 16 * 8 * 8 = 1024 features.

    ``detail_channels`` > 0 (the ``"fine"`` preset, beyond the paper) reads an image of twice the
    pixels (128x128 over the same window): the stages run on its even rows and columns (the
    paper's 64x64 image, nearly: each pixel a quarter of a coarse pixel off its centre), and a
    detail branch on the whole image (conv 3x3 stride 2 to ``detail_channels`` + leaky ReLU + conv
    3x3 to the first stage's channels, no bias) is added to the first stage's conv before its batch
    norm. The branch's last conv starts at zero, so a new branch changes nothing until it learns;
    the output keeps the paper's 1024 features and the paper's weights load unchanged
    (:func:`occrl.modules.with_finer_input`).

    Examples:
        >>> import torch
        >>> from occrl.modules import ConvEncoder
        >>> enc = ConvEncoder()
        >>> enc(torch.zeros(2, 3, 64, 64)).shape
        torch.Size([2, 1024])
        >>> ConvEncoder(image_size=128, detail_channels=8)(torch.zeros(2, 3, 128, 128)).shape
        torch.Size([2, 1024])
    """

    def __init__(
        self,
        in_channels: int = 3,
        channels: Sequence[int] = (8, 8, 16),
        image_size: int = 64,
        batch_norm: bool = True,
        detail_channels: int = 0,
    ) -> None:
        super().__init__()
        self.detail: nn.Sequential | None = None
        if detail_channels > 0:
            self.detail = nn.Sequential(
                nn.Conv2d(in_channels, detail_channels, kernel_size=3, stride=2, padding=1),
                nn.LeakyReLU(),
                nn.Conv2d(detail_channels, channels[0], kernel_size=3, padding=1, bias=False),
            )
            nn.init.zeros_(self.detail[2].weight)
            image_size //= 2
        layers: list[nn.Module] = []
        c = in_channels
        for out in channels:
            layers.append(nn.Conv2d(c, out, kernel_size=3, padding=1))
            if batch_norm:
                layers.append(nn.BatchNorm2d(out))
            layers += [nn.LeakyReLU(), nn.MaxPool2d(2)]
            c = out
        self.net = nn.Sequential(*layers)
        side = image_size // 2 ** len(channels)
        self.out_features = c * side * side

    def forward(self, pixels: torch.Tensor) -> torch.Tensor:
        lead = pixels.shape[:-3]
        # channels-last activations: same values (to float rounding), ~1.7x (training) to ~2.5x (inference
        # on 4-12 images) faster convolutions on CPU with these few channels (benchmarks/encoder_speed.py)
        x = pixels.reshape(-1, *pixels.shape[-3:]).contiguous(memory_format=torch.channels_last)
        if self.detail is None:
            x = self.net(x)
        else:
            x = self.net[1:](self.net[0](x[..., ::2, ::2]) + self.detail(x))
        return x.reshape(*lead, -1)
