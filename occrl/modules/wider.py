"""A wider network that starts as a trained one: more channels, LSTM units and hidden units, the
same function (beyond the paper; the ``"wide"`` preset).

Is the paper's small network (conv 8-8-16, LSTM 128) what holds its policy back? A wider network
trained from scratch would have to relearn everything a trained network knows; instead
:func:`with_wider_network` copies the trained weights into the top-left blocks of the wider
layers and sets every weight *from* a new unit *into* an old one to zero (Net2Net-style
function-preserving growth, Chen et al. 2016, with zero fan-out instead of replication). The new
units get PyTorch's default random fan-in, so they compute something from the start, but
nothing reads them until training gives their outgoing weights a value: the wider network's
actions, value and heat-map equal the trained network's (tested, to float rounding).

Per layer kind: a conv or linear layer's new output rows are random and its columns from new
inputs zero for old outputs; a batch norm's new channels start at weight 1, bias 0, running mean
0, variance 1; the LSTM's four gates are widened gate by gate (old units' rows keep their input
and recurrent weights, with zero weight on new inputs and new units); the heads read the new
LSTM units with zero weights.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import torch
from torch import nn

from occrl.modules.encoder import ConvEncoder
from occrl.modules.heads import HeatmapHead, PolicyHead, ValueHead
from occrl.modules.occnet import PRESETS, OccNet

__all__ = ["with_wider_network"]


def _only(net: nn.Module, kind: type) -> nn.Module:
    found = {id(m): m for m in net.modules() if isinstance(m, kind)}
    if len(found) != 1:
        raise ValueError(f"expected one {kind.__name__} in the network, found {len(found)}")
    return next(iter(found.values()))


@torch.no_grad()
def _grow(new: torch.Tensor, old: torch.Tensor) -> None:
    """Old values into the leading block of ``new``; the rest of the block's rows (old outputs
    from new inputs) zero. Rows beyond the old ones keep their random values."""
    if old.dim() == 1:
        new[: old.shape[0]] = old
        return
    rows, cols = old.shape[0], old.shape[1]
    new[:rows] = 0.0
    new[:rows, :cols] = old


@torch.no_grad()
def _grow_mlp(new: nn.Sequential, old: nn.Sequential) -> None:
    """Linear layers of an MLP: each layer's old block copied, new inputs of old outputs zero."""
    old_linear = [m for m in old if isinstance(m, nn.Linear)]
    new_linear = [m for m in new if isinstance(m, nn.Linear)]
    for n, o in zip(new_linear, old_linear, strict=True):
        _grow(n.weight, o.weight)
        _grow(n.bias, o.bias)


@torch.no_grad()
def _grow_encoder(new: ConvEncoder, old: ConvEncoder) -> None:
    if old.detail is not None or new.detail is not None:
        raise ValueError("with_wider_network widens the paper's encoder; a detail branch (the 'fine' preset) is not supported")
    for n, o in zip(new.net, old.net, strict=True):
        if isinstance(o, nn.Conv2d):
            _grow(n.weight, o.weight)
            _grow(n.bias, o.bias)
        elif isinstance(o, nn.BatchNorm2d):
            for name in ("weight", "bias", "running_mean", "running_var"):
                getattr(n, name)[: o.num_features] = getattr(o, name)
            n.num_batches_tracked.copy_(o.num_batches_tracked)


@torch.no_grad()
def _grow_lstm(new: nn.LSTM, old: nn.LSTM, old_inputs: int) -> None:
    """Gate by gate (PyTorch's order: input, forget, cell, output): the old units' rows of each
    gate keep their weights on the old inputs and old units, zero on the new ones."""
    h_old, h_new = old.hidden_size, new.hidden_size
    for name in ("weight_ih_l0", "weight_hh_l0", "bias_ih_l0", "bias_hh_l0"):
        n, o = getattr(new, name), getattr(old, name)
        for gate in range(4):
            rows_new, rows_old = slice(gate * h_new, gate * h_new + h_old), slice(gate * h_old, (gate + 1) * h_old)
            if o.dim() == 1:
                n[rows_new] = o[rows_old]
            else:
                cols = old_inputs if name == "weight_ih_l0" else h_old
                n[rows_new] = 0.0
                n[rows_new, :cols] = o[rows_old]


