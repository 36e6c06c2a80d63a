"""Small, resumable checkpoints, loaded with ``torch.load(weights_only=True)``.

A training checkpoint holds the network config and weights, the optimizer state, the training
config and the trainer state (iteration, frames, curriculum stage and window). A *weights*
file (what ``occrl.load_pretrained`` reads) holds only the network config and weights.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import torch

from occrl.modules.occnet import OccNet, OccNetConfig

__all__ = ["save_checkpoint", "load_checkpoint", "save_weights", "load_weights", "CheckpointError", "FORMAT"]

FORMAT = "occrl-checkpoint-v1"
WEIGHTS_FORMAT = "occrl-weights-v1"


class CheckpointError(ValueError):
    """A checkpoint file is missing, corrupt, of another format or of another architecture.

    Examples:
        >>> from occrl.training import CheckpointError, load_weights
        >>> issubclass(CheckpointError, ValueError)
        True
        >>> load_weights("/nonexistent/net.pt")
        Traceback (most recent call last):
            ...
        occrl.training.checkpoint.CheckpointError: no checkpoint at /nonexistent/net.pt
    """


def _atomic_save(obj: Any, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


def _load(path: str | Path, expected_format: str) -> dict:
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # corrupt or not a torch file
        raise CheckpointError(f"{path} is not a readable checkpoint ({type(err).__name__}: {err})") from None
    if not isinstance(obj, dict) or obj.get("format") not in (FORMAT, WEIGHTS_FORMAT):
        raise CheckpointError(f"{path} is not an occrl checkpoint (expected format {expected_format!r})")
    if expected_format == FORMAT and obj["format"] != FORMAT:
        raise CheckpointError(f"{path} holds only weights; a training checkpoint ({FORMAT}) is needed to resume")
    return obj


def _check_architecture(net: OccNet, config: dict, path) -> None:
    if config != net.config.to_dict():
        diff = {k: (config.get(k), v) for k, v in net.config.to_dict().items() if config.get(k) != v}
        raise CheckpointError(f"{path} was saved from another architecture; differences (file, this net): {diff}")


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
    _atomic_save(
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
    obj = _load(path, FORMAT)
    if net is not None:
        _check_architecture(net, obj["net_config"], path)
        net.load_state_dict(obj["model"])
    if optimizer is not None:
        optimizer.load_state_dict(obj["optimizer"])
    return obj


def save_weights(path: str | Path, net: OccNet, meta: dict | None = None) -> None:
    """Write the network config and weights only (plus ``meta``): the file :func:`load_weights` and
    ``occrl.load_pretrained`` read.

    Examples:
        >>> import os, tempfile
        >>> from occrl.modules import make_occnet
        >>> from occrl.training import load_checkpoint, save_weights
        >>> path = os.path.join(tempfile.mkdtemp(), "net.pt")
        >>> save_weights(path, make_occnet("paper"), meta={"note": "untrained"})
        >>> load_checkpoint(path)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
            ...
        occrl.training.checkpoint.CheckpointError: ...net.pt holds only weights; a training checkpoint (occrl-checkpoint-v1) is needed to resume
    """
    _atomic_save({"format": WEIGHTS_FORMAT, "net_config": net.config.to_dict(), "model": net.state_dict(), "meta": meta or {}}, Path(path))


def load_weights(path: str | Path, net: OccNet | None = None) -> OccNet:
    """Build (or fill) a network from a weights file or a training checkpoint.

    Examples:
        >>> import os, tempfile
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.training import load_weights, save_weights
        >>> net, path = make_occnet("paper"), os.path.join(tempfile.mkdtemp(), "net.pt")
        >>> save_weights(path, net)
        >>> loaded = load_weights(path)  # built from the stored config, in eval mode
        >>> loaded.training, all(torch.equal(a, b) for a, b in zip(net.state_dict().values(), loaded.state_dict().values()))
        (False, True)
        >>> load_weights(path, make_occnet("paper", heatmap=False))  # doctest: +ELLIPSIS
        Traceback (most recent call last):
            ...
        occrl.training.checkpoint.CheckpointError: ...net.pt was saved from another architecture; differences (file, this net): {'heatmap': (True, False)}
    """
    obj = _load(path, WEIGHTS_FORMAT)
    cfg = {k: tuple(v) if isinstance(v, list) else v for k, v in obj["net_config"].items()}
    if net is None:
        try:
            net = OccNet(OccNetConfig(**cfg))
        except TypeError as err:
            raise CheckpointError(f"{path}: unknown network settings ({err})") from None
    else:
        _check_architecture(net, cfg, path)
    try:
        net.load_state_dict(obj["model"])
    except RuntimeError as err:
        raise CheckpointError(f"{path}: weights do not fit the network ({err})") from None
    return net.eval()
