"""Named decision makers for evaluation: each becomes a TorchRL-style policy plus the env
transforms it needs (e.g. the LSTM's recurrent-state primer)."""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from torchrl.envs.utils import ExplorationType

from occrl.baselines.clearing import ClearingRetriever
from occrl.baselines.policies import NetPolicy
from occrl.baselines.scripted import ScriptedRetriever
from occrl.envs.episodes import EpisodeResult, run_episodes
from occrl.envs.robot_frame import DEFAULT_SIZE
from occrl.envs.scene import Scene
from occrl.modules.weights import load_weights
from occrl.planners import HybridPlanner
from occrl.pretrained import PRETRAINED_DIR, PRETRAINED_FILES, load_pretrained, network_name, weights_file

__all__ = [
    "Method",
    "make_method",
    "default_network",
    "method_network",
    "hybrid_setting",
    "ompl_hybrid_setting",
    "is_method",
    "is_planner",
    "METHODS",
    "PRIVILEGED",
]

METHODS = [
    "hybrid-2x2",
    "hybrid-4x4",
    "hybrid-6x6",
    "hybrid-lim-4x4",
    "greedy",
    "stochastic",
    "stochastic-gen",
    "hierarchical",
    "scripted",
    "clearing",
]
# read the true state (not methods of the paper; left out of sweeps unless named)
PRIVILEGED = ("scripted", "clearing")
# the papers' hybrid planners are named hybrid-MxH (m roll-outs of depth h per root) and
# hybrid-lim-MxH (the most likely root only); any m, h >= 1 is accepted beyond the listed four
_HYBRID_NAME = re.compile(r"hybrid-(lim-)?([1-9][0-9]*)x([1-9][0-9]*)")


def hybrid_setting(name: str) -> tuple[int, int, bool] | None:
    """``(m, h, limited)`` of a hybrid planner's name, None for any other name.

    Examples:
        >>> from occrl.eval.methods import hybrid_setting
        >>> hybrid_setting("hybrid-4x4"), hybrid_setting("hybrid-lim-2x3"), hybrid_setting("hybrid-0x4")
        ((4, 4, False), (2, 3, True), None)
    """
    match = _HYBRID_NAME.fullmatch(name)
    if match is None:
        return None
    return int(match.group(2)), int(match.group(3)), match.group(1) is not None


# beyond the papers: the hybrid planner with the hierarchical planner's next actions as one more
# roll-out per root (occrl.baselines.hybrid_ompl); named, never part of a sweep unless named
_OMPL_HYBRID_NAME = re.compile(r"hybrid-ompl-([1-9][0-9]*)x([1-9][0-9]*)")


def ompl_hybrid_setting(name: str) -> tuple[int, int] | None:
    """``(m, h)`` of a ``hybrid-ompl-MxH`` name (the hybrid planner with an OMPL proposal among its
    roll-outs, :class:`~occrl.baselines.hybrid_ompl.HybridOMPLPlanner`), None for any other name.

    Examples:
        >>> from occrl.eval.methods import ompl_hybrid_setting
        >>> ompl_hybrid_setting("hybrid-ompl-4x4"), ompl_hybrid_setting("hybrid-4x4")
        ((4, 4), None)
    """
    match = _OMPL_HYBRID_NAME.fullmatch(name)
    return None if match is None else (int(match.group(1)), int(match.group(2)))


def is_method(name: str) -> bool:
    """Whether :func:`make_method` knows ``name``: one of :data:`METHODS`, any hybrid-MxH or
    hybrid-ompl-MxH."""
    return name in METHODS or hybrid_setting(name) is not None or ompl_hybrid_setting(name) is not None


def is_planner(name: str) -> bool:
    """Whether a method plans: the hierarchical planner, every hybrid-MxH and hybrid-ompl-MxH.
    Planners run one world per task when evaluated, so their time per task is measured exactly."""
    return name == "hierarchical" or hybrid_setting(name) is not None or ompl_hybrid_setting(name) is not None


@dataclass
class Method:
    """A named decision maker: its policy, the env transforms it needs (``primers``), the exploration
    type to run it under and the network it was built from (None without one).

    Examples:
        >>> from occrl.eval.methods import make_method
        >>> m = make_method("scripted")
        >>> m.name, type(m.policy).__name__, m.primers, m.network
        ('scripted', 'ScriptedRetriever', [], None)
    """

    name: str
    policy: object
    primers: list = field(default_factory=list)
    exploration: ExplorationType = ExplorationType.RANDOM
    network: str | None = None
    image_size: int = DEFAULT_SIZE
    """Pixels a side of the env's network input: the network's ``config.image_size`` (64 for the
    paper's network); methods without a network ignore the image."""
    remembered_detections: bool = False
    """Whether the env draws earlier detections into the image: the network's
    ``config.remembered_detections``."""

    def run_episodes(
        self, scenes: Sequence[Scene], seeds: Sequence[int], noise: float = 0.0, batch_size: int = 16, policy=None, **options
    ) -> list[EpisodeResult]:
        """:func:`occrl.envs.episodes.run_episodes` of this method: its primers, exploration type,
        image size and remembered detections. ``policy`` replaces the method's own (a diagnosis's
        wrapper around it); ``options`` are ``run_episodes``'s others (``world``, ``replicate``,
        ``heatmap_target``, ``on_env``, ``on_rollout``)."""
        return run_episodes(
            self.policy if policy is None else policy,
            scenes,
            seeds,
            noise,
            batch_size,
            self.primers,
            self.exploration,
            size=self.image_size,
            remembered_detections=self.remembered_detections,
            **options,
        )