def with_wider_network(
    net: OccNet,
    conv_channels: Sequence[int] | None = None,
    lstm_hidden: int | None = None,
    policy_hidden: Sequence[int] | None = None,
    value_hidden: Sequence[int] | None = None,
    seed: int = 0,
) -> OccNet:
    """A wider copy of ``net`` that computes what ``net`` computes (module docstring). Every new
    size must be at least the old one; a size not given is the ``"wide"`` preset's (twice the
    paper's).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from occrl.modules import make_occnet
        >>> from occrl.modules.wider import with_wider_network
        >>> net = make_occnet("paper")
        >>> wide = with_wider_network(net)
        >>> td = TensorDict({"pixels": torch.rand(2, 3, 64, 64), "is_init": torch.ones(2, 1, dtype=torch.bool)}, batch_size=[2])
        >>> a, b = net.policy(td.clone())["loc"], wide.policy(td.clone())["loc"]
        >>> wide.config.lstm_hidden, bool(torch.allclose(a, b, atol=1e-6))
        (256, True)
    """
    cfg, preset = net.config, PRESETS["wide"]
    conv_channels = preset.conv_channels if conv_channels is None else conv_channels
    lstm_hidden = preset.lstm_hidden if lstm_hidden is None else lstm_hidden
    policy_hidden = preset.policy_hidden if policy_hidden is None else policy_hidden
    value_hidden = preset.value_hidden if value_hidden is None else value_hidden
    sizes = {
        "conv_channels": (tuple(conv_channels), cfg.conv_channels),
        "policy_hidden": (tuple(policy_hidden), cfg.policy_hidden),
        "value_hidden": (tuple(value_hidden), cfg.value_hidden),
        "lstm_hidden": ((lstm_hidden,), (cfg.lstm_hidden,)),
    }
    for name, (new_sizes, old_sizes) in sizes.items():
        if len(new_sizes) != len(old_sizes) or any(n < o for n, o in zip(new_sizes, old_sizes)):
            raise ValueError(
                f"{name} must have the old network's {len(old_sizes)} layer(s), each at least as wide as {old_sizes}; got {new_sizes}"
            )
    if cfg.policy_components != 1:
        raise ValueError("with_wider_network widens the paper's Gaussian policy head; a mixture policy is not supported")
    with torch.random.fork_rng():  # the new units' initialisation from ``seed``, the caller's RNG untouched
        torch.manual_seed(seed)
        wide = OccNet(
            replace(
                cfg,
                conv_channels=tuple(conv_channels),
                lstm_hidden=lstm_hidden,
                policy_hidden=tuple(policy_hidden),
                value_hidden=tuple(value_hidden),
            )
        )
    old_encoder, new_encoder = _only(net, ConvEncoder), _only(wide, ConvEncoder)
    _grow_encoder(new_encoder, old_encoder)
    # the encoder's flattened output is channel-major: the old channels' features come first
    _grow_lstm(_only(wide, nn.LSTM), _only(net, nn.LSTM), old_encoder.out_features)
    _grow_mlp(_only(wide, PolicyHead).net, _only(net, PolicyHead).net)
    _grow_mlp(_only(wide, ValueHead).net, _only(net, ValueHead).net)
    if cfg.heatmap:
        new_heat, old_heat = _only(wide, HeatmapHead), _only(net, HeatmapHead)
        _grow(new_heat.project[0].weight, old_heat.project[0].weight)
        _grow(new_heat.project[0].bias, old_heat.project[0].bias)
        new_heat.decode.load_state_dict(old_heat.decode.state_dict())
    return wide.eval()
