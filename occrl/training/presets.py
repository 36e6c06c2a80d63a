"""The named training presets (``occrl train --preset NAME``). Results always name the preset
they come from; :func:`get_train_config` applies a run's own settings on top of one."""

from __future__ import annotations

from dataclasses import replace

from occrl.training.config import TEACHER_SETTINGS, ImitationConfig, PromotionConfig, TrainConfig

__all__ = ["TRAIN_PRESETS", "get_train_config"]


# What every CPU preset shares on this project's 2-core machines: Adam, two epochs per batch,
# two collector processes of 32 envs, the heat-map loss on a random quarter of the frames.
_CPU_MACHINE = dict(optimizer="adam", epochs=2, collector="multi", num_envs=32, heatmap_fraction=0.25)

# What trains on these machines: the paper's network and loss, Adam at a higher learning rate,
# and a DAgger warm start on the scripted retriever before PPO (see docs/design/training.md).
_CPU = TrainConfig(
    preset="cpu",
    **_CPU_MACHINE,
    lr=3e-4,
    imitation=ImitationConfig(iterations=400, beta_iters=50, beta_min=0.3, buffer_iters=16, updates=16),
    batch_norm_frames=400,
)


TRAIN_PRESETS: dict[str, TrainConfig] = {
    # The paper (Sec. V / VI-B): RMSProp 5e-5, c1 0.5, c2 0.01, c3 1.0, gamma 0.995, 1,500 frames
    # per batch, promotion by hybrid 4x4 success.
    "paper": TrainConfig(promotion=PromotionConfig(rule="hybrid")),
    # A 2-core CPU machine: Adam, a DAgger warm start on the scripted retriever, then PPO.
    "cpu": _CPU,
    # PPO from a warm-started network (--init-weights occnet): small steps, no entropy bonus, a
    # value-head warm-up, a KL early stop, frozen batch-norm statistics, the paper's promotion.
    # Why each: docs/design/training.md, "PPO fine-tuning".
    "cpu-finetune": TrainConfig(
        preset="cpu-finetune",
        **_CPU_MACHINE,
        lr=1e-5,
        entropy_coeff=0.0,
        critic_warmup_iters=10,
        target_kl=0.02,
        batch_norm_frames=0,
        promotion=PromotionConfig(rule="hybrid"),
    ),
    # The curriculum continued by imitation from a warm-started network (--init-weights occnet
    # --start-stage 2; choose the teacher with --imitation-teacher), the teacher acting on 30 % of
    # the steps, the paper's promotion check every 25 iterations, one worker replaying the
    # previous stage. What each teacher achieved: docs/lab/training-teachers.md, "Training".
    "cpu-curriculum": replace(
        _CPU,
        preset="cpu-curriculum",
        lr=3e-5,
        imitation=replace(_CPU.imitation, iterations=100_000, beta_iters=0),
        batch_norm_frames=0,
        promotion=PromotionConfig(rule="hybrid", eval_every=25),
        replay_stage_workers=1,
    ),
    # A seconds-long configuration for tests and smoke runs (no imitation unless a run asks for
    # iterations of it: then 3 updates per iteration).
    "tiny": TrainConfig(
        preset="tiny",
        num_envs=4,
        steps_per_env=8,
        epochs=1,
        minibatch_envs=2,
        promotion=PromotionConfig(window=8),
        imitation=ImitationConfig(updates=3),
    ),
}


def get_train_config(preset: str = "paper", **overrides) -> TrainConfig:
    """The preset's :class:`TrainConfig` with ``overrides`` applied, by their flat names
    (:meth:`TrainConfig.flat_settings`: ``occrl train``'s options), or ``imitation=`` a whole
    :class:`ImitationConfig` (``ValueError`` for an unknown preset or setting).

    Examples:
        >>> from occrl.training import get_train_config
        >>> cfg = get_train_config("tiny", lr=1e-3, imitation_iters=5, imitation_teacher="hierarchical", teacher_action_noise=0.05)
        >>> cfg.preset, cfg.lr, cfg.frames_per_batch
        ('tiny', 0.001, 32)
        >>> cfg.imitation.iterations, cfg.imitation.updates, cfg.imitation.teacher
        (5, 3, HierarchicalTeacher(action_noise=0.05, label_episodes='all'))
        >>> get_train_config("tiny", imitation_iters=5, imitation_teacher="self").imitation.teacher  # its own defaults
        SelfTeacher(label_episodes='success')
    """
    if preset not in TRAIN_PRESETS:
        raise ValueError(f"unknown training preset {preset!r}; available: {sorted(TRAIN_PRESETS)}")
    if "imitation" in overrides:
        imitation = overrides.pop("imitation")
        return replace(get_train_config(preset, **overrides), imitation=imitation)
    settings = TRAIN_PRESETS[preset].flat_settings()
    if overrides.get("imitation_teacher", settings["imitation_teacher"]) != settings["imitation_teacher"]:
        # another teacher: the preset's teacher settings were its own teacher's; the new one starts from its defaults
        settings = {name: value for name, value in settings.items() if name not in TEACHER_SETTINGS}
    return TrainConfig.from_flat({**settings, **overrides})
