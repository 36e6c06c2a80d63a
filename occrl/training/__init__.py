"""Training: configs (presets), curriculum, imitation teachers, checkpoints, the trainer, and the
demonstrations and offline fit of the shipped networks' recipe."""

from occrl.modules.weights import CheckpointError, load_weights, save_weights
from occrl.training.checkpoint import load_checkpoint, save_checkpoint
from occrl.training.config import ImitationConfig, PromotionConfig, TrainConfig
from occrl.training.presets import TRAIN_PRESETS, get_train_config
from occrl.training.curriculum import Curriculum
from occrl.training.stats import episode_stats
from occrl.training.teachers import TEACHERS, Teacher
from occrl.training.trainer import Trainer
from occrl.training.demonstrations import collect_demonstrations
from occrl.training.offline_fit import FitConfig, fit_offline

__all__ = [
    "TrainConfig",
    "ImitationConfig",
    "PromotionConfig",
    "Teacher",
    "TEACHERS",
    "TRAIN_PRESETS",
    "get_train_config",
    "Curriculum",
    "Trainer",
    "collect_demonstrations",
    "FitConfig",
    "fit_offline",
    "episode_stats",
    "CheckpointError",
    "save_checkpoint",
    "load_checkpoint",
    "save_weights",
    "load_weights",
]
