"""Training settings: :class:`TrainConfig`, the core of PPO, collection and curriculum with one
documented field per setting, its :class:`PromotionConfig` and its optional
:class:`ImitationConfig`, whose teacher (:mod:`occrl.training.teachers`) holds its own settings.

Every setting also has a flat name, one per ``occrl train`` option (``imitation_iters`` for
``imitation.iterations``, ``teacher_inference`` for the teacher's ``inference``):
:meth:`TrainConfig.flat_settings` and :meth:`TrainConfig.from_dict` translate, so that checkpoints
written before the nested form, model cards' recipes and command lines read as they always did.
The named presets built from it live in :mod:`occrl.training.presets`."""

from __future__ import annotations

import ast
import inspect
import textwrap
from dataclasses import dataclass, fields
from functools import lru_cache

import torch

from occrl.envs import world_constants as C
from occrl.training.removed_settings import drop_removed_settings
from occrl.training.teachers import LABEL_EPISODES, TEACHER_INFERENCE, TEACHER_SEARCH, TEACHERS, ScriptedTeacher, Teacher

__all__ = [
    "TrainConfig",
    "ImitationConfig",
    "PromotionConfig",
    "SETTING_CHOICES",
    "same_run_settings",
    "training_device",
    "dataclass_field_docs",
]

# The values a string setting accepts (checked when settings are read; ``occrl train`` offers them).
SETTING_CHOICES: dict[str, tuple[str, ...]] = {
    "collector": ("single", "multi", "ray"),
    "optimizer": ("rmsprop", "adam"),
    "imitation_teacher": tuple(TEACHERS),
    "label_episodes": LABEL_EPISODES,
    "promotion": ("learner", "hybrid"),
    "teacher_inference": TEACHER_INFERENCE,
    "teacher_search": TEACHER_SEARCH,
}

# The flat setting names (``occrl train``'s options, checkpoints before the nested form, model
# cards' recipes) of the imitation settings (ImitationConfig's fields) and of the teachers' own.
IMITATION_SETTINGS = {
    "imitation_iters": "iterations",
    "imitation_beta_iters": "beta_iters",
    "imitation_beta_min": "beta_min",
    "imitation_min_scale": "min_scale",
    "imitation_buffer_iters": "buffer_iters",
    "imitation_updates": "updates",
}
PROMOTION_SETTINGS = {
    "promotion": "rule",
    "promote_threshold": "threshold",
    "promote_window": "window",
    "promotion_eval_every": "eval_every",
    "promotion_eval_tasks": "eval_tasks",
}
TEACHER_SETTINGS = {
    "label_episodes": "label_episodes",
    "teacher_inference": "inference",
    "teacher_weights": "weights",
    "retrieval_takeover": "retrieval_takeover",
    "teacher_action_noise": "action_noise",
    "teacher_search": "search",
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
    body = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0].body
    docs = {}
    for node, after in zip(body, body[1:]):
        if isinstance(node, ast.AnnAssign) and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant):
            docs[node.target.id] = " ".join(str(after.value.value).split())
    return docs


@dataclass(frozen=True)
class PromotionConfig:
    """When the curriculum moves on to the next stage.

    Examples:
        >>> from occrl.training.config import PromotionConfig
        >>> PromotionConfig(rule="hybrid", eval_every=25).eval_tasks
        30
    """

    rule: str = "learner"
    """"hybrid" (the paper: hybrid 4x4 success on validation tasks > promote_threshold) or "learner"
    (the learner's own success over its last promote_window training episodes; cheaper)."""
    threshold: float = 0.8
    """Success rate that promotes to the next stage."""
    window: int = 300
    """Training episodes the "learner" rule averages over."""
    eval_every: int = 50
    """Iterations between "hybrid" promotion checks (imitation or PPO, not the critic warm-up)."""
    eval_tasks: int = 30
    """Validation tasks per "hybrid" check (95 % interval about +-15 points at 30, +-8 at 100)."""


