"""Baselines: the Greedy and Stochastic policies (:class:`NetPolicy`), the privileged scripted and
clearing retrievers (teachers, not methods of the paper) and the hierarchical OMPL planner (paper
Alg. 3)."""

from occrl.baselines.policies import NetPolicy
from occrl.baselines.clearing import ClearingRetriever
from occrl.baselines.scripted import ScriptedRetriever

__all__ = ["NetPolicy", "ScriptedRetriever", "ClearingRetriever", "HierarchicalPlanner"]


def __getattr__(name: str):
    # OMPL is an optional extra: import the hierarchical planner only when it is asked for.
    if name == "HierarchicalPlanner":
        from occrl.baselines.hierarchical import HierarchicalPlanner

        return HierarchicalPlanner
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
