"""Weights files of an :class:`~occrl.modules.OccNet`: the network config and weights (plus a
free-form ``meta`` dict), loaded with ``torch.load(weights_only=True)``; what
``occrl.load_pretrained`` reads and what training runs write next to their checkpoints
(:mod:`occrl.training.checkpoint` adds the optimizer and trainer state).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import torch

from occrl.modules.occnet import OccNet, OccNetConfig

__all__ = ["save_weights", "load_weights", "read_occrl_file", "check_architecture", "atomic_save", "CheckpointError",
           "WEIGHTS_FORMAT", "CHECKPOINT_FORMAT"]  # fmt: skip

WEIGHTS_FORMAT = "occrl-weights-v1"
CHECKPOINT_FORMAT = "occrl-checkpoint-v1"  # a training checkpoint (occrl.training.checkpoint) also holds weights


class CheckpointError(ValueError):
    """A checkpoint file is missing, corrupt, of another format or of another architecture.

    Examples:
        >>> from occrl.modules.weights import CheckpointError, load_weights
        >>> issubclass(CheckpointError, ValueError)
        True
        >>> load_weights("/nonexistent/net.pt")
        Traceback (most recent call last):
            ...
        occrl.modules.weights.CheckpointError: no checkpoint at /nonexistent/net.pt
    """


def atomic_save(obj: Any, path: Path) -> None:
    """``torch.save`` to a temporary file, then rename: a crash mid-write leaves the old file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


def read_occrl_file(path: str | Path, expected_format: str) -> dict:
    """The dict of an occrl weights file or training checkpoint (``CheckpointError`` otherwise)."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint at {path}")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # corrupt or not a torch file
        raise CheckpointError(f"{path} is not a readable checkpoint ({type(err).__name__}: {err})") from None
    if not isinstance(obj, dict) or obj.get("format") not in (CHECKPOINT_FORMAT, WEIGHTS_FORMAT):
        raise CheckpointError(f"{path} is not an occrl checkpoint (expected format {expected_format!r})")
    if expected_format == CHECKPOINT_FORMAT and obj["format"] != CHECKPOINT_FORMAT:
        raise CheckpointError(f"{path} holds only weights; a training checkpoint ({CHECKPOINT_FORMAT}) is needed to resume")
    return obj


def check_architecture(net: OccNet, config: dict, path) -> None:
    """``CheckpointError`` naming the differences when ``config`` is not ``net``'s architecture.
    Settings added to :class:`OccNetConfig` after the file was written take their defaults (the
    architecture the file was saved from), as :func:`load_weights` builds it."""
    config = {**OccNetConfig().to_dict(), **config}
    if config != net.config.to_dict():
        diff = {k: (config.get(k), v) for k, v in net.config.to_dict().items() if config.get(k) != v}
        raise CheckpointError(f"{path} was saved from another architecture; differences (file, this net): {diff}")


def save_weights(path: str | Path, net: OccNet, meta: dict | None = None) -> None:
    """Write the network config and weights only (plus ``meta``): the file :func:`load_weights` and
    ``occrl.load_pretrained`` read.

    Examples:
        >>> import os, tempfile
        >>> from occrl.modules import make_occnet
        >>> from occrl.modules.weights import save_weights
        >>> from occrl.training import load_checkpoint
        >>> path = os.path.join(tempfile.mkdtemp(), "net.pt")
        >>> save_weights(path, make_occnet("paper"), meta={"note": "untrained"})
        >>> load_checkpoint(path)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
            ...
        occrl.modules.weights.CheckpointError: ...net.pt holds only weights; a training checkpoint (occrl-checkpoint-v1) is needed to resume
    """
    atomic_save({"format": WEIGHTS_FORMAT, "net_config": net.config.to_dict(), "model": net.state_dict(), "meta": meta or {}}, Path(path))


def load_weights(path: str | Path, net: OccNet | None = None) -> OccNet:
    """Build (or fill) a network from a weights file or a training checkpoint.

    Examples:
        >>> import os, tempfile
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.modules.weights import load_weights, save_weights
        >>> net, path = make_occnet("paper"), os.path.join(tempfile.mkdtemp(), "net.pt")
        >>> save_weights(path, net)
        >>> loaded = load_weights(path)  # built from the stored config, in eval mode
        >>> loaded.training, all(torch.equal(a, b) for a, b in zip(net.state_dict().values(), loaded.state_dict().values()))
        (False, True)
        >>> load_weights(path, make_occnet("paper", heatmap=False))  # doctest: +ELLIPSIS
        Traceback (most recent call last):
            ...
        occrl.modules.weights.CheckpointError: ...net.pt was saved from another architecture; differences (file, this net): {'heatmap': (True, False)}
    """
    obj = read_occrl_file(path, WEIGHTS_FORMAT)
    cfg = {k: tuple(v) if isinstance(v, list) else v for k, v in obj["net_config"].items()}
    if net is None:
        try:
            net = OccNet(OccNetConfig(**cfg))
        except TypeError as err:
            raise CheckpointError(f"{path}: unknown network settings ({err})") from None
    else:
        check_architecture(net, cfg, path)
    try:
        net.load_state_dict(obj["model"])
    except RuntimeError as err:
        raise CheckpointError(f"{path}: weights do not fit the network ({err})") from None
    return net.eval()
