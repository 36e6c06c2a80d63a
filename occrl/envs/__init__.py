"""Shelf worlds, perception and TorchRL environments."""

from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, LEGACY_PHYSICS, PhysicsSettings
from occrl.envs.perception import detected_polygons, observation_from_detections
from occrl.envs.pipeline import make_env, observation_transforms
from occrl.envs.scene import STAGES, Scene, SceneObject
from occrl.envs.shelf_env import ShelfEnv
from occrl.envs.transforms import HeatmapTarget, OcclusionRender, RobotCentricCrop
from occrl.envs.task import StepOutcome
from occrl.envs.pymunk2d.world import ShelfWorld

__all__ = [
    "Scene",
    "SceneObject",
    "STAGES",
    "ShelfWorld",
    "StepOutcome",
    "PhysicsSettings",
    "DEFAULT_PHYSICS",
    "LEGACY_PHYSICS",
    "ShelfEnv",
    "OcclusionRender",
    "RobotCentricCrop",
    "HeatmapTarget",
    "make_env",
    "observation_transforms",
    "detected_polygons",
    "observation_from_detections",
    "MujocoShelfEnv",
]


def __getattr__(name: str):
    # MuJoCo is an optional extra: import its env only when it is asked for.
    if name == "MujocoShelfEnv":
        from occrl.envs.mujoco3d.env import MujocoShelfEnv

        return MujocoShelfEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
