"""Named decision makers for evaluation: each becomes a TorchRL-style policy plus the env
transforms it needs (e.g. the LSTM's recurrent-state primer)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from torchrl.envs.utils import ExplorationType

__all__ = ["Method", "make_method", "METHODS"]

METHODS = ["scripted", "greedy", "stochastic", "stochastic-gen"]


@dataclass
class Method:
    name: str
    policy: object
    primers: list = field(default_factory=list)
    exploration: ExplorationType = ExplorationType.RANDOM
    network: str | None = None


def _net(name: str, weights: str | Path | None):
    from occrl.pretrained import load_pretrained
    from occrl.training.checkpoint import load_weights

    return load_weights(weights) if weights else load_pretrained(name)


def make_method(name: str, weights: str | Path | None = None) -> Method:
    """``scripted`` (privileged), ``greedy`` / ``stochastic`` (net without heat-map head: mean /
    sampled action), ``stochastic-gen`` (full net, sampled). ``weights`` overrides the shipped net."""
    if name == "scripted":
        from occrl.baselines import ScriptedRetriever

        return Method(name, ScriptedRetriever())
    if name in ("greedy", "stochastic", "stochastic-gen"):
        net_name = "occnet" if name == "stochastic-gen" else "occnet-noheatmap"
        net = _net(net_name, weights)
        exploration = ExplorationType.DETERMINISTIC if name == "greedy" else ExplorationType.RANDOM
        return Method(name, net.policy, [net.make_primer()], exploration, network=str(weights or net_name))
    raise ValueError(f"unknown method {name!r}; available: {METHODS}")
