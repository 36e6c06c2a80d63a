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

__all__ = ["save_weights", "load_weights", "read_occrl_file", "check_architecture", "stored_net_config", "atomic_save",
           "CheckpointError", "WEIGHTS_FORMAT", "CHECKPOINT_FORMAT", "REMOVED_NET_SETTINGS", "REMOVED_NET_SETTINGS_COMMIT"]  # fmt: skip

WEIGHTS_FORMAT = "occrl-weights-v1"
CHECKPOINT_FORMAT = "occrl-checkpoint-v1"  # a training checkpoint (occrl.training.checkpoint) also holds weights

# network settings that experiments beyond the papers added and that occrl no longer has, each with
# the value every paper network stores: a file storing them at that value loads as before, another
# value names the commit whose code builds that network
REMOVED_NET_SETTINGS = {
    "policy_components": 1,  # > 1: the policy a mixture of Gaussians
    "detail_channels": 0,  # > 0: a detail branch on a 128 x 128 image
}
REMOVED_NET_SETTINGS_COMMIT = "53b1240"


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


def stored_net_config(stored: dict, path) -> dict:
    """The network settings a file stores (its ``"net_config"``), as :class:`OccNetConfig` takes
    them: lists as tuples, and the settings of :data:`REMOVED_NET_SETTINGS` dropped where they hold
    the paper's value. A removed setting at another value raises ``CheckpointError`` naming the
    commit whose code builds that network.

    Examples:
        >>> from occrl.modules.weights import stored_net_config
        >>> stored_net_config({"lstm_hidden": 128, "policy_hidden": [128, 128], "detail_channels": 0}, "net.pt")
        {'lstm_hidden': 128, 'policy_hidden': (128, 128)}
        >>> stored_net_config({"policy_components": 4}, "mixture.pt")
        Traceback (most recent call last):
            ...
        occrl.modules.weights.CheckpointError: mixture.pt stores policy_components=4, a network setting occrl no longer has (only policy_components=1, the paper's, loads); the code that builds this network is at commit 53b1240: git checkout 53b1240
    """
    config = {}
    for key, value in stored.items():
        if key in REMOVED_NET_SETTINGS:
            if value != REMOVED_NET_SETTINGS[key]:
                raise CheckpointError(
                    f"{path} stores {key}={value!r}, a network setting occrl no longer has (only {key}={REMOVED_NET_SETTINGS[key]!r}, "
                    f"the paper's, loads); the code that builds this network is at commit {REMOVED_NET_SETTINGS_COMMIT}: "
                    f"git checkout {REMOVED_NET_SETTINGS_COMMIT}"
                )
            continue
        config[key] = tuple(value) if isinstance(value, list) else value
    return config


def check_architecture(net: OccNet, config: dict, path) -> None:
    """``CheckpointError`` naming the differences when ``config`` (a file's ``"net_config"``) is not
    ``net``'s architecture. Settings added to :class:`OccNetConfig` after the file was written take
    their defaults (the architecture the file was saved from), as :func:`load_weights` builds it;
    removed ones are read by :func:`stored_net_config`."""
    config = {**OccNetConfig().to_dict(), **stored_net_config(config, path)}
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
    cfg = stored_net_config(obj["net_config"], path)
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