def _net(name: str, weights: str | Path | None):
    return load_weights(weights) if weights else load_pretrained(name)


def default_network(name: str) -> str | None:
    """The shipped network a method decides with unless ``weights`` says otherwise (None: none).

    Examples:
        >>> from occrl.eval.methods import default_network
        >>> default_network("hybrid-4x4"), default_network("greedy"), default_network("hierarchical")
        ('occnet', 'occnet-noheatmap', None)
    """
    if hybrid_setting(name) is not None or ompl_hybrid_setting(name) is not None or name == "stochastic-gen":
        return "occnet"
    return "occnet-noheatmap" if name in ("greedy", "stochastic") else None


def method_network(name: str, weights: str | Path | None = None) -> tuple[str | None, str | None]:
    """What a result records as a method's network: its name (a shipped network's own name, also
    for the path of a shipped file; a default such as "occnet" resolved to the network it stands
    for in this version; else the weights file as given) and the SHA-256 of its weights file;
    ``(None, None)`` for a method without one.

    Examples:
        >>> from occrl.eval.methods import method_network
        >>> from occrl.pretrained import pretrained_path
        >>> method_network("hybrid-4x4")[0], method_network("greedy", str(pretrained_path("occnet-ei")))[0]
        ('occnet-selfimit', 'occnet-ei')
        >>> method_network("scripted")
        (None, None)
    """
    default = default_network(name)
    if default is None:
        return None, None
    path = Path(weights_file(weights or default))
    shipped = [net for net, f in PRETRAINED_FILES.items() if PRETRAINED_DIR / f == path.resolve()]
    record = shipped[0] if shipped else network_name(str(weights or default))  # a shipped file by its name
    return record, hashlib.sha256(path.read_bytes()).hexdigest()


def _network_record(default: str, weights: str | Path | None) -> str:
    """What a result records as its network: a shipped network's own name (a default name such
    as "occnet" resolved to the network it stands for in this version) or the weights file."""
    return network_name(str(weights or default))


def make_method(
    name: str,
    weights: str | Path | None = None,
    seed: int = 0,
    inference: str = "torch",
) -> Method:
    """``hybrid-MxH`` / ``hybrid-lim-MxH`` (planner on the full net; the papers' are 2x2, 4x4, 6x6 and lim-4x4), ``greedy`` / ``stochastic``
    (net without heat-map head: mean / sampled action), ``stochastic-gen`` (full net, sampled),
    ``hierarchical`` (Alg. 3 with OMPL; literal Search), ``hybrid-ompl-MxH`` (beyond the papers: the
    hybrid planner with the hierarchical planner's next actions as one more roll-out per root), ``scripted`` and ``clearing`` (privileged). ``weights``
    overrides the shipped net. ``inference`` is how the hybrid planners' roll-outs call the
    network (``"torch"`` or ``"onnxruntime"``; :class:`~occrl.planners.HybridPlanner`).

    Examples:
        >>> from occrl.eval.methods import make_method
        >>> m = make_method("hybrid-2x2")  # loads the shipped net
        >>> type(m.policy).__name__, (m.policy.m, m.policy.h), len(m.primers), m.network
        ('HybridPlanner', (2, 2), 1, 'occnet-selfimit')
        >>> make_method("random")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
            ...
        ValueError: unknown method 'random'; available: ['hybrid-2x2', ..., 'clearing'] (or any hybrid-MxH / hybrid-lim-MxH / hybrid-ompl-MxH, m and h >= 1)
    """
    hybrid, ompl_hybrid = hybrid_setting(name), ompl_hybrid_setting(name)
    if inference != "torch" and hybrid is None and ompl_hybrid is None:
        raise ValueError(f"inference is a hybrid planner setting; {name!r} does not take it")
    if ompl_hybrid is not None:
        from occrl.baselines.hybrid_ompl import HybridOMPLPlanner

        m, h = ompl_hybrid
        net = _net("occnet", weights)
        return Method(
            name,
            HybridOMPLPlanner(net, m=m, h=h, seed=seed, inference=inference),
            [net.make_primer()],
            network=_network_record("occnet", weights),
            image_size=net.config.image_size,
            remembered_detections=net.config.remembered_detections,
        )
    if hybrid is not None:
        m, h, limited = hybrid
        net = _net("occnet", weights)
        return Method(
            name,
            HybridPlanner(net, m=m, h=h, limited=limited, seed=seed, inference=inference),
            [net.make_primer()],
            network=_network_record("occnet", weights),
            image_size=net.config.image_size,
            remembered_detections=net.config.remembered_detections,
        )
    if name == "hierarchical":
        from occrl.baselines.hierarchical import HierarchicalPlanner

        return Method(name, HierarchicalPlanner(seed=seed))
    if name == "scripted":
        return Method(name, ScriptedRetriever())
    if name == "clearing":
        return Method(name, ClearingRetriever())
    if name in ("greedy", "stochastic", "stochastic-gen"):
        net_name = "occnet" if name == "stochastic-gen" else "occnet-noheatmap"
        net = _net(net_name, weights)
        policy = NetPolicy(net, stochastic=name != "greedy", seed=seed)
        return Method(
            name,
            policy,
            [net.make_primer()],
            ExplorationType.DETERMINISTIC,
            network=_network_record(net_name, weights),
            image_size=net.config.image_size,
            remembered_detections=net.config.remembered_detections,
        )
    raise ValueError(f"unknown method {name!r}; available: {METHODS} (or any hybrid-MxH / hybrid-lim-MxH / hybrid-ompl-MxH, m and h >= 1)")
