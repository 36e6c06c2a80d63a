"""Shelf worlds, perception and TorchRL environments."""

from occrl.envs.scene import STAGES, Scene, SceneObject
from occrl.envs.world import ShelfWorld, StepOutcome

__all__ = ["Scene", "SceneObject", "STAGES", "ShelfWorld", "StepOutcome"]
