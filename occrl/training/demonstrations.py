"""Demonstrations collected once, for the offline fit (``occrl demos``).

A teacher acts in every step of every episode (with its action noise: disturbed demonstrations)
and its episodes are kept as labelled sequences, in the run folder's data set that
:func:`~occrl.training.offline_fit.fit_offline` reads. It is a training run of the
``cpu-curriculum`` preset whose network does not learn (learning rate 0; the teacher acts, so the
network only fixes the run's network configuration), so the data set, its checkpoint and its
resume are the trainer's own: :func:`demonstration_config` names the settings.
"""

from __future__ import annotations

import logging
from pathlib import Path

from occrl.pretrained import pretrained_path
from occrl.training.config import TrainConfig
from occrl.training.plots import read_metrics
from occrl.training.presets import get_train_config
from occrl.training.run_folder import METRICS
from occrl.training.trainer import Trainer

__all__ = ["collect_demonstrations", "demonstration_config", "DEMONSTRATION_PRESET", "DEMONSTRATION_SETTINGS"]

logger = logging.getLogger(__name__)

DEMONSTRATION_PRESET = "cpu-curriculum"
# what makes a training run of DEMONSTRATION_PRESET a demonstration collector: the teacher acts in
# every step, the network does not learn, every iteration's sequences are kept, no promotion check
DEMONSTRATION_SETTINGS = {
    "imitation_beta_min": 1.0,
    "critic_coeff": 0.0,
    "heatmap_coeff": 0.0,
    "collector": "single",
    "replay_stage_workers": 0,
    "promotion_eval_every": 1000,
    "imitation_updates": 1,
    "lr": 0.0,
}
SEARCHING_TEACHER = "clearing-observed"  # the teacher with a search setting (teacher_search; default here: hierarchical)
MIN_BUFFER_ITERS = 1000  # the data set keeps this many iterations at least (more for a longer run)


def demonstration_config(
    teacher: str = "clearing-observed",
    teacher_search: str | None = None,
    action_noise: float = 0.05,
    label_episodes: str = "success",
    num_envs: int = 16,
    stage: int = 2,
    iterations: int = 150,
    **overrides,
) -> TrainConfig:
    """The training settings of a demonstration run: :data:`DEMONSTRATION_PRESET` with
    :data:`DEMONSTRATION_SETTINGS`, the teacher's (``teacher_search`` None: "hierarchical" for the
    clearing-observed teacher, unset for the others), and ``overrides`` (flat names, as
    :func:`~occrl.training.get_train_config` takes them, e.g. ``steps_per_env``).

    Examples:
        >>> from occrl.training.demonstrations import demonstration_config
        >>> cfg = demonstration_config(iterations=40)
        >>> cfg.lr, cfg.start_stage, cfg.num_envs, cfg.imitation.beta_min, cfg.imitation.teacher.name
        (0.0, 2, 16, 1.0, 'clearing-observed')
    """
    teacher_settings = {"imitation_teacher": teacher, "label_episodes": label_episodes, "teacher_action_noise": action_noise}
    if teacher_search is None and teacher == SEARCHING_TEACHER:
        teacher_search = "hierarchical"
    if teacher_search is not None:
        teacher_settings["teacher_search"] = teacher_search
    settings = {
        **DEMONSTRATION_SETTINGS,
        **teacher_settings,
        "num_envs": num_envs,
        "start_stage": stage,
        "imitation_buffer_iters": max(MIN_BUFFER_ITERS, iterations),
        **overrides,
    }
    return get_train_config(DEMONSTRATION_PRESET, **settings)


def collect_demonstrations(
    out: str | Path,
    iterations: int,
    seed: int = 0,
    init_weights: str | Path = "occnet-takeover",
    progress: bool = True,
    **settings,
) -> dict:
    """Collect ``iterations`` iterations of demonstrations (each ``num_envs x steps_per_env``
    frames) into the run folder ``out``; the same call again resumes a stopped collection. Returns
    the run's last metrics row (frames, cpu_hours, success_rate: the teacher's, ...).

    ``settings`` go to :func:`demonstration_config` (teacher, teacher_search, action_noise,
    label_episodes, num_envs, stage, or any training setting by its flat name). The data set is
    the one ``occrl train`` writes with the same settings and ``--lr 0``, bit for bit.
    ``init_weights``: a shipped network's name or a weights file (the network the run holds; it
    does not act where the teacher acts in every step).
    """
    if iterations < 1:
        raise ValueError(f"iterations must be >= 1, got {iterations}")
    config = demonstration_config(iterations=iterations, **settings)
    weights = Path(init_weights) if Path(init_weights).exists() else pretrained_path(str(init_weights))
    trainer = Trainer(config, out, seed=seed, progress=progress, tensorboard=False, init_weights=weights)
    try:
        trainer.train(iterations=iterations)
    finally:
        trainer.close()
    last = read_metrics(Path(out) / METRICS)[-1]  # also when the run had finished before this call
    logger.info("%s: %d iterations, %d frames of demonstrations", out, last["iteration"], last["frames"])
    return last
