"""Training settings: :class:`TrainConfig`, one documented field per setting, and its checks.

The named presets built from it live in :mod:`occrl.training.presets`."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
import torch

from occrl.envs import world_constants as C

__all__ = [
    "TrainConfig",
    "SETTING_CHOICES",
    "REMOVED_SETTINGS",
    "RemovedSetting",
    "drop_removed_settings",
    "training_device",
    "dataclass_field_docs",
]

# The values a string setting accepts (TrainConfig.validate checks them; ``occrl train`` offers them).
SETTING_CHOICES: dict[str, tuple[str, ...]] = {
    "collector": ("single", "multi", "ray"),
    "optimizer": ("rmsprop", "adam"),
    "imitation_teacher": ("scripted", "clearing", "clearing-observed", "hybrid", "hybrid-acting", "hierarchical", "self"),
    "label_episodes": ("all", "success"),
    "promotion": ("learner", "hybrid"),
    "teacher_inference": ("torch", "onnxruntime"),
    "teacher_search": ("learner", "hierarchical"),
}


def dataclass_field_docs(cls: type) -> dict[str, str]:
    """Each field's docstring (the string literal under it in the class body, whitespace
    collapsed), by name: the help of options made from a dataclass's fields (``occrl train``'s
    from :class:`TrainConfig`, a script's arguments).

    Examples:
        >>> from occrl.training.config import TrainConfig, dataclass_field_docs
        >>> dataclass_field_docs(TrainConfig)["minibatch_envs"]
        'Sequences (each steps_per_env long) per minibatch.'
    """
    import ast
    import inspect
    import textwrap

    body = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0].body
    docs = {}
    for node, after in zip(body, body[1:]):
        if isinstance(node, ast.AnnAssign) and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant):
            docs[node.target.id] = " ".join(str(after.value.value).split())
    return docs


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (besides the seed and the run folder).

    ``frames_per_batch = num_envs * steps_per_env``; every iteration starts all episodes afresh
    (``reset_at_each_iter``), which makes runs resumable exactly from a checkpoint.

    Examples:
        >>> from occrl.training import TrainConfig
        >>> cfg = TrainConfig(num_envs=4, steps_per_env=8)
        >>> cfg.frames_per_batch, TrainConfig.from_dict(cfg.to_dict()) == cfg
        (32, True)
        >>> TrainConfig.from_dict({"learning_rate": 1e-3})
        Traceback (most recent call last):
            ...
        ValueError: unknown training settings ['learning_rate']
    """

    preset: str = "paper"
    """Name of the preset these settings come from (results name it)."""
    net_preset: str = "paper"
    """Network architecture (:func:`occrl.modules.make_occnet` preset)."""
    heatmap: bool = True
    """Train the heat-map head and its BCE loss (False: the greedy / stochastic baselines' network)."""

    # ---- collection
    num_envs: int = 30
    """Worlds collected in parallel (over all collector workers)."""
    steps_per_env: int = 50
    """Steps per world and iteration; every iteration starts all episodes afresh."""
    collector: str = "single"
    """TorchRL collector: "single" (one process), "multi" (MultiSyncCollector) or "ray" (RayCollector)."""
    workers: int = 2
    """Collector processes or Ray actors ("multi", "ray"); num_envs must be a multiple of it."""
    device: str = "cpu"
    """Where the network, loss and optimiser run: "cpu", "cuda" or "cuda:N". Collection always acts on
    the CPU, on a copy of the network synchronised after every update; a run may resume on another device."""

    # ---- optimisation (the paper: RMSProp, lr 5e-5, c1 0.5, c2 0.01, c3 1.0)
    optimizer: str = "rmsprop"
    """"rmsprop" (the paper) or "adam"."""
    lr: float = 5e-5
    """Learning rate."""
    epochs: int = 4
    """PPO epochs over each collected batch."""
    minibatch_envs: int = 10
    """Sequences (each steps_per_env long) per minibatch."""
    max_grad_norm: float = 0.5
    """Gradient-norm clip."""
    clip_epsilon: float = 0.2
    """PPO ratio clip."""
    critic_coeff: float = 0.5
    """c1: weight of the value loss."""
    entropy_coeff: float = 0.01
    """c2: weight of the entropy bonus."""
    heatmap_coeff: float = 1.0
    """c3: weight of the heat-map BCE."""
    heatmap_fraction: float = 1.0
    """Share of a minibatch's frames whose heat-map is decoded for the BCE (1: all)."""
    batch_norm_frames: int = 1500
    """Frames that refresh the encoder's batch-norm statistics after each update (0: frozen)."""
    gamma: float = C.GAMMA
    """Discount."""
    gae_lambda: float = 0.95
    """GAE lambda."""
    target_kl: float = 0.0
    """> 0: stop an iteration's PPO epochs once a minibatch's approximate KL exceeds 1.5 x this."""

    # ---- imitation (beyond the paper: docs/decisions.md, "Training")
    imitation_iters: int = 0
    """Iterations of DAgger before PPO (0: PPO from the start)."""
    imitation_teacher: str = "scripted"
    """Who labels the learner's frames: "scripted" (the privileged scripted retriever), "clearing"
    (the privileged clearing retriever, which acts in a share beta of the episodes as "scripted"
    does, but labels only the frames from the first sight of the target on, so the learner keeps
    its own search: "expert_weight"), "clearing-observed" (the same retriever deciding from the
    observations alone, occrl.baselines.observed_clearing: the learner searches; from the first
    sight of the target the teacher acts in a share beta of the episodes, and only the frames it
    acted on are labels; collector "single"), "hybrid" (the
    hybrid 4x4 planner on the current network labels, the learner acts: expert iteration),
    "hybrid-acting" (that planner acts and labels, so the value learns the planner's own returns;
    collector "single"), "hierarchical" (the OMPL hierarchical planner, observations only, acts in
    a share beta of the episodes and labels every step of the others; collector "single") or
    "self" (the learner acts and its own actions are the labels; needs label_episodes "success":
    self-imitation, its successful episodes cloned)."""
    label_episodes: str = "all"
    """Which episodes' frames are imitation labels with the teachers whose labels are the actions
    taken ("self", "hybrid-acting", "clearing-observed") and with "hierarchical": "all", or
    "success" (only the frames of episodes that end in success within the batch; the others
    still train the value and heat-map heads). With "hierarchical", "success" keeps only the
    frames of the episodes the teacher acted in (its own successful demonstrations; its labels on
    the learner's states are dropped). With "self" the cloned successes are a policy-gradient step
    on the success probability (beyond the paper: docs/decisions.md, "Cloning only successes")."""
    teacher_inference: str = "torch"
    """Network inference of the hybrid-planner teachers ("hybrid", "hybrid-acting"): "torch" or
    "onnxruntime" (pip install onnx onnxruntime; ~1.2x the labels per second, the same network to
    float rounding, re-exported after every update). Like the device, it changes rounding only: a
    run may resume under the other. Promotion checks always plan with torch, as evaluations do."""
    teacher_weights: str = ""
    """"hybrid-acting": plan with this fixed network (a weights file or a shipped name such as
    "occnet-takeover"; it needs the heat-map head) instead of the live learner. The learner then
    learns from the episodes of a planner that does not change, and may itself lack the heat-map
    head (heatmap=False: the greedy / stochastic baselines' network trained on the same planner's
    episodes as the full network). "": the live network (expert iteration)."""
    retrieval_takeover: float = 0.0
    """"hybrid-acting": the share of episodes (drawn per world and episode) in which a retriever
    (takeover_retriever; the privileged scripted one by default) acts instead of the planner from
    the first step whose observation shows the target (takeover_at) to the episode's end; its
    actions are then the labels, along its own trajectory (occrl.training.dagger.RetrievalTakeover).
    0: the planner acts throughout."""
    teacher_action_noise: float = 0.0
    """The "hierarchical" and "clearing-observed" teachers: where the teacher acts, Gaussian noise
    of this standard deviation (action units) is added to its executed motion, the label staying
    its decision (DART: demonstrations of recoveries from a learner's small errors; beyond the
    paper, docs/decisions.md)."""
    teacher_search: str = "learner"
    """Who searches before the target is first seen when the "clearing-observed" teacher is drawn:
    "learner" (the learner's own policy; only the teacher's retrieval frames are labels) or
    "hierarchical" (the hierarchical planner's Search, observations only: sweeps from the nearer
    end outside the shelf, stopping at the first detection, and the closest object rearranged where
    a sweep finds nothing; then the clearing retriever, which has followed the whole episode; the
    teacher acts and labels its drawn episodes from their start. The two together solve 86.5 % of
    the held-out stage-2 tasks: scripts/handover.py --from hierarchical --to clearing-observed)."""
    imitation_beta_iters: int = 10
    """The teacher acts with probability decaying from 1 to imitation_beta_min over these iterations
    (0: imitation_beta_min from the start)."""
    imitation_beta_min: float = 0.0
    """The teacher keeps acting this often (per step; per episode for "hierarchical")."""
    imitation_min_scale: float = 0.1
    """Standard-deviation floor of the imitation likelihood."""
    imitation_buffer_iters: int = 8
    """DAgger aggregates the labelled data of this many iterations."""
    imitation_updates: int = 0
    """Gradient steps per iteration on the aggregate (0: epochs over the new batch only)."""
    critic_warmup_iters: int = 0
    """PPO iterations, after imitation, that train only the value (and heat-map) head."""

    # ---- curriculum
    start_stage: int = 1
    """Curriculum stage of a new run (1-3)."""
    promotion: str = "learner"
    """"hybrid" (the paper: hybrid 4x4 success on validation tasks > promote_threshold) or "learner"
    (the learner's own success over its last promote_window training episodes; cheaper)."""
    promote_threshold: float = 0.8
    """Success rate that promotes to the next stage."""
    promote_window: int = 300
    """Training episodes the "learner" rule averages over."""
    promotion_eval_every: int = 50
    """Iterations between "hybrid" promotion checks (imitation or PPO, not the critic warm-up)."""
    promotion_eval_tasks: int = 30
    """Validation tasks per "hybrid" check (95 % interval about +-15 points at 30, +-8 at 100)."""
    replay_stage_workers: int = 0
    """Collector workers that keep collecting the previous stage after a promotion (collector
    "multi" or "ray", fewer than workers)."""
    noise: float = 0.0
    """Physics noise of the training tasks."""

    @property
    def frames_per_batch(self) -> int:
        return self.num_envs * self.steps_per_env

    def validate(self) -> None:
        """Refuse settings that are out of range or do not go together (``ValueError`` naming what was
        wrong and what is allowed). The trainer calls it before it builds anything.

        Examples:
            >>> from occrl.training import get_train_config
            >>> get_train_config("tiny").validate()
            >>> get_train_config("tiny", imitation_teacher="self").validate()
            Traceback (most recent call last):
                ...
            ValueError: imitation_teacher='self' needs label_episodes='success': the learner's own actions of every episode as labels teach nothing (their expected gradient is zero)
        """
        for name, allowed in SETTING_CHOICES.items():  # every string setting with a fixed set of values
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {getattr(self, name)!r}")
        if self.promotion_eval_tasks < 1:
            raise ValueError(f"promotion_eval_tasks must be >= 1, got {self.promotion_eval_tasks}")
        if self.replay_stage_workers < 0:
            raise ValueError(f"replay_stage_workers must be >= 0, got {self.replay_stage_workers}")
        if self.replay_stage_workers and (self.collector == "single" or self.replay_stage_workers >= self.workers):
            raise ValueError(
                f"replay_stage_workers={self.replay_stage_workers} needs collector 'multi' or 'ray' and "
                f"fewer than workers={self.workers} (got collector {self.collector!r})"
            )
        if not 0.0 <= self.retrieval_takeover <= 1.0:
            raise ValueError(f"retrieval_takeover must be a share in [0, 1], got {self.retrieval_takeover!r}")
        if self.retrieval_takeover > 0 and self.imitation_teacher != "hybrid-acting":
            raise ValueError(f"retrieval_takeover applies to imitation_teacher 'hybrid-acting', not {self.imitation_teacher!r}")
        if self.label_episodes != "all" and self.imitation_teacher not in ("self", "hybrid-acting", "clearing-observed", "hierarchical"):
            raise ValueError(
                f"label_episodes={self.label_episodes!r} applies to the teachers whose labels are the actions taken "
                f"('self', 'hybrid-acting', 'clearing-observed') and to 'hierarchical', not {self.imitation_teacher!r}"
            )
        if self.imitation_teacher == "self" and self.label_episodes != "success":
            raise ValueError(
                "imitation_teacher='self' needs label_episodes='success': the learner's own actions of every "
                "episode as labels teach nothing (their expected gradient is zero)"
            )
        if self.collector != "single" and (self.workers < 1 or self.num_envs % self.workers):
            raise ValueError(f"num_envs ({self.num_envs}) must be a multiple of workers ({self.workers}) with collector {self.collector!r}")
        if self.teacher_weights and self.imitation_teacher != "hybrid-acting":
            raise ValueError(f"teacher_weights applies to imitation_teacher 'hybrid-acting', not {self.imitation_teacher!r}")
        if self.imitation_teacher in ("hybrid", "hybrid-acting") and not self.heatmap and not self.teacher_weights:
            raise ValueError(
                f"imitation_teacher={self.imitation_teacher!r} needs the heat-map head (the hybrid planner uses it), "
                "or, for 'hybrid-acting', teacher_weights naming a fixed network with one to plan with"
            )
        if self.imitation_teacher in ("hybrid-acting", "hierarchical", "clearing-observed") and self.collector != "single":
            raise ValueError(
                f"imitation_teacher={self.imitation_teacher!r} needs collector 'single' (the teacher's network "
                f"or episode memory lives in this process), got collector {self.collector!r}"
            )
        if self.teacher_action_noise > 0 and self.imitation_teacher not in ("hierarchical", "clearing-observed"):
            raise ValueError(
                f"teacher_action_noise applies to imitation_teacher 'hierarchical' or 'clearing-observed', not {self.imitation_teacher!r}"
            )
        if self.teacher_search != "learner" and self.imitation_teacher != "clearing-observed":
            raise ValueError(f"teacher_search applies to imitation_teacher 'clearing-observed', not {self.imitation_teacher!r}")
        if self.promotion == "hybrid" and not self.heatmap:
            raise ValueError("promotion='hybrid' needs the heat-map head (the hybrid planner uses it); use 'learner'")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def field_docs(cls) -> dict[str, str]:
        """Each setting's docstring (the string under its field), by name: the help of the
        ``occrl train`` options.

        Examples:
            >>> from occrl.training import TrainConfig
            >>> TrainConfig.field_docs()["lr"]
            'Learning rate.'
        """
        return dataclass_field_docs(cls)

    @classmethod
    def from_dict(cls, d: dict) -> "TrainConfig":
        """Settings from :meth:`to_dict` (e.g. a checkpoint's). Settings occrl has removed are
        dropped where they were off, and refused with the version that had them otherwise."""
        d = drop_removed_settings(d)
        names = {f.name for f in fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise ValueError(f"unknown training settings {sorted(unknown)}")
        return cls(**d)


@dataclass(frozen=True)
class RemovedSetting:
    """A training setting occrl no longer has: the value that meant "off" (None: inert without the
    others, any value accepted) and the commit of the last version that had it."""

    off: object
    commit: str
    why: str


_EXPERIMENT = "an experiment that made no shipped network (docs/decisions.md)"
# Settings removed from the library: a stored config (a checkpoint's) that names one at its "off"
# value reads as if it did not; any other value is refused, naming the commit that still has it.
REMOVED_SETTINGS: dict[str, RemovedSetting] = {
    **{
        name: RemovedSetting(off, "eed1cea", "it only served experiments shown to hurt (docs/decisions.md)")
        for name, off in (("ppo_bc_coeff", 0.0), ("ppo_bc_min_scale", None), ("freeze_policy_scale", False))
    },
    **{
        name: RemovedSetting(off, "53b1240", _EXPERIMENT)
        for name, off in (
            ("detail_lr", 0.0),
            ("teacher_roots", "own"),
            ("teacher_to_the_end", False),
            ("start_scenes", ""),
            ("start_scenes_share", None),
            ("task_copies", 1),
            ("critic_to_trunk", True),
            ("success_weighting", "episode"),
            ("retrieval_labels", "planner"),
            ("takeover_retriever", "scripted"),
            ("takeover_at", "first-sight"),
            ("teacher_label_kinds", "all"),
            ("teacher_replan_inside", False),
            ("teacher_roll_in", 0),
        )
    },
}


def drop_removed_settings(stored: dict) -> dict:
    """``stored`` without the settings of :data:`REMOVED_SETTINGS`; ``ValueError`` where one is
    not at its "off" value, naming the commit whose occrl still has it.

    Examples:
        >>> from occrl.training.config import drop_removed_settings
        >>> drop_removed_settings({"lr": 1e-3, "task_copies": 1})
        {'lr': 0.001}
        >>> drop_removed_settings({"task_copies": 4})
        Traceback (most recent call last):
            ...
        ValueError: training setting task_copies=4 was removed from occrl (an experiment that made no shipped network (docs/decisions.md)); to run or resume with it, use the version that has it: git checkout 53b1240
    """
    kept = dict(stored)
    for name, removed in REMOVED_SETTINGS.items():
        if name in kept:
            value = kept.pop(name)
            if removed.off is not None and value != removed.off:
                raise ValueError(
                    f"training setting {name}={value!r} was removed from occrl ({removed.why}); "
                    f"to run or resume with it, use the version that has it: git checkout {removed.commit}"
                )
    return kept


def training_device(name: str) -> torch.device:
    """The torch device for ``TrainConfig.device``, with a clear error where it does not exist.

    Examples:
        >>> training_device("cpu")
        device(type='cpu')
        >>> training_device("tpu")
        Traceback (most recent call last):
            ...
        ValueError: device must be 'cpu', 'cuda' or 'cuda:N', got 'tpu'
    """
    try:
        device = torch.device(name)
    except (RuntimeError, TypeError):
        device = None
    if device is None or device.type not in ("cpu", "cuda"):
        raise ValueError(f"device must be 'cpu', 'cuda' or 'cuda:N', got {name!r}")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise ValueError(
                f"device {name!r}: no CUDA device is available here (torch.cuda.is_available() is False; "
                f"this torch build: {torch.__version__}); train with device 'cpu'"
            )
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise ValueError(f"device {name!r}: only {torch.cuda.device_count()} CUDA device(s) here")
    return device
