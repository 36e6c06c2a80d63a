"""The named training presets (``occrl train --preset NAME``). Results always name the preset
they come from; :func:`get_train_config` applies a run's own settings on top of one."""

from __future__ import annotations

from dataclasses import replace

from occrl.training.config import TrainConfig

__all__ = ["TRAIN_PRESETS", "get_train_config"]


# What every CPU preset shares on this project's 2-core machines: Adam, two epochs per batch,
# two collector processes of 32 envs, the heat-map loss on a random quarter of the frames.
_CPU_MACHINE = dict(optimizer="adam", epochs=2, collector="multi", num_envs=32, heatmap_fraction=0.25)

# What trains on these machines: the paper's network and loss, Adam at a higher learning rate,
# and a DAgger warm start on the scripted retriever before PPO (see docs/decisions.md).
_CPU = TrainConfig(
    preset="cpu",
    **_CPU_MACHINE,
    lr=3e-4,
    imitation_iters=400,
    imitation_beta_iters=50,
    imitation_beta_min=0.3,
    imitation_buffer_iters=16,
    imitation_updates=16,
    batch_norm_frames=400,
)


TRAIN_PRESETS: dict[str, TrainConfig] = {
    # The paper (Sec. V / VI-B): RMSProp 5e-5, c1 0.5, c2 0.01, c3 1.0, gamma 0.995, 1,500 frames
    # per batch, promotion by hybrid 4x4 success.
    "paper": TrainConfig(promotion="hybrid"),
    # A 2-core CPU machine: Adam, a DAgger warm start on the scripted retriever, then PPO.
    "cpu": _CPU,
    # PPO from a warm-started network (--init-weights occnet): small steps, no entropy bonus, a
    # value-head warm-up, a KL early stop, frozen batch-norm statistics, the paper's promotion.
    # Why each: docs/decisions.md, "PPO fine-tuning".
    "cpu-finetune": TrainConfig(
        preset="cpu-finetune",
        **_CPU_MACHINE,
        lr=1e-5,
        entropy_coeff=0.0,
        critic_warmup_iters=10,
        target_kl=0.02,
        batch_norm_frames=0,
        promotion="hybrid",
    ),
    # The curriculum continued by imitation from a warm-started network (--init-weights occnet
    # --start-stage 2; choose the teacher with --imitation-teacher), the teacher acting on 30 % of
    # the steps, the paper's promotion check every 25 iterations, one worker replaying the
    # previous stage. What each teacher achieved: docs/experiments.md, "Training".
    "cpu-curriculum": replace(
        _CPU,
        preset="cpu-curriculum",
        lr=3e-5,
        imitation_iters=100_000,
        imitation_beta_iters=0,
        batch_norm_frames=0,
        promotion="hybrid",
        promotion_eval_every=25,
        replay_stage_workers=1,
    ),
    # A seconds-long configuration for tests and smoke runs.
    "tiny": TrainConfig(preset="tiny", num_envs=4, steps_per_env=8, epochs=1, minibatch_envs=2, promote_window=8, imitation_updates=3),
}


def get_train_config(preset: str = "paper", **overrides) -> TrainConfig:
    """The preset's :class:`TrainConfig` with ``overrides`` applied (``ValueError`` for an unknown preset).

    Examples:
        >>> from occrl.training import get_train_config
        >>> cfg = get_train_config("tiny", lr=1e-3)
        >>> cfg.preset, cfg.lr, cfg.frames_per_batch
        ('tiny', 0.001, 32)
    """
    if preset not in TRAIN_PRESETS:
        raise ValueError(f"unknown training preset {preset!r}; available: {sorted(TRAIN_PRESETS)}")
    return replace(TRAIN_PRESETS[preset], **overrides)
