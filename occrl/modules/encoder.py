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

    ``stem_channels`` > 0 (the ``"fine"`` preset, beyond the paper) puts a stride-2 stem in front:
    conv 3x3, stride 2 (padding 1) to ``stem_channels`` + leaky ReLU, which halves the input, so a
    128x128 image (twice the pixels over the same window) reaches the stages at 64x64 and the
    output keeps the paper's 1024 features.

    Examples:
        >>> import torch
        >>> from occrl.modules import ConvEncoder
        >>> enc = ConvEncoder()
        >>> enc(torch.zeros(2, 3, 64, 64)).shape
        torch.Size([2, 1024])
        >>> ConvEncoder(image_size=128, stem_channels=8)(torch.zeros(2, 3, 128, 128)).shape
        torch.Size([2, 1024])
    """

    def __init__(
        self,
        in_channels: int = 3,
        channels: Sequence[int] = (8, 8, 16),
        image_size: int = 64,
        batch_norm: bool = True,
        stem_channels: int = 0,
    ) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        c = in_channels
        if stem_channels > 0:
            layers += [nn.Conv2d(c, stem_channels, kernel_size=3, stride=2, padding=1), nn.LeakyReLU()]
            c, image_size = stem_channels, image_size // 2
        for out in channels:
            layers.append(nn.Conv2d(c, out, kernel_size=3, padding=1))
            if batch_norm:
                layers.append(nn.BatchNorm2d(out))
            layers += [nn.LeakyReLU(), nn.MaxPool2d(2)]
            c = out
        self.net = nn.Sequential(*layers)
        self.stem_channels = stem_channels
        side = image_size // 2 ** len(channels)
        self.out_features = c * side * side

    @property
    def stem(self) -> nn.Conv2d | None:
        """The stride-2 stem's conv (None without a stem)."""
        return self.net[0] if self.stem_channels else None

    @property
    def stage_convs(self) -> list[nn.Conv2d]:
        """The conv of each stage, in order (the stem's not included)."""
        convs = [m for m in self.net if isinstance(m, nn.Conv2d)]
        return convs[1:] if self.stem_channels else convs

    def forward(self, pixels: torch.Tensor) -> torch.Tensor:
        lead = pixels.shape[:-3]
        # channels-last activations: same values (to float rounding), ~1.7x (training) to ~2.5x (inference
        # on 4-12 images) faster convolutions on CPU with these few channels (benchmarks/encoder_speed.py)
        x = self.net(pixels.reshape(-1, *pixels.shape[-3:]).contiguous(memory_format=torch.channels_last))
        return x.reshape(*lead, -1)