@dataclass(frozen=True)
class ImitationConfig:
    """The imitation phase before PPO (beyond the paper: docs/design/training.md, "Training"): DAgger
    with a :class:`~occrl.training.teachers.Teacher` that labels the learner's frames and acts in a
    share ``beta`` of them.

    Examples:
        >>> from occrl.training.config import ImitationConfig
        >>> from occrl.training.teachers import HierarchicalTeacher
        >>> ImitationConfig(iterations=50, teacher=HierarchicalTeacher(action_noise=0.05)).to_dict()["teacher"]
        {'name': 'hierarchical', 'action_noise': 0.05, 'label_episodes': 'all'}
    """

    iterations: int = 0
    """Iterations of DAgger before PPO (0: PPO from the start)."""
    teacher: Teacher = ScriptedTeacher()
    """Who labels the learner's frames, with its own settings (occrl.training.teachers.TEACHERS)."""
    beta_iters: int = 10
    """The teacher acts with probability decaying from 1 to beta_min over these iterations (0:
    beta_min from the start)."""
    beta_min: float = 0.0
    """The teacher keeps acting this often (per step; per episode for the teachers that act in whole episodes)."""
    min_scale: float = 0.1
    """Standard-deviation floor of the imitation likelihood."""
    buffer_iters: int = 8
    """DAgger aggregates the labelled data of this many iterations."""
    updates: int = 0
    """Gradient steps per iteration on the aggregate (0: epochs over the new batch only)."""

    def validate(self, core: TrainConfig) -> None:
        """The teacher's checks against the run's settings (``ValueError``)."""
        self.teacher.validate(core)

    def to_dict(self) -> dict:
        settings = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "teacher"}
        return {**settings, "teacher": {"name": self.teacher.name, **self.teacher.settings()}}

    @classmethod
    def from_dict(cls, d: dict) -> "ImitationConfig":
        d = dict(d)
        teacher = dict(d.pop("teacher", {"name": ScriptedTeacher.name}))
        name = teacher.pop("name", None)
        if name not in TEACHERS:
            raise ValueError(f"imitation_teacher must be one of {tuple(TEACHERS)}, got {name!r}")
        check_known_keys("imitation settings", d, cls, skip=("teacher",))
        check_known_keys(f"{name} teacher settings", teacher, TEACHERS[name])
        return cls(**d, teacher=TEACHERS[name](**teacher))


