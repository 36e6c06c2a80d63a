"""A trained network, given twice the pixels: the paper network turned into a ``"fine"`` one.

The ``"fine"`` preset (:data:`~occrl.modules.PRESETS`) reads the same 0.8 m window at 128 x 128
(6.25 mm per pixel instead of 12.5) through a stride-2 stem in front of the paper's encoder, and
decodes its heat-map at 64 x 64, repeated 2 x 2. :func:`with_finer_input` builds one from a
trained paper network so that it computes exactly what the paper network computes whenever each
pixel of the 64 x 64 image is repeated 2 x 2: the stem's first three channels copy the pixel at
the even row and column (a one at the kernel's centre), its other channels start at random and
reach the first stage through zero weights (so they change nothing yet, but learn from the first
gradient), and every other weight is the original's. Training from it (``occrl train --net-preset
fine --init-weights W``) starts from the trained behaviour with room to use the finer detail.
"""

from __future__ import annotations

import math
from dataclasses import replace

import torch
from torch import nn

from occrl.modules.occnet import OccNet

__all__ = ["with_finer_input"]


@torch.no_grad()
def with_finer_input(net: OccNet, stem_channels: int = 8, seed: int = 0) -> OccNet:
    """A network on twice the image size that starts as ``net`` (see the module docstring).

    Args:
        net: a network without a stem (``net.config.stem_channels == 0``), e.g. the paper's.
        stem_channels: the stem's channels (>= 3: three of them carry the image on).
        seed: draws the other stem channels' weights (uniform within PyTorch's default bound for
            a conv, 1 / sqrt(fan-in)): the same network and seed give the same result.

    Returns:
        The new network in eval mode; ``net`` is left as it was.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import make_occnet, with_finer_input
        >>> net = make_occnet("paper")
        >>> fine = with_finer_input(net)
        >>> fine.config.image_size, fine.config.stem_channels
        (128, 8)
        >>> x = torch.rand(2, 3, 64, 64)
        >>> td = lambda px: TensorDict({"pixels": px, "is_init": torch.ones(2, 1, dtype=torch.bool)}, [2])
        >>> a = net.value(td(x))["state_value"]
        >>> b = fine.value(td(x.repeat_interleave(2, -1).repeat_interleave(2, -2)))["state_value"]
        >>> torch.allclose(a, b, atol=1e-5)
        True
    """
    if net.config.stem_channels:
        raise ValueError(f"the network already has a stem of {net.config.stem_channels} channels; give a network without one")
    if stem_channels < 3:
        raise ValueError(f"stem_channels must be >= 3 (three carry the image's colours on), got {stem_channels}")
    fine = OccNet(replace(net.config, image_size=2 * net.config.image_size, stem_channels=stem_channels))
    old, new = net.encoder.module, fine.encoder.module
    stem = new.stem
    generator = torch.Generator().manual_seed(int(seed))
    bound = 1.0 / math.sqrt(stem.weight[0].numel())
    stem.weight.copy_((2 * torch.rand(stem.weight.shape, generator=generator) - 1) * bound)
    stem.bias.copy_((2 * torch.rand(stem.bias.shape, generator=generator) - 1) * bound)
    nn.init.zeros_(stem.weight[:3])
    nn.init.zeros_(stem.bias[:3])
    for c in range(3):
        stem.weight[c, c, 1, 1] = 1.0  # the colour at the even row and column, unchanged
    # the paper's layers after the stem, as they were, but the first conv takes the stem's
    # channels: the original weights on the three that carry the image, zeros on the others
    state = old.net.state_dict()
    first = torch.zeros_like(new.stage_convs[0].weight)
    first[:, :3] = state["0.weight"]
    state["0.weight"] = first
    shift = len(new.net) - len(old.net)  # the stem's layers come first
    new.net.load_state_dict({**new.net[:shift].state_dict(), **{_shifted(k, shift): v for k, v in state.items()}})
    fine.lstm.load_state_dict(net.lstm.state_dict())
    fine.actor.load_state_dict(net.actor.state_dict())
    fine.critic.load_state_dict(net.critic.state_dict())
    if net.heatmap_head is not None:
        fine.heatmap_head.load_state_dict(net.heatmap_head.state_dict())
    return fine.eval()


def _shifted(key: str, shift: int) -> str:
    """A ``Sequential`` state-dict key (``"4.weight"``) for the layer ``shift`` places later."""
    index, rest = key.split(".", 1)
    return f"{int(index) + shift}.{rest}"
