"""A trained network, given twice the pixels: the paper network turned into a ``"fine"`` one.

The ``"fine"`` preset (:data:`~occrl.modules.PRESETS`) reads the same 0.8 m window at 128 x 128
(6.25 mm per pixel instead of 12.5): the paper's encoder runs on every other pixel and a detail
branch on all of them adds to its first stage (:class:`~occrl.modules.ConvEncoder`); the heat-map
is decoded at 64 x 64 and repeated 2 x 2. :func:`with_finer_input` builds one from a trained
paper network: every weight of the paper network as it was, the detail branch new (its last conv
at zero), so the fine network computes exactly what the paper network computes on the even rows
and columns of its image, and training (``occrl train --net-preset fine --init-weights W
[--detail-lr R]``) starts from the trained behaviour with room to use the finer detail.
"""

from __future__ import annotations

import math
from dataclasses import replace

import torch

from occrl.modules.occnet import OccNet

__all__ = ["with_finer_input"]


@torch.no_grad()
def with_finer_input(net: OccNet, detail_channels: int = 8, seed: int = 0) -> OccNet:
    """A network on twice the image size that starts as ``net`` (see the module docstring).

    Args:
        net: a network without a detail branch (``net.config.detail_channels == 0``), e.g. the paper's.
        detail_channels: the detail branch's channels.
        seed: draws the branch's first conv (uniform within PyTorch's default bound for a conv,
            1 / sqrt(fan-in)): the same network and seed give the same result.

    Returns:
        The new network in eval mode; ``net`` is left as it was.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import make_occnet, with_finer_input
        >>> net = make_occnet("paper")
        >>> fine = with_finer_input(net)
        >>> fine.config.image_size, fine.config.detail_channels
        (128, 8)
        >>> x = torch.rand(2, 3, 128, 128)
        >>> td = lambda px: TensorDict({"pixels": px, "is_init": torch.ones(2, 1, dtype=torch.bool)}, [2])
        >>> torch.equal(fine.value(td(x))["state_value"], net.value(td(x[..., ::2, ::2]))["state_value"])
        True
    """
    if net.config.detail_channels:
        raise ValueError(f"the network already has a detail branch of {net.config.detail_channels} channels; give one without")
    if detail_channels < 1:
        raise ValueError(f"detail_channels must be >= 1, got {detail_channels}")
    fine = OccNet(replace(net.config, image_size=2 * net.config.image_size, detail_channels=detail_channels))
    missing, unexpected = fine.load_state_dict(net.state_dict(), strict=False)
    if unexpected or any(".detail." not in key for key in missing):  # pragma: no cover - a programming error
        raise RuntimeError(f"the paper network's weights do not map onto the fine one: missing {missing}, unexpected {unexpected}")
    first = fine.encoder.module.detail[0]
    generator = torch.Generator().manual_seed(int(seed))
    bound = 1.0 / math.sqrt(first.weight[0].numel())
    first.weight.copy_((2 * torch.rand(first.weight.shape, generator=generator) - 1) * bound)
    first.bias.copy_((2 * torch.rand(first.bias.shape, generator=generator) - 1) * bound)
    return fine.eval()
