"""DAgger-style warm start: the learner acts, the privileged scripted retriever labels.

Behaviour cloning on expert trajectories compounds errors once the learner drifts; DAgger labels
the states the *learner* visits (Ross et al., 2011). Early on, the expert itself acts with
probability ``beta`` so the learner sees successful endings too; ``beta`` decays to 0.
:func:`label_with_planner` labels with the hybrid planner instead (expert iteration): a teacher
that, like the learner, sees only detections and searches for a hidden target.
:class:`OnlineTeacherPolicy` labels while collecting, for a teacher that keeps a memory of the
episode (the hierarchical planner: accumulated detections, its stage and its current plan), which
must see every observation of the learner's episode in order. :class:`RetrievalTakeover` lets a
privileged retriever act in a share of the episodes from the first sight of the target, so that
its labels lie on its own, consistent trajectories. :func:`since_first_sight` marks the frames a
retrieval teacher labels (the "clearing" teacher). The teachers that use them:
:mod:`occrl.training.teachers`.
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.baselines.scripted import ScriptedRetriever
from occrl.envs import world_constants as C
from occrl.planners import HybridPlanner

__all__ = [
    "ExpertMixPolicy",
    "OnlineTeacherPolicy",
    "RetrievalTakeover",
    "label_with_expert",
    "label_with_planner",
    "since_first_sight",
    "target_in_view",
]


class ExpertMixPolicy(TensorDictModuleBase):
    """Run the learner's policy (keeping its recurrent state and log-prob) and replace its action
    by the expert's with probability ``beta`` per step.

    Examples:
        >>> import torch
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.training.dagger import ExpertMixPolicy
        >>> net = make_occnet("paper")
        >>> td = make_env(batch_size=1, seed=0).append_transform(net.make_primer()).reset()
        >>> expert_action = ScriptedRetriever()(td.clone())["action"]
        >>> mix = ExpertMixPolicy(net.policy, ScriptedRetriever(), beta=1.0)  # the expert always acts
        >>> out = mix(td.clone())
        >>> torch.equal(out["action"], expert_action), "action_log_prob" in out.keys()
        (True, True)
        >>> mix.beta = 0.0  # the learner always acts
        >>> torch.equal(mix(td.clone())["action"], expert_action)
        False
    """

    def __init__(self, policy: TensorDictModuleBase, expert: ScriptedRetriever, beta: float = 1.0) -> None:
        super().__init__()
        self.policy = policy
        self.expert = expert
        # a buffer, so that collectors' weight updates carry it to worker processes
        self.register_buffer("_beta", torch.tensor(float(beta)))
        self.in_keys = list(policy.in_keys) + ["privileged", "gripper_closed"]
        self.out_keys = list(policy.out_keys)

    @property
    def beta(self) -> float:
        return float(self._beta)

    @beta.setter
    def beta(self, value: float) -> None:
        self._beta.fill_(float(value))

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict = self.policy(tensordict)
        if self.beta > 0:  # with beta = 0 the trainer labels the whole batch afterwards
            learner = tensordict.get("action")
            expert = self.expert(tensordict.copy()).get("action")
            take = torch.rand(learner.shape[:-1] + (1,)) < self.beta
            tensordict.set("action", torch.where(take, expert, learner))
        return tensordict


class OnlineTeacherPolicy(ExpertMixPolicy):
    """DAgger with a teacher that remembers the episode: the teacher sees every observation of
    every episode, in order, and its decision is written as ``"expert_action"`` on every step;
    who acts is drawn per episode and world (the teacher with probability ``beta``), so the
    teacher's own episodes run undisturbed and the learner's are labelled on the states the
    learner reaches.

    Only the teacher's ``in_keys`` are passed to it (never ``"privileged"``), so a teacher that
    reads only observations stays a fair one. ``"teacher_acts"`` records who acted. Built for the
    hierarchical planner with ``follow_tolerance`` (it re-plans when the learner leaves its plan);
    the teacher's memory lives in this process, so collect with a single-process collector.

    ``from_first_sight``: in its drawn episodes the teacher acts only from the first step whose
    observation shows the target (:func:`target_in_view`) on, the learner before (for a teacher
    that retrieves but does not search, such as
    :class:`~occrl.baselines.observed_clearing.ObservedClearingRetriever`).

    ``label_kinds``: label only the steps where the teacher's action is of these kinds (its
    ``last_action_kinds``, e.g. ``("reach", "extract")``: the teacher teaches the retrieval of a
    located target and leaves the search to the learner); ``"expert_weight"`` is 1 on those steps
    and 0 elsewhere (:func:`occrl.objectives.imitation_nll` averages over the labelled ones).

    ``action_noise`` (DART, Laskey et al. 2017): where the teacher acts, the executed motion
    (forward, lateral, rotation) is its decision plus Gaussian noise of this standard deviation
    (in action units, clipped to [-1, 1]; the gripper command is left as decided), while the
    label stays the decision. The teacher then shows how it recovers from the small errors a
    learner makes, on states near its own path; the noise comes from torch's global generator
    (seeded per iteration by the trainer).

    Examples:
        >>> import torch
        >>> from occrl.baselines import HierarchicalPlanner
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.training.dagger import OnlineTeacherPolicy
        >>> net = make_occnet("paper")
        >>> env = make_env(batch_size=2, stage=1, seed=0).append_transform(net.make_primer())
        >>> teacher = HierarchicalPlanner(plan_seconds=0.5, follow_tolerance=(0.01, 0.15))
        >>> data = env.rollout(3, OnlineTeacherPolicy(net.policy, teacher, beta=0.0))
        >>> data["expert_action"].shape, bool(data["teacher_acts"].any())
        (torch.Size([2, 3, 4]), False)
    """

    def __init__(
        self,
        policy: TensorDictModuleBase,
        teacher: TensorDictModuleBase,
        beta: float = 0.0,
        label_kinds: tuple[str, ...] | None = None,
        from_first_sight: bool = False,
        action_noise: float = 0.0,
    ) -> None:
        super().__init__(policy, teacher, beta)
        if not 0.0 <= float(action_noise) <= 1.0:
            raise ValueError(f"action_noise must be in [0, 1] (a standard deviation in action units), got {action_noise!r}")
        self.action_noise = float(action_noise)
        if "privileged" in teacher.in_keys:
            raise ValueError("the online teacher must read observations only; its in_keys contain 'privileged'")
        if label_kinds is not None and not hasattr(teacher, "last_action_kinds"):
            raise ValueError(f"label_kinds needs a teacher that reports last_action_kinds; {type(teacher).__name__} does not")
        self.label_kinds = None if label_kinds is None else tuple(label_kinds)
        self.in_keys = list(dict.fromkeys(list(policy.in_keys) + list(teacher.in_keys)))
        self.out_keys = list(policy.out_keys) + ["expert_action", "teacher_acts"] + (["expert_weight"] if label_kinds is not None else [])
        self.from_first_sight = bool(from_first_sight)
        self._teacher_acts: torch.Tensor | None = None  # per world: the teacher acts in this episode
        self._seen: torch.Tensor | None = None  # per world: the target has been in view in this episode

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        tensordict = self.policy(tensordict)
        label = self.expert(tensordict.select(*self.expert.in_keys).copy()).get("action")
        is_init = tensordict.get("is_init").reshape(label.shape[:-1])
        if self._teacher_acts is None or self._teacher_acts.shape != is_init.shape:
            self._teacher_acts = torch.zeros(is_init.shape, dtype=torch.bool)
        draw = torch.rand(is_init.shape) < self.beta
        self._teacher_acts = torch.where(is_init, draw, self._teacher_acts)
        acts = self._teacher_acts
        if self.from_first_sight:  # a teacher that does not search takes over once the target is seen
            in_view = target_in_view(tensordict).reshape(is_init.shape)
            seen_before = torch.zeros_like(in_view) if self._seen is None or self._seen.shape != in_view.shape else self._seen
            self._seen = in_view | (seen_before & ~is_init)
            acts = acts & self._seen
        acts = acts.unsqueeze(-1)
        tensordict.set("expert_action", label)
        if self.label_kinds is not None:
            kinds = self.expert.last_action_kinds
            weight = torch.tensor([k in self.label_kinds for k in kinds], dtype=torch.float32).reshape(*label.shape[:-1], 1)
            tensordict.set("expert_weight", weight)
        tensordict.set("teacher_acts", acts.clone())
        executed = label
        if self.action_noise > 0.0:
            noise = torch.randn(label.shape) * self.action_noise
            noise[..., 3] = 0.0  # the gripper command as decided
            executed = (label + noise).clamp(-1.0, 1.0)
        tensordict.set("action", torch.where(acts, executed, tensordict.get("action")))
        return tensordict


class RetrievalTakeover(TensorDictModuleBase):
    """The planner acts; in a share of the episodes a retriever takes over from the first step
    whose observation shows the target (:func:`target_in_view`) to the end of the episode. Who may
    take over is drawn per world at each episode start (probability ``share``, from a generator
    reseeded with :meth:`reseed`); the planner decides only for the worlds it still acts in, the
    retriever for the taken-over worlds together. The retriever decides from each step alone (the
    privileged scripted or clearing retriever; one with an episode memory, which reads
    ``"is_init"``, is refused).

    For the "hybrid-acting" teacher with ``retrieval_takeover > 0``: the executed action is the
    label, so the retrieval labels are the retriever's own trajectory (an approach kept over
    steps, backed out of only when it fails), not its answers on states the planner reached (which
    made the planner worse: docs/lab/training-teachers.md). ``frames_taken_over`` / ``frames`` count the steps
    since :meth:`reset`.

    Examples:
        >>> import torch
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import HybridPlanner
        >>> from occrl.training.dagger import RetrievalTakeover
        >>> net = make_occnet("paper").eval()
        >>> env = make_env(batch_size=2, stage=2, seed=1).append_transform(net.make_primer())
        >>> mix = RetrievalTakeover(HybridPlanner(net, m=2, h=2), ScriptedRetriever(), share=1.0)
        >>> td = env.reset()  # the target is hidden in the first world, seen in the second
        >>> mix(td.clone())["action"][1].tolist() == ScriptedRetriever()(td.clone())["action"][1].tolist()
        True
        >>> mix.frames_taken_over, mix.frames
        (1, 2)
    """

    def __init__(self, planner: TensorDictModuleBase, retriever: TensorDictModuleBase, share: float, seed: int = 0) -> None:
        super().__init__()
        if not 0.0 <= float(share) <= 1.0:
            raise ValueError(f"share must be in [0, 1], got {share!r}")
        if "is_init" in retriever.in_keys:
            raise ValueError(f"the retriever must decide from each step alone; {type(retriever).__name__} keeps an episode memory")
        self.planner, self.retriever, self.share = planner, retriever, float(share)
        self.in_keys = list(
            dict.fromkeys(["is_init", *planner.in_keys, *retriever.in_keys, ("objects", "detected"), ("objects", "type_id"), "target_type"])
        )
        self.out_keys = ["action"]
        self.seed = int(seed)
        self.generator = torch.Generator().manual_seed(self.seed)
        self.frames = self.frames_taken_over = 0
        self._may = self._taken = None  # per world: may the retriever take over / has it

    def reseed(self, seed: int) -> None:
        self.seed = int(seed)
        self.generator.manual_seed(self.seed)
        if hasattr(self.planner, "reseed"):
            self.planner.reseed(seed)

    def sync_weights(self) -> None:
        self.planner.sync_weights()

    def reset(self) -> None:
        """Forget every world's episode, the retriever's plan caches and the counts."""
        self.retriever.reset()
        self._may = self._taken = None
        self.frames = self.frames_taken_over = 0

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        n = flat.shape[0]
        is_init = flat.get("is_init").reshape(n)
        if self._may is None or self._may.shape[0] != n:
            self._may, self._taken = torch.zeros(n, dtype=torch.bool), torch.zeros(n, dtype=torch.bool)
        draw = torch.rand(n, generator=self.generator) < self.share
        self._may = torch.where(is_init, draw, self._may)
        self._taken = (self._taken & ~is_init) | (self._may & target_in_view(flat))
        action = torch.zeros(n, C.ACTION_DIM)
        planned = torch.nonzero(~self._taken).reshape(-1)
        if planned.numel():
            action[planned] = self.planner(flat[planned].select(*self.planner.in_keys).copy()).get("action").reshape(-1, C.ACTION_DIM)
        taken = torch.nonzero(self._taken).reshape(-1)
        if taken.numel():
            action[taken] = self.retriever(flat[taken].select(*self.retriever.in_keys).copy()).get("action").reshape(-1, C.ACTION_DIM)
        self.frames += n
        self.frames_taken_over += int(taken.numel())
        tensordict.set("action", action.reshape(*tensordict.shape, C.ACTION_DIM))
        return tensordict


@torch.no_grad()
def label_with_expert(data: TensorDictBase, expert: ScriptedRetriever) -> TensorDictBase:
    """Write ``"expert_action"`` for every step of a collected batch (expert reads privileged keys).

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.training.dagger import label_with_expert
        >>> net = make_occnet("paper")
        >>> data = make_env(batch_size=1, seed=0).append_transform(net.make_primer()).rollout(2, net.policy)
        >>> label_with_expert(data, ScriptedRetriever())["expert_action"].shape
        torch.Size([1, 2, 4])
    """
    flat = data.reshape(-1)
    labels = expert(flat.select("gripper_pose", "gripper_opening", "gripper_closed", "privileged").copy()).get("action")
    data.set("expert_action", labels.reshape(*data.shape, -1))
    return data


def target_in_view(data: TensorDictBase) -> torch.Tensor:
    """Per frame: whether the observation's detections include the target (an object of the
    target's type), as the learner sees it. Shape: the batch's.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.training.dagger import target_in_view
        >>> td = make_env(batch_size=2, stage=2, seed=1, heatmap_target=False).reset()
        >>> target_in_view(td).tolist()  # hidden in the first world, seen in the second
        [False, True]
    """
    detected = data.get(("objects", "detected"))
    same_type = data.get(("objects", "type_id")) == data.get("target_type")
    return (detected & same_type).any(-1)


def since_first_sight(data: TensorDictBase) -> torch.Tensor:
    """Per frame of a collected batch (worlds x steps): whether the target has been in view
    (:func:`target_in_view`) at this frame or earlier in the same episode (``"is_init"`` starts
    one). Shape: the batch's.

    Examples:
        >>> import torch
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.training.dagger import since_first_sight, target_in_view
        >>> net = make_occnet("paper")
        >>> data = make_env(batch_size=2, stage=2, seed=1).append_transform(net.make_primer()).rollout(3, net.policy)
        >>> bool((since_first_sight(data) >= target_in_view(data)).all())
        True
    """
    shown = target_in_view(data)
    starts = data.get("is_init").reshape(shown.shape)
    seen = torch.zeros_like(shown)
    for t in range(shown.shape[-1]):
        before = seen[..., t - 1] & ~starts[..., t] if t else torch.zeros_like(shown[..., 0])
        seen[..., t] = before | shown[..., t]
    return seen


def label_with_planner(data: TensorDictBase, net, seed: int = 0, m: int = 4, h: int = 4, inference: str = "torch") -> TensorDictBase:
    """Write ``"expert_action"``: the hybrid m x h planner's decision on every step of a collected
    batch, each from the step's own observation and stored LSTM state (expert iteration: the
    planner improves on the network, the network imitates the planner; no privileged keys).

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.training.dagger import label_with_planner
        >>> net = make_occnet("paper").eval()
        >>> data = make_env(batch_size=1, seed=0).append_transform(net.make_primer()).rollout(2, net.policy)
        >>> label_with_planner(data, net, m=2, h=2)["expert_action"].shape
        torch.Size([1, 2, 4])
    """
    planner = HybridPlanner(net, m=m, h=h, seed=seed, inference=inference, batch_worlds=True)
    flat = data.reshape(-1)
    labels = planner(flat.select(*planner.in_keys).copy()).get("action")
    data.set("expert_action", labels.reshape(*data.shape, -1))
    return data
