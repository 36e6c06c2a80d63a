"""Who teaches during imitation: one :class:`Teacher` per kind, each a small frozen dataclass of its
own settings, registered by name in :data:`TEACHERS` (``TrainConfig.imitation.teacher``).

A teacher provides what the trainer needs from it, so that the trainer never asks which teacher
it has: its settings' checks (:meth:`Teacher.validate`), the decision maker it runs
(:meth:`Teacher.make_expert`: the privileged scripted or clearing retriever, the clearing
retriever deciding from observations, the hybrid planner acting, the hierarchical OMPL planner,
or none where the learner acts), what the collector runs with it (:meth:`Teacher.collection_policy`:
the learner's policy mixed with the teacher, which acts in a share ``beta`` of the steps or
episodes, or labelled by it online), that share per iteration (:meth:`Teacher.beta`), and the
labels it writes on a collected batch (:meth:`Teacher.label`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.baselines.clearing import ClearingRetriever
from occrl.baselines.handover import SearchThenRetrieve
from occrl.baselines.observed_clearing import ObservedClearingRetriever
from occrl.baselines.scripted import ScriptedRetriever
from occrl.modules.occnet import OccNet
from occrl.modules.weights import load_weights
from occrl.planners import HybridPlanner
from occrl.pretrained import available, weights_file
from occrl.training.dagger import ExpertMixPolicy, OnlineTeacherPolicy, RetrievalTakeover, label_with_expert, label_with_planner
from occrl.training.dagger import since_first_sight
from occrl.training.run_folder import file_sha256
from occrl.training.stats import successful_episode_frames

if TYPE_CHECKING:  # the settings of a run hold a teacher; a teacher checks itself against them
    from occrl.training.config import ImitationConfig, TrainConfig

__all__ = [
    "HIERARCHICAL_TEACHER",
    "LABEL_EPISODES",
    "TEACHER_INFERENCE",
    "TEACHER_SEARCH",
    "Teacher",
    "ScriptedTeacher",
    "ClearingTeacher",
    "ObservedClearingTeacher",
    "HybridTeacher",
    "HybridActingTeacher",
    "HierarchicalTeacher",
    "SelfTeacher",
    "TEACHERS",
    "teacher_network",
    "keep_successful_episodes",
]

logger = logging.getLogger(__name__)

# the hierarchical teacher: closed-loop (re-plans when the learner leaves its plan: 1 cm / 10 degrees),
# 1 s per OMPL query, no episode time limit (labels, not a timed evaluation), a Search that starts at
# the nearer end and ends once the target is seen (on 16 stage-2 tasks it then solved 16, with the
# paper's full left-to-right sweeps 11: docs/design/training.md)
HIERARCHICAL_TEACHER = dict(
    plan_seconds=1.0, follow_tolerance=(0.01, math.radians(10.0)), time_limit=1e6, sweep_from="nearest", stop_when_located=True
)

#: The values of the teachers' string settings.
LABEL_EPISODES = ("all", "success")
TEACHER_INFERENCE = ("torch", "onnxruntime")
TEACHER_SEARCH = ("learner", "hierarchical")


def teacher_network(value: str) -> OccNet:
    """The fixed network a "hybrid-acting" teacher plans with (its ``weights``): a weights file or a
    shipped network's name; it must have the heat-map head."""

    path = weights_file(value)
    if not Path(path).is_file():
        raise ValueError(f"teacher_weights {value!r} is neither a weights file nor a shipped network ({available()})")
    net = load_weights(path)
    if not net.config.heatmap:
        raise ValueError(f"teacher_weights {value!r} has no heat-map head; the hybrid planner needs one")
    logger.info("the hybrid-acting teacher plans with the fixed network %s (sha256 %s)", path, file_sha256(path)[:12])
    return net


def keep_successful_episodes(data: TensorDictBase) -> None:
    """Keep as labels only the frames of the episodes that end in success within the batch
    (``"expert_weight"`` 0 elsewhere, times any weight already there)."""
    successes = successful_episode_frames(data).to(torch.float32)
    if "expert_weight" in data.keys():
        successes = successes * data.get("expert_weight")
    data.set("expert_weight", successes)


def check_choice(teacher: str, name: str, value: str, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"the {teacher} teacher's {name} must be one of {allowed}, got {value!r}")


def check_single_collector(teacher: str, core: TrainConfig) -> None:
    if core.collector != "single":
        raise ValueError(
            f"imitation_teacher={teacher!r} needs collector 'single' (the teacher's network "
            f"or episode memory lives in this process), got collector {core.collector!r}"
        )