def check_known_keys(what: str, settings: dict, config_class: type, skip: tuple[str, ...] = ()) -> None:
    """Refuse keys of ``settings`` that ``config_class`` (a dataclass) has no field for, naming the allowed ones.

    Examples:
        >>> from occrl.training.config import PromotionConfig, check_known_keys
        >>> check_known_keys("promotion settings", {"bogus": 1}, PromotionConfig)
        Traceback (most recent call last):
            ...
        ValueError: unknown promotion settings ['bogus']; allowed: ['eval_every', 'eval_tasks', 'rule', 'threshold', 'window']
    """
    allowed = {f.name for f in fields(config_class)} - set(skip)
    unknown = sorted(set(settings) - allowed - set(skip))
    if unknown:
        raise ValueError(f"unknown {what} {unknown}; allowed: {sorted(allowed)}")


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (besides the seed and the run folder).

    ``frames_per_batch = num_envs * steps_per_env``; every iteration starts all episodes afresh
    (``reset_at_each_iter``), which makes runs resumable exactly from a checkpoint. A checkpoint
    stores :meth:`to_dict` (nested); :meth:`from_dict` reads that or the flat names.

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

    imitation: ImitationConfig | None = None
    """The imitation phase before PPO and its teacher (None: PPO from the start; the ``imitation_*``,
    ``teacher_*``, ``label_episodes`` and ``retrieval_takeover`` options set it)."""
    critic_warmup_iters: int = 0
    """PPO iterations, after imitation, that train only the value (and heat-map) head."""

    # ---- curriculum
    start_stage: int = 1
    """Curriculum stage of a new run (1-3)."""
    promotion: PromotionConfig = PromotionConfig()
    """When the curriculum moves on (the ``promotion`` and ``promote_*`` / ``promotion_*`` options set it)."""
    replay_stage_workers: int = 0
    """Collector workers that keep collecting the previous stage after a promotion (collector
    "multi" or "ray", fewer than workers)."""
    noise: float = 0.0
    """Physics noise of the training tasks."""

    @property
    def frames_per_batch(self) -> int:
        return self.num_envs * self.steps_per_env

    @property
    def imitation_iterations(self) -> int:
        """Iterations of the imitation phase (0 without one)."""
        return 0 if self.imitation is None else self.imitation.iterations

    def validate(self) -> None:
        """Refuse settings that are out of range or do not go together (``ValueError`` naming what was
        wrong and what is allowed). The trainer calls it before it builds anything.

        Examples:
            >>> from occrl.training import get_train_config
            >>> get_train_config("tiny").validate()
            >>> get_train_config("tiny", imitation_teacher="self", label_episodes="all").validate()
            Traceback (most recent call last):
                ...
            ValueError: imitation_teacher='self' needs label_episodes='success': the learner's own actions of every episode as labels teach nothing (their expected gradient is zero)
        """
        flat = {"collector": self.collector, "optimizer": self.optimizer, "promotion": self.promotion.rule}
        for name, value in flat.items():  # the core's string settings with a fixed set of values
            if value not in SETTING_CHOICES[name]:
                raise ValueError(f"{name} must be one of {SETTING_CHOICES[name]}, got {value!r}")
        if self.promotion.eval_tasks < 1:
            raise ValueError(f"promotion_eval_tasks must be >= 1, got {self.promotion.eval_tasks}")
        if self.replay_stage_workers < 0:
            raise ValueError(f"replay_stage_workers must be >= 0, got {self.replay_stage_workers}")
        if self.replay_stage_workers and (self.collector == "single" or self.replay_stage_workers >= self.workers):
            raise ValueError(
                f"replay_stage_workers={self.replay_stage_workers} needs collector 'multi' or 'ray' and "
                f"fewer than workers={self.workers} (got collector {self.collector!r})"
            )
        if self.collector != "single" and (self.workers < 1 or self.num_envs % self.workers):
            raise ValueError(f"num_envs ({self.num_envs}) must be a multiple of workers ({self.workers}) with collector {self.collector!r}")
        if self.promotion.rule == "hybrid" and not self.heatmap:
            raise ValueError("promotion='hybrid' needs the heat-map head (the hybrid planner uses it); use 'learner'")
        if self.imitation is not None:
            self.imitation.validate(self)

    def to_dict(self) -> dict:
        """The settings as a checkpoint stores them (the imitation phase nested, with its teacher's)."""
        core = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("imitation", "promotion")}
        promotion = {f.name: getattr(self.promotion, f.name) for f in fields(self.promotion)}
        return {**core, "promotion": promotion, "imitation": None if self.imitation is None else self.imitation.to_dict()}

    def flat_settings(self) -> dict:
        """The settings by their flat names, one per ``occrl train`` option (``--imitation-iters``
        for ``imitation.iterations``, ``--teacher-inference`` for the teacher's ``inference``); the
        imitation and teacher settings a run does not use at their defaults.

        Examples:
            >>> from occrl.training import get_train_config
            >>> flat = get_train_config("cpu").flat_settings()
            >>> flat["imitation_iters"], flat["imitation_teacher"], flat["teacher_inference"]
            (400, 'scripted', 'torch')
        """
        flat = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("imitation", "promotion")}
        flat |= {setting: getattr(self.promotion, name) for setting, name in PROMOTION_SETTINGS.items()}
        imitation = self.imitation or ImitationConfig()
        flat |= {setting: getattr(imitation, name) for setting, name in IMITATION_SETTINGS.items()}
        flat["imitation_teacher"] = imitation.teacher.name
        own = imitation.teacher.settings()
        flat |= {setting: own.get(name, TEACHER_DEFAULTS[setting]) for setting, name in TEACHER_SETTINGS.items()}
        return flat

    @classmethod
    def field_docs(cls) -> dict[str, str]:
        """Each flat setting's docstring (:meth:`flat_settings`' names), by name: the help of the
        ``occrl train`` options.

        Examples:
            >>> from occrl.training import TrainConfig
            >>> TrainConfig.field_docs()["lr"]
            'Learning rate.'
        """
        return {name: doc for name, (kind, doc) in flat_setting_kinds().items()}

    @classmethod
    def setting_types(cls) -> dict[str, str]:
        """Each flat setting's type ("int", "float", "bool" or "str"), by name."""
        return {name: kind for name, (kind, doc) in flat_setting_kinds().items()}

    @classmethod
    def from_dict(cls, d: dict) -> "TrainConfig":
        """Settings from :meth:`to_dict` (e.g. a checkpoint's) or by their flat names
        (:meth:`flat_settings`; checkpoints written before the nested form, model cards' recipes).
        Settings occrl has removed are dropped where they were off, and refused with the version
        that had them otherwise (:data:`~occrl.training.removed_settings.REMOVED_SETTINGS`).

        Examples:
            >>> from occrl.training import TrainConfig
            >>> cfg = TrainConfig.from_dict({"imitation_iters": 5, "imitation_teacher": "hybrid", "teacher_inference": "onnxruntime"})
            >>> cfg.imitation.iterations, cfg.imitation.teacher
            (5, HybridTeacher(inference='onnxruntime'))
            >>> TrainConfig.from_dict(cfg.to_dict()) == cfg
            True
            >>> TrainConfig.from_dict({"teacher_search": "hierarchical"})
            Traceback (most recent call last):
                ...
            ValueError: teacher_search applies to imitation_teacher 'clearing-observed', not 'scripted' (got teacher_search='hierarchical')
        """
        d = drop_removed_settings(d)
        if "imitation" in d:  # the nested form (to_dict)
            if isinstance(d["imitation"], dict):
                d["imitation"] = ImitationConfig.from_dict(d["imitation"])
            if isinstance(d.get("promotion"), dict):
                check_known_keys("promotion settings", d["promotion"], PromotionConfig)
                d["promotion"] = PromotionConfig(**d["promotion"])
            unknown = set(d) - {f.name for f in fields(cls)}
            if unknown:
                raise ValueError(f"unknown training settings {sorted(unknown)}")
            return cls(**d)
        return cls.from_flat(d)

    @classmethod
    def from_flat(cls, d: dict) -> "TrainConfig":
        """Settings by their flat names (:meth:`flat_settings`); the ones not given take their defaults."""
        unknown = set(d) - set(flat_setting_kinds())
        if unknown:
            raise ValueError(f"unknown training settings {sorted(unknown)}")
        for name, allowed in SETTING_CHOICES.items():
            if name in d and d[name] not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, got {d[name]!r}")
        nested = {**IMITATION_SETTINGS, **PROMOTION_SETTINGS, **TEACHER_SETTINGS}
        core = {name: value for name, value in d.items() if name not in nested}
        promotion = PromotionConfig(**{name: d[setting] for setting, name in PROMOTION_SETTINGS.items() if setting in d})
        teacher_cls = TEACHERS[core.pop("imitation_teacher", ScriptedTeacher.name)]
        own = {f.name for f in fields(teacher_cls)}
        teacher = {}
        for setting, name in TEACHER_SETTINGS.items():
            if setting not in d:
                continue
            if name in own:
                teacher[name] = d[setting]
            elif d[setting] != TEACHER_DEFAULTS[setting]:
                users = " / ".join(repr(t) for t, c in TEACHERS.items() if name in {f.name for f in fields(c)})
                raise ValueError(f"{setting} applies to imitation_teacher {users}, not {teacher_cls.name!r} (got {setting}={d[setting]!r})")
        imitation = ImitationConfig(
            **{name: d[setting] for setting, name in IMITATION_SETTINGS.items() if setting in d}, teacher=teacher_cls(**teacher)
        )
        return cls(**core, promotion=promotion, imitation=None if imitation == ImitationConfig() else imitation)


