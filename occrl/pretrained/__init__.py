"""Pretrained networks shipped inside the package (no download at run time).

``occrl.load_pretrained("occnet")`` is the default full three-headed net (the hybrid planner and
the Stochastic-gen baseline), ``"occnet-noheatmap"`` the default net without heat-map head (Greedy
and Stochastic baselines). Each default name stands for one shipped network
(:data:`DEFAULT_NETWORKS`); every network keeps its own name:

- ``"occnet-selfimit"`` (``occnet`` since occrl 0.3.0): ``occnet-takeover`` fitted offline to the
  clearing-observed teacher's disturbed demonstrations on stage 2 (hierarchical search, action
  noise 0.05; 3,000 gradient steps), then 80 iterations of imitating its own successful stage-2
  episodes; the best network so far for its own policy on every stage and for the hybrid planner
  on stages 2 and 3 (level on stage 1);
- ``"occnet-noheatmap-selfimit"`` (``occnet-noheatmap`` since 0.3.0): ``occnet-noheatmap-takeover``
  trained by the same recipe minus the heat-map (the same demonstrations, fit and self-imitation);
- ``"occnet-takeover"`` (``occnet`` from 2026-12-03 to 2026-12-05): ``occnet-warmstart`` after 75
  iterations of the hybrid planner acting on stage 2 with the scripted retriever taking over half
  of the retrievals (``retrieval_takeover=0.5``);
- ``"occnet-noheatmap-takeover"`` (``occnet-noheatmap`` then): ``occnet-noheatmap-warmstart``
  trained by the same recipe minus the heat-map: the same planner (on ``occnet-takeover``, fixed:
  ``teacher_weights``) and retriever act, the net learns from their episodes;
- ``"occnet-warmstart"``, ``"occnet-noheatmap-warmstart"`` (``occnet`` / ``occnet-noheatmap`` up
  to 0.2.x): DAgger on the privileged scripted retriever, stage 1;
- ``"occnet-ei"``: ``occnet-warmstart`` after expert iteration on stage 2.

``model_card`` says how each was trained; the lab log (docs/lab/networks.md) has the figures.
An installed wheel carries the two default networks (:data:`DEFAULT_NETWORKS`); the others load
from a source checkout (``pip install -e .`` in a clone), and a wheel names where they are.
"""

from __future__ import annotations

import json
from pathlib import Path

from occrl.modules.weights import load_weights

__all__ = [
    "load_pretrained",
    "available",
    "model_card",
    "network_name",
    "pretrained_path",
    "weights_file",
    "PRETRAINED_DIR",
    "PRETRAINED_FILES",
    "DEFAULT_NETWORKS",
]

PRETRAINED_DIR = Path(__file__).resolve().parent  # where the shipped weights and model_cards.json live
PRETRAINED_FILES = {  # shipped network -> weights file in PRETRAINED_DIR
    "occnet-selfimit": "occnet-selfimit.pt",
    "occnet-noheatmap-selfimit": "occnet-noheatmap-selfimit.pt",
    "occnet-takeover": "occnet-takeover.pt",
    "occnet-noheatmap-takeover": "occnet-noheatmap-takeover.pt",
    "occnet-warmstart": "occnet-warmstart.pt",
    "occnet-noheatmap-warmstart": "occnet-noheatmap-warmstart.pt",
    "occnet-ei": "occnet-ei.pt",
}
DEFAULT_NETWORKS = {  # default name -> the shipped network it stands for (the planners' and baselines' defaults)
    "occnet": "occnet-selfimit",
    "occnet-noheatmap": "occnet-noheatmap-selfimit",
}


def network_name(name: str) -> str:
    """The shipped network a name stands for (a default name resolved, other names as they are).

    Examples:
        >>> from occrl.pretrained import network_name
        >>> network_name("occnet"), network_name("occnet-ei")
        ('occnet-selfimit', 'occnet-ei')
    """
    return DEFAULT_NETWORKS.get(name, name)


def available() -> list[str]:
    """Names of the shipped networks present in this installation (default names included).

    Examples:
        >>> from occrl.pretrained import available
        >>> "occnet" in available()
        True
    """
    present = {name for name, f in PRETRAINED_FILES.items() if (PRETRAINED_DIR / f).is_file()}
    return sorted(present | {name for name, net in DEFAULT_NETWORKS.items() if net in present})


def model_card(name: str) -> dict:
    """Training facts of a shipped network (preset, stage reached, frames, CPU-hours, ...). The
    default networks' cards add ``recipe_from_scratch``: the ``occrl recipe`` command that makes
    them, each of its steps' CPU-hours (None where never logged) and their total.

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
    return cards.get(network_name(name), {})


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
        'occnet-selfimit.pt'
        >>> pretrained_path("occnet-v9")
        Traceback (most recent call last):
            ...
        ValueError: unknown pretrained network 'occnet-v9'; known: ['occnet', 'occnet-ei', 'occnet-noheatmap', 'occnet-noheatmap-selfimit', 'occnet-noheatmap-takeover', 'occnet-noheatmap-warmstart', 'occnet-selfimit', 'occnet-takeover', 'occnet-warmstart']
    """
    if network_name(name) not in PRETRAINED_FILES:
        raise ValueError(f"unknown pretrained network {name!r}; known: {sorted(PRETRAINED_FILES | DEFAULT_NETWORKS)}")
    path = PRETRAINED_DIR / PRETRAINED_FILES[network_name(name)]
    if not path.is_file():
        raise FileNotFoundError(
            f"{path} is missing: this installation has no weights for {name!r} (here: {available()}). "
            f"A wheel carries the default networks {sorted(DEFAULT_NETWORKS)} only; the others are the files "
            f"occrl/pretrained/*.pt of the source repository: install occrl from a clone (pip install -e .) "
            f"or pass that file's path as the weights"
        )
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
