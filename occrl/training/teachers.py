"""Who teaches during imitation: the teacher a run's settings name, and the policy its collector runs.

:func:`make_expert` builds the teacher of :attr:`TrainConfig.imitation_teacher` (the hybrid planner
acting, possibly with a retriever taking over a share of the retrievals; the hierarchical OMPL
planner; the clearing or scripted retrievers; none when the learner labels itself), and
:func:`collection_policy` what the collector runs with it: the learner's policy mixed with the
teacher (it acts in a share of the episodes) or labelled by it online.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

from occrl.baselines.clearing import ClearingRetriever
from occrl.baselines.handover import SearchThenRetrieve
from occrl.baselines.observed_clearing import ObservedClearingRetriever
from occrl.baselines.scripted import ScriptedRetriever
from occrl.modules.occnet import OccNet
from occrl.modules.weights import load_weights
from occrl.planners import HybridPlanner
from occrl.training.config import TrainConfig
from occrl.training.dagger import ExpertMixPolicy, OnlineTeacherPolicy, RetrievalTakeover
from occrl.training.run_folder import file_sha256

__all__ = ["HIERARCHICAL_TEACHER", "teacher_network", "make_retriever", "make_expert", "collection_policy"]

logger = logging.getLogger(__name__)

# the hierarchical teacher: closed-loop (re-plans when the learner leaves its plan: 1 cm / 10 degrees),
# 1 s per OMPL query, no episode time limit (labels, not a timed evaluation), a Search that starts at
# the nearer end and ends once the target is seen (on 16 stage-2 tasks it then solved 16, with the
# paper's full left-to-right sweeps 11: docs/decisions.md)
HIERARCHICAL_TEACHER = dict(
    plan_seconds=1.0, follow_tolerance=(0.01, math.radians(10.0)), time_limit=1e6, sweep_from="nearest", stop_when_located=True
)


def teacher_network(value: str) -> OccNet:
    """The fixed network a "hybrid-acting" teacher plans with (``teacher_weights``): a weights
    file or a shipped network's name; it must have the heat-map head."""
    from occrl.pretrained import available, weights_file

    path = weights_file(value)
    if not Path(path).is_file():
        raise ValueError(f"teacher_weights {value!r} is neither a weights file nor a shipped network ({available()})")
    net = load_weights(path)
    if not net.config.heatmap:
        raise ValueError(f"teacher_weights {value!r} has no heat-map head; the hybrid planner needs one")
    logger.info("the hybrid-acting teacher plans with the fixed network %s (sha256 %s)", path, file_sha256(path)[:12])
    return net


def make_retriever(name: str, seed: int):
    """The teacher or taker-over that is not the hybrid planner: the hierarchical planner (with
    the teacher's settings, :data:`HIERARCHICAL_TEACHER`), the clearing retriever (privileged, or
    deciding from observations), or the privileged scripted one (otherwise)."""
    if name == "hierarchical":
        from occrl.baselines.hierarchical import HierarchicalPlanner  # needs OMPL

        return HierarchicalPlanner(seed=seed, **HIERARCHICAL_TEACHER)
    if name == "clearing-observed":
        return ObservedClearingRetriever()
    return ClearingRetriever() if name == "clearing" else ScriptedRetriever()


def make_expert(config: TrainConfig, acting_net: OccNet, seed: int, teacher_net: OccNet | None = None):
    """The teacher of ``config.imitation_teacher`` (None for "self": the learner acts and labels).
    The "hybrid-acting" teacher plans on ``acting_net`` (the live network) unless ``teacher_net``
    (``teacher_weights``) is given; planners are reseeded every iteration."""
    if config.imitation_teacher == "hybrid-acting":
        planning_net = acting_net if teacher_net is None else teacher_net
        expert = HybridPlanner(planning_net, m=4, h=4, seed=seed, inference=config.teacher_inference, batch_worlds=True)
        if config.retrieval_takeover > 0:  # a retriever acts in a share of the retrievals
            expert = RetrievalTakeover(expert, ScriptedRetriever(), config.retrieval_takeover, seed=seed)
        return expert
    if config.imitation_teacher == "self":
        return None
    if config.imitation_teacher == "clearing-observed" and config.teacher_search == "hierarchical":
        from occrl.baselines.hierarchical import HierarchicalPlanner  # needs OMPL

        searcher = HierarchicalPlanner(seed=seed, **HIERARCHICAL_TEACHER)
        return SearchThenRetrieve(searcher, ObservedClearingRetriever(), retriever_follows=True)
    return make_retriever(config.imitation_teacher, seed)


def collection_policy(config: TrainConfig, acting_policy, expert):
    """What the collector runs: the learner's policy, mixed with or labelled by the teacher during
    imitation (the share the teacher acts is set per iteration on the returned policy)."""
    if config.imitation_iters > 0 and config.imitation_teacher == "hierarchical":
        return OnlineTeacherPolicy(acting_policy, expert, 0.0, action_noise=config.teacher_action_noise)
    if config.imitation_iters > 0 and config.imitation_teacher == "clearing-observed":
        searches = config.teacher_search != "learner"  # else the learner searches, the teacher acts from the first sight
        return OnlineTeacherPolicy(
            acting_policy,
            expert,
            0.0,
            from_first_sight=not searches,
            action_noise=config.teacher_action_noise,
        )
    if config.imitation_iters > 0 and config.imitation_teacher != "self":
        return ExpertMixPolicy(acting_policy, expert, 0.0)
    return acting_policy