@lru_cache(maxsize=1)
def flat_setting_kinds() -> dict[str, tuple[str, str]]:
    """Each flat setting's type and docstring, in ``occrl train``'s order: the core settings, then
    the imitation phase's and the teachers' (a teacher's setting documented by the first teacher
    in :data:`TEACHERS` that has it, naming every teacher that does)."""
    kinds = {}
    for cls, settings in ((TrainConfig, None), (PromotionConfig, PROMOTION_SETTINGS), (ImitationConfig, IMITATION_SETTINGS)):
        docs, types = dataclass_field_docs(cls), {f.name: str(f.type) for f in fields(cls)}
        for setting, name in (settings or {n: n for n in types if n not in ("imitation", "promotion")}).items():
            kinds[setting] = (types[name], docs[name])
    teachers = "; ".join(f'"{name}": {doc_line(cls).rstrip(".")}' for name, cls in TEACHERS.items())
    kinds["imitation_teacher"] = ("str", f"Who labels the learner's frames (occrl.training.teachers): {teachers}.")
    for setting, name in TEACHER_SETTINGS.items():
        users = [cls for cls in TEACHERS.values() if name in {f.name for f in fields(cls)}]
        kind = next(str(f.type) for f in fields(users[0]) if f.name == name)
        who = ", ".join(f'"{cls.name}"' for cls in users)
        kinds[setting] = (kind, f"{dataclass_field_docs(users[0])[name]} (teacher {who})")
    return kinds


def doc_line(cls: type) -> str:
    """A class's docstring, whitespace collapsed."""
    return " ".join((cls.__doc__ or "").split())


# the flat value of each teacher setting for a teacher that does not have it
TEACHER_DEFAULTS = {"label_episodes": "all", "teacher_inference": "torch", "teacher_weights": "", "retrieval_takeover": 0.0}
TEACHER_DEFAULTS |= {"teacher_action_noise": 0.0, "teacher_search": "learner"}


# settings that change where frames are computed but not which: a run may resume under another one
RUNTIME_SETTINGS = {"collector": {"multi", "ray"}}
# a run resumes on any device and teacher inference (they change float rounding, not the method)
MACHINE_SETTINGS = ("device", "teacher_inference")


def same_run_settings(saved: dict, current: dict) -> bool:
    """Equal training settings (stored ones, :meth:`TrainConfig.to_dict`'s or flat), except a run
    collected by "multi" may resume on "ray" and back, and on any device and teacher inference.
    Settings added after a checkpoint was written take their defaults (the behaviour it ran with);
    settings removed since are dropped where they were off (:meth:`TrainConfig.from_dict` refuses
    them otherwise)."""
    saved, current = TrainConfig.from_dict(saved).flat_settings(), TrainConfig.from_dict(current).flat_settings()
    for key, interchangeable in RUNTIME_SETTINGS.items():
        if saved.get(key) in interchangeable and current.get(key) in interchangeable:
            saved, current = {**saved, key: None}, {**current, key: None}
    for key in MACHINE_SETTINGS:
        saved, current = {**saved, key: None}, {**current, key: None}
    return saved == current


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
