"""Pretrained networks shipped inside the package (no download at run time).

``occrl.load_pretrained("occnet")`` is the full three-headed net (used by the hybrid planner and
the Stochastic-gen baseline); ``"occnet-noheatmap"`` the net without heat-map head (Greedy and
Stochastic baselines); ``"occnet-ei"`` is ``occnet`` after expert iteration on stage 2: its own
sampled policy is better on every stage, the hybrid planner on it is no better than on ``occnet``
(``occrl eval --method stochastic-gen --weights occnet-ei``); ``"occnet-takeover"`` is ``occnet``
after 75 iterations of the hybrid planner acting with the scripted retriever taking over half of
the retrievals (``retrieval_takeover=0.5``): the best network so far for the hybrid planner and its
own policy on stages 2 and 3 (``occrl eval --method hybrid-4x4 --weights occnet-takeover``), not yet
the default. ``model_card`` says how each was trained; docs/experiments.md has the figures.
"""

from __future__ import annotations

import json
from pathlib import Path

from occrl.modules.weights import load_weights

__all__ = ["load_pretrained", "available", "model_card", "pretrained_path", "weights_file", "PRETRAINED_DIR", "PRETRAINED_FILES"]

PRETRAINED_DIR = Path(__file__).resolve().parent  # where the shipped weights and model_cards.json live
PRETRAINED_FILES = {  # shipped name -> weights file in PRETRAINED_DIR
    "occnet": "occnet.pt",
    "occnet-noheatmap": "occnet-noheatmap.pt",
    "occnet-ei": "occnet-ei.pt",
    "occnet-takeover": "occnet-takeover.pt",
}


def available() -> list[str]:
    """Names of the shipped networks present in this installation.

    Examples:
        >>> from occrl.pretrained import available
        >>> "occnet" in available()
        True
    """
    return sorted(name for name, f in PRETRAINED_FILES.items() if (PRETRAINED_DIR / f).is_file())


def model_card(name: str) -> dict:
    """Training facts of a shipped network (preset, stage reached, frames, CPU-hours, ...).

    Examples:
        >>> from occrl.pretrained import model_card
        >>> card = model_card("occnet")
        >>> "train_preset" in card, "frames" in card
        (True, True)
        >>> model_card("no-such-net")  # unknown names have no card
        {}
    """
    path = PRETRAINED_DIR / "model_cards.json"
    cards = json.loads(path.read_text()) if path.is_file() else {}
    return cards.get(name, {})


def load_pretrained(name: str = "occnet"):
    """Load a shipped network in eval mode.

    Raises:
        ValueError: for an unknown name (lists the known ones).
        FileNotFoundError: when the package was installed without that weights file.

    Examples:
        >>> import occrl
        >>> net = occrl.load_pretrained("occnet")  # doctest: +SKIP
    """
    return load_weights(pretrained_path(name))


def pretrained_path(name: str) -> Path:
    """The weights file of a shipped network (e.g. to start training from it).

    Raises:
        ValueError: for an unknown name (lists the known ones).
        FileNotFoundError: when the package was installed without that weights file.

    Examples:
        >>> from occrl.pretrained import pretrained_path
        >>> pretrained_path("occnet").name
        'occnet.pt'
        >>> pretrained_path("occnet-v9")
        Traceback (most recent call last):
            ...
        ValueError: unknown pretrained network 'occnet-v9'; known: ['occnet', 'occnet-ei', 'occnet-noheatmap', 'occnet-takeover']
    """
    if name not in PRETRAINED_FILES:
        raise ValueError(f"unknown pretrained network {name!r}; known: {sorted(PRETRAINED_FILES)}")
    path = PRETRAINED_DIR / PRETRAINED_FILES[name]
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing: this installation has no weights for {name!r} (shipped: {available()})")
    return path


def weights_file(value: str | Path | None) -> str | None:
    """What a ``--weights`` option names: an existing weights file as is, a shipped network's
    name as its file in the package; anything else as is (for the loader to refuse).

    Examples:
        >>> from occrl.pretrained import weights_file
        >>> weights_file("occnet-ei").endswith("occnet-ei.pt"), weights_file(None), weights_file("nowhere.pt")
        (True, None, 'nowhere.pt')
    """
    if value is None or Path(value).exists():
        return None if value is None else str(value)
    try:
        return str(pretrained_path(str(value)))
    except ValueError:  # not a shipped name either
        return str(value)