@dataclass(frozen=True)
class Teacher:
    """A teacher of the imitation phase. Subclasses are frozen dataclasses of the teacher's own
    settings with a registered :attr:`name`; the defaults below are those of a privileged
    retriever that acts in a share ``beta`` of the steps and labels every frame afterwards."""

    name: ClassVar[str] = ""

    def validate(self, core: TrainConfig) -> None:
        """Refuse settings that are out of range or do not go with the run's (``ValueError``)."""

    def fixed_network(self) -> OccNet | None:
        """A network the teacher plans with that is not the learner (loaded once, before the
        learner is built); None: none."""
        return None

    def make_expert(self, acting_net: OccNet, seed: int, fixed_net: OccNet | None = None) -> TensorDictModuleBase | None:
        """The decision maker that acts and labels (None: the learner acts and labels itself);
        planners are reseeded every iteration."""
        return ScriptedRetriever()

    def collection_policy(self, acting_policy: TensorDictModuleBase, expert: TensorDictModuleBase | None) -> TensorDictModuleBase:
        """What the collector runs: the learner's policy with the expert acting in a share ``beta``
        of the steps (set per iteration on the returned policy)."""
        return ExpertMixPolicy(acting_policy, expert, 0.0)

    def beta(self, iteration: int, imitation: ImitationConfig) -> float:
        """The share the teacher acts in at imitation ``iteration``: 1 decaying linearly to
        ``beta_min`` over ``beta_iters`` iterations (``beta_min`` from the start when 0)."""
        if imitation.beta_iters <= 0:
            return imitation.beta_min
        return max(imitation.beta_min, 1.0 - iteration / imitation.beta_iters)

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        """Write the imitation labels of a collected batch (``"expert_action"``, and
        ``"expert_weight"`` where only some frames are labels); ``seed`` seeds a planner that labels."""
        label_with_expert(data, expert)

    def summary(self, expert: TensorDictModuleBase | None) -> dict:
        """The teacher's own figures for an iteration's metrics row."""
        return {}

    def settings(self) -> dict:
        """The teacher's settings, by field name."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class LearnerActsTeacher(Teacher):
    """A teacher that only labels: the learner acts in every step (no expert acts, ``beta`` 0)."""

    def make_expert(self, acting_net: OccNet, seed: int, fixed_net: OccNet | None = None) -> TensorDictModuleBase | None:
        return None

    def collection_policy(self, acting_policy: TensorDictModuleBase, expert: TensorDictModuleBase | None) -> TensorDictModuleBase:
        return acting_policy

    def beta(self, iteration: int, imitation: ImitationConfig) -> float:
        return 0.0


@dataclass(frozen=True)
class ScriptedTeacher(Teacher):
    """The privileged scripted retriever (reach, grasp, pull: it reads the true poses) acts in a
    share beta of the steps and labels every frame."""

    name: ClassVar[str] = "scripted"


@dataclass(frozen=True)
class ClearingTeacher(Teacher):
    """The privileged clearing retriever (it carries the objects in the target's corridor aside
    first) acts as the scripted one does, but labels only the frames from the first sight of the
    target on, so the learner keeps its own search."""

    name: ClassVar[str] = "clearing"

    def make_expert(self, acting_net: OccNet, seed: int, fixed_net: OccNet | None = None) -> TensorDictModuleBase | None:
        return ClearingRetriever()

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        label_with_expert(data, expert)
        data.set("expert_weight", since_first_sight(data).to(torch.float32))


@dataclass(frozen=True)
class ObservedClearingTeacher(Teacher):
    """The clearing retriever deciding from the observations alone
    (:class:`~occrl.baselines.observed_clearing.ObservedClearingRetriever`): the learner searches;
    from the first sight of the target the teacher acts in a share beta of the episodes, and only
    the frames it acted on are labels (on the learner's states its corrections are mostly "back
    out first": docs/design/training.md). Collector "single"."""

    name: ClassVar[str] = "clearing-observed"

    search: str = "learner"
    """Who searches before the target is first seen in the episodes the teacher is drawn for:
    "learner" (the learner's own policy; only the teacher's retrieval frames are labels) or
    "hierarchical" (the hierarchical planner's Search, observations only: sweeps from the nearer
    end outside the shelf, stopping at the first detection, and the closest object rearranged
    where a sweep finds nothing; then the clearing retriever, which has followed the whole
    episode; the teacher acts and labels its drawn episodes from their start. The two together
    solve 86.5 % of the held-out stage-2 tasks: scripts/handover.py --from hierarchical --to
    clearing-observed)."""
    action_noise: float = 0.0
    """Where the teacher acts, Gaussian noise of this standard deviation (action units) is added to
    its executed motion, the label staying its decision (DART: demonstrations of recoveries from a
    learner's small errors; beyond the paper, docs/design/training.md)."""
    label_episodes: str = "all"
    """Which episodes' frames are labels: "all", or "success" (only the frames of episodes that end
    in success within the batch; the others still train the value and heat-map heads)."""

    def validate(self, core: TrainConfig) -> None:
        check_choice(self.name, "search", self.search, TEACHER_SEARCH)
        check_choice(self.name, "label_episodes", self.label_episodes, LABEL_EPISODES)
        check_single_collector(self.name, core)

    def make_expert(self, acting_net: OccNet, seed: int, fixed_net: OccNet | None = None) -> TensorDictModuleBase | None:
        if self.search == "hierarchical":
            from occrl.baselines.hierarchical import HierarchicalPlanner  # needs OMPL

            searcher = HierarchicalPlanner(seed=seed, **HIERARCHICAL_TEACHER)
            return SearchThenRetrieve(searcher, ObservedClearingRetriever(), retriever_follows=True)
        return ObservedClearingRetriever()

    def collection_policy(self, acting_policy: TensorDictModuleBase, expert: TensorDictModuleBase | None) -> TensorDictModuleBase:
        from_first_sight = self.search == "learner"  # the learner searches, the teacher acts from the first sight
        return OnlineTeacherPolicy(acting_policy, expert, 0.0, from_first_sight=from_first_sight, action_noise=self.action_noise)

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        # labelled while collecting; only the teacher's own frames are labels
        data.set("expert_weight", data.get("teacher_acts").reshape(data.shape).to(torch.float32))
        if self.label_episodes == "success":
            keep_successful_episodes(data)


@dataclass(frozen=True)
class HybridTeacher(LearnerActsTeacher):
    """Expert iteration: the learner acts, and the hybrid 4x4 planner on the current network labels
    every frame (a teacher that, like the learner, sees only detections)."""

    name: ClassVar[str] = "hybrid"

    inference: str = "torch"
    """Network inference of the planner: "torch" or "onnxruntime" (pip install onnx onnxruntime;
    ~1.2x the labels per second, the same network to float rounding, re-exported after every
    update). Like the device, it changes rounding only: a run may resume under the other.
    Promotion checks always plan with torch, as evaluations do."""

    def validate(self, core: TrainConfig) -> None:
        check_choice(self.name, "inference", self.inference, TEACHER_INFERENCE)
        if not core.heatmap:
            raise ValueError(f"imitation_teacher={self.name!r} needs the heat-map head (the hybrid planner uses it)")

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        label_with_planner(data, acting_net, seed=seed, inference=self.inference)


@dataclass(frozen=True)
class HybridActingTeacher(Teacher):
    """The hybrid 4x4 planner acts in every episode and its actions are the labels, so the value
    learns the planner's own returns. Collector "single"."""

    name: ClassVar[str] = "hybrid-acting"

    inference: str = "torch"
    """Network inference of the acting planner: "torch" or "onnxruntime" (as the "hybrid" teacher's)."""
    weights: str = ""
    """Plan with this fixed network (a weights file or a shipped name such as "occnet-takeover"; it
    needs the heat-map head) instead of the live learner. The learner then learns from the
    episodes of a planner that does not change, and may itself lack the heat-map head
    (heatmap=False: the greedy / stochastic baselines' network trained on the same planner's
    episodes as the full network). "": the live network (expert iteration)."""
    retrieval_takeover: float = 0.0
    """The share of episodes (drawn per world and episode) in which the privileged scripted
    retriever acts instead of the planner from the first step whose observation shows the target to
    the episode's end; its actions are then the labels, along its own trajectory
    (occrl.training.dagger.RetrievalTakeover). 0: the planner acts throughout."""
    label_episodes: str = "all"
    """Which episodes' frames are labels: "all", or "success" (those that end in success within the batch)."""

    def validate(self, core: TrainConfig) -> None:
        check_choice(self.name, "inference", self.inference, TEACHER_INFERENCE)
        check_choice(self.name, "label_episodes", self.label_episodes, LABEL_EPISODES)
        if not 0.0 <= self.retrieval_takeover <= 1.0:
            raise ValueError(f"retrieval_takeover must be a share in [0, 1], got {self.retrieval_takeover!r}")
        if not core.heatmap and not self.weights:
            raise ValueError(
                f"imitation_teacher={self.name!r} needs the heat-map head (the hybrid planner uses it), "
                "or teacher_weights naming a fixed network with one to plan with"
            )
        check_single_collector(self.name, core)

    def fixed_network(self) -> OccNet | None:
        return teacher_network(self.weights) if self.weights else None

    def make_expert(self, acting_net: OccNet, seed: int, fixed_net: OccNet | None = None) -> TensorDictModuleBase | None:
        if fixed_net is not None and fixed_net.config.image_size != acting_net.config.image_size:
            raise ValueError(
                f"teacher_weights {self.weights!r} reads {fixed_net.config.image_size} px images, the learner "
                f"{acting_net.config.image_size} px; they must see the same images"
            )
        planning_net = acting_net if fixed_net is None else fixed_net
        expert = HybridPlanner(planning_net, m=4, h=4, seed=seed, inference=self.inference, batch_worlds=True)
        if self.retrieval_takeover > 0:  # the scripted retriever acts in a share of the retrievals
            expert = RetrievalTakeover(expert, ScriptedRetriever(), self.retrieval_takeover, seed=seed)
        return expert

    def beta(self, iteration: int, imitation: ImitationConfig) -> float:
        return 1.0  # the planner acts throughout

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        data.set("expert_action", data.get("action").clone())  # the planner acted
        if self.label_episodes == "success":
            keep_successful_episodes(data)

    def summary(self, expert: TensorDictModuleBase | None) -> dict:
        if isinstance(expert, RetrievalTakeover):  # the share of frames the retriever acted in
            return {"takeover_share": expert.frames_taken_over / max(expert.frames, 1)}
        return {}


@dataclass(frozen=True)
class HierarchicalTeacher(Teacher):
    """The OMPL hierarchical planner (observations only) acts in a share beta of the episodes and
    labels every step of the others, while collecting (it remembers the episode). Collector
    "single"; needs OMPL."""

    name: ClassVar[str] = "hierarchical"

    action_noise: float = 0.0
    """Where the teacher acts, Gaussian noise of this standard deviation (action units) is added to
    its executed motion, the label staying its decision (DART)."""
    label_episodes: str = "all"
    """"all", or "success": only the frames of the episodes the teacher acted in and that end in
    success within the batch (its own successful demonstrations; its labels on the learner's
    states are dropped)."""

    def validate(self, core: TrainConfig) -> None:
        check_choice(self.name, "label_episodes", self.label_episodes, LABEL_EPISODES)
        check_single_collector(self.name, core)

    def make_expert(self, acting_net: OccNet, seed: int, fixed_net: OccNet | None = None) -> TensorDictModuleBase | None:
        from occrl.baselines.hierarchical import HierarchicalPlanner  # needs OMPL

        return HierarchicalPlanner(seed=seed, **HIERARCHICAL_TEACHER)

    def collection_policy(self, acting_policy: TensorDictModuleBase, expert: TensorDictModuleBase | None) -> TensorDictModuleBase:
        return OnlineTeacherPolicy(acting_policy, expert, 0.0, action_noise=self.action_noise)

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        if self.label_episodes == "success":  # labelled while collecting; its own episodes only
            data.set("expert_weight", data.get("teacher_acts").reshape(data.shape).to(torch.float32))
            keep_successful_episodes(data)


@dataclass(frozen=True)
class SelfTeacher(LearnerActsTeacher):
    """Self-imitation: the learner acts and its own actions in the episodes that succeed are the
    labels (a policy-gradient step on the success probability; beyond the paper: docs/design/training.md,
    "Cloning only successes")."""

    name: ClassVar[str] = "self"

    label_episodes: str = "success"
    """Must be "success": the learner's own actions of every episode as labels teach nothing (their
    expected gradient is zero)."""

    def validate(self, core: TrainConfig) -> None:
        if self.label_episodes != "success":
            raise ValueError(
                "imitation_teacher='self' needs label_episodes='success': the learner's own actions of every "
                "episode as labels teach nothing (their expected gradient is zero)"
            )

    def label(self, data: TensorDictBase, expert: TensorDictModuleBase | None, acting_net: OccNet, seed: int) -> None:
        data.set("expert_action", data.get("action").clone())  # the learner acted
        keep_successful_episodes(data)


#: Every teacher by its name (``occrl train --imitation-teacher NAME``).
TEACHERS: dict[str, type[Teacher]] = {
    cls.name: cls
    for cls in (
        ScriptedTeacher,
        ClearingTeacher,
        ObservedClearingTeacher,
        HybridTeacher,
        HybridActingTeacher,
        HierarchicalTeacher,
        SelfTeacher,
    )
}
