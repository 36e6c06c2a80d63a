"""Small, resumable training checkpoints, loaded with ``torch.load(weights_only=True)``.

A training checkpoint holds the network config and weights, the optimizer state, the training
config and the trainer state (iteration, frames, curriculum stage and window). A *weights* file
(:mod:`occrl.modules.weights`, what ``occrl.load_pretrained`` reads) holds only the network config
and weights.
"""

from __future__ import annotations

from pathlib import Path

import torch

from occrl.modules.occnet import OccNet
from occrl.modules.weights import (
    CHECKPOINT_FORMAT,
    atomic_save,
    check_architecture,
    read_occrl_file,
)

__all__ = ["save_checkpoint", "load_checkpoint", "FORMAT"]

FORMAT = CHECKPOINT_FORMAT


def save_checkpoint(path: str | Path, net: OccNet, optimizer: torch.optim.Optimizer, train_config: dict, state: dict) -> None:
    """Write a training checkpoint (network config and weights, optimizer state, training config and
    trainer ``state``) atomically: a crash mid-write leaves the previous file intact.

    Examples:
        >>> import os, tempfile
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.training import get_train_config, load_checkpoint, save_checkpoint
        >>> net = make_occnet("paper")
        >>> path = os.path.join(tempfile.mkdtemp(), "checkpoint.pt")
        >>> save_checkpoint(path, net, torch.optim.Adam(net.parameters()), get_train_config("tiny").to_dict(), {"iteration": 3})
        >>> load_checkpoint(path)["state"]
        {'iteration': 3}
    """
    atomic_save(
        {
            "format": FORMAT,
            "net_config": net.config.to_dict(),
            "model": net.state_dict(),
            "optimizer": optimizer.state_dict(),
            "train_config": train_config,
            "state": state,
        },
        Path(path),
    )


def load_checkpoint(path: str | Path, net: OccNet | None = None, optimizer: torch.optim.Optimizer | None = None) -> dict:
    """Read a training checkpoint; with ``net``/``optimizer`` also load their states (after
    checking the architecture). Returns the raw dict.

    Examples:
        >>> import os, tempfile
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.training import load_checkpoint, save_checkpoint
        >>> net = make_occnet("paper")
        >>> path = os.path.join(tempfile.mkdtemp(), "checkpoint.pt")
        >>> save_checkpoint(path, net, torch.optim.Adam(net.parameters()), {"preset": "tiny"}, {"iteration": 3})
        >>> other = make_occnet("paper")
        >>> obj = load_checkpoint(path, other, torch.optim.Adam(other.parameters()))
        >>> obj["format"], obj["state"]["iteration"]
        ('occrl-checkpoint-v1', 3)
        >>> all(torch.equal(a, b) for a, b in zip(net.state_dict().values(), other.state_dict().values()))
        True
    """
    obj = read_occrl_file(path, FORMAT)
    if net is not None:
        check_architecture(net, obj["net_config"], path)
        net.load_state_dict(obj["model"])
    if optimizer is not None:
        optimizer.load_state_dict(obj["optimizer"])
    return obj
