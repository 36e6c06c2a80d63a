"""Run an occrl planner or policy on a robot: camera frame -> tag detections -> observation ->
decision -> action, until the task is over or the step limit.

The robot is wrapped as a TorchRL environment (:class:`RobotEnv`) behind the same transforms the
simulated envs use (:func:`occrl.envs.make_env`: episode-start flag, step counter, optional
remembered detections, the occlusion-aware render and the robot-centric crop), so a decision maker
sees on the robot exactly what it sees in simulation, and is seeded the same way as an evaluated
task (:func:`occrl.envs.episodes.seeded_task_env`).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import Compose, EnvBase, InitTracker, StepCounter, TransformedEnv
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.envs import world_constants as C
from occrl.envs.detection_slots import DetectionSlots
from occrl.envs.pipeline import observation_transforms
from occrl.envs.robot_frame import DEFAULT_SIZE
from occrl.envs.scene import validate_vertices
from occrl.envs.shelf_env import ShelfEnv
from occrl.perception import TagDetector
from occrl.robot.protocol import TASK_STATUSES, Robot

__all__ = ["RobotEnv", "RobotEpisode", "run_on_robot", "robot_env"]

logger = logging.getLogger(__name__)


class RobotEnv(EnvBase):
    """One robot as a TorchRL environment with the observation keys and specs of
    :class:`~occrl.envs.ShelfEnv` (no ``"privileged"`` entries: a robot has no ground truth).

    Each observation reads the robot's camera frame, decodes it with ``detector`` and puts each
    detected type in its episode's slot (:class:`~occrl.envs.detection_slots.DetectionSlots`).
    A step executes the action on the robot; the episode ends when the robot reports the task
    retrieved or dropped (``terminated``) or after ``max_steps`` actions (``truncated``).
    Reward: -1 per action and -50 more when the robot reports a drop (the simulated envs' rewards).

    Args:
        robot: a :class:`~occrl.robot.protocol.Robot`.
        detector: the calibrated tag detector (:class:`occrl.perception.TagDetector`).
        target_type: the target's type id (the task).
        target_vertices: the target's footprint polygon about its pose (a task prior).
        max_steps: the step limit (50, as in the papers).
    """

    batch_locked = True

    def __init__(
        self, robot: Robot, detector: TagDetector, target_type: int, target_vertices, max_steps: int = C.MAX_EPISODE_STEPS
    ) -> None:
        if not isinstance(robot, Robot):
            missing = [
                m
                for m in (
                    "camera_image",
                    "gripper_pose",
                    "gripper_transform",
                    "gripper_opening",
                    "gripper_closed",
                    "execute",
                    "task_status",
                )
                if not hasattr(robot, m)
            ]
            raise TypeError(f"robot must offer the occrl.robot.Robot methods; {type(robot).__name__} lacks {missing}")
        if not isinstance(detector, TagDetector):
            raise TypeError(f"detector must be an occrl.perception.TagDetector, got {type(detector).__name__}")
        if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
            raise ValueError(f"max_steps must be an int >= 1, got {max_steps!r}")
        super().__init__(batch_size=torch.Size([1]))
        self.robot = robot
        self.detector = detector
        self.target_type = target_type
        self.target_vertices = validate_vertices("target_vertices", target_vertices)
        self.max_steps = max_steps
        self.slots = DetectionSlots()
        self.steps = 0
        self.detections: list[list[dict]] = []  # every frame's detections, the reset's first
        simulated = ShelfEnv(batch_size=1)  # the simulated envs' specs (no world is built)
        spec = simulated.observation_spec.clone()
        del spec["privileged"]
        self.observation_spec = spec
        self.action_spec = simulated.action_spec.clone()
        self.reward_spec = simulated.reward_spec.clone()
        self.done_spec = simulated.done_spec.clone()

    def _set_seed(self, seed: int | None) -> None:
        """Nothing to seed: the robot is the world."""

    def status(self) -> str:
        """The robot's task status, checked."""
        status = self.robot.task_status()
        if status not in TASK_STATUSES:
            raise ValueError(f"robot.task_status() must return one of {TASK_STATUSES}, got {status!r}")
        return status

    def _observe(self) -> TensorDict:
        image = self.robot.camera_image()
        detections = self.detector.detect(image, self.robot.gripper_transform())
        td = self.slots.observation(
            self.robot.gripper_pose(),
            self.robot.gripper_opening(),
            detections,
            self.target_type,
            self.target_vertices,
            self.robot.gripper_closed(),
        )
        self.detections.append(detections)
        return td

    def _flags(self, td: TensorDict, terminated: bool, truncated: bool) -> TensorDict:
        flag = lambda v: torch.tensor([[bool(v)]])  # noqa: E731
        td.update({"terminated": flag(terminated), "truncated": flag(truncated), "done": flag(terminated or truncated)})
        return td

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        self.slots.reset()
        self.steps = 0
        self.detections = []
        return self._flags(self._observe(), False, False)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get("action").detach().cpu().numpy().astype(np.float64).reshape(-1)
        if action.shape != (C.ACTION_DIM,) or not np.isfinite(action).all():
            raise ValueError(f"an action is {C.ACTION_DIM} finite numbers, got {action.tolist()}; nothing was executed")
        self.robot.execute(np.clip(action, -1.0, 1.0))
        self.steps += 1
        status = self.status()
        td = self._observe()
        td.set("success", torch.tensor([[status == "retrieved"]]))
        td.set("dropped", torch.tensor([[status == "dropped"]]))
        terminated = status != "running"
        reward = C.STEP_REWARD + (C.DROP_PENALTY if status == "dropped" else 0.0)
        td.set("reward", torch.tensor([[reward]], dtype=torch.float32))
        return self._flags(td, terminated, not terminated and self.steps >= self.max_steps)


def robot_env(
    robot: Robot,
    detector: TagDetector,
    target_type: int,
    target_vertices,
    primers: Sequence = (),
    size: int = DEFAULT_SIZE,
    remembered_detections: bool = False,
    max_steps: int = C.MAX_EPISODE_STEPS,
) -> TransformedEnv:
    """:class:`RobotEnv` behind the transforms :func:`occrl.envs.make_env` applies (without the
    heat-map label, which needs ground truth), and a decision maker's ``primers``."""
    transforms = [
        InitTracker(),
        StepCounter(),
        *observation_transforms(size=size, heatmap_target=False, remembered_detections=remembered_detections),
    ]
    env = TransformedEnv(RobotEnv(robot, detector, target_type, target_vertices, max_steps), Compose(*transforms))
    for p in primers:
        env.append_transform(p.clone() if hasattr(p, "clone") else p)
    return env


@dataclass
class RobotEpisode:
    """What :func:`run_on_robot` did: the actions (T, 4), each frame's detections (T + 1, the
    first before any action), the robot's final status, the seconds it took, and the trajectory
    (TorchRL's rollout: observations, actions, and the decision maker's outputs)."""

    actions: np.ndarray
    detections: list[list[dict]]
    status: str
    seconds: float
    trajectory: TensorDictBase = field(repr=False)

    @property
    def steps(self) -> int:
        return len(self.actions)


def run_on_robot(
    robot: Robot,
    decision_maker: Any,
    detector: TagDetector,
    target_type: int,
    target_vertices,
    seed: int = 0,
    max_steps: int = C.MAX_EPISODE_STEPS,
    primers: Sequence = (),
    exploration: ExplorationType | None = None,
    size: int | None = None,
    remembered_detections: bool | None = None,
    on_env: Callable[[TransformedEnv], None] | None = None,
) -> RobotEpisode:
    """Run one task on a robot with an occrl planner or policy.

    Args:
        robot: the :class:`~occrl.robot.protocol.Robot` (gripper outside the shelf, open).
        decision_maker: a policy or planner (a TensorDict module writing ``"action"``, e.g.
            :class:`occrl.planners.HybridPlanner`), or a method of :func:`occrl.eval.methods.make_method`
            (its policy, primers, exploration type, image size and remembered detections are used,
            unless given here).
        detector: the tag detector with the lab's camera calibration and tag catalogue.
        target_type, target_vertices: the task: the target's type id and footprint.
        seed: seeds the decision maker's randomness as an evaluated task's seed does
            (``torch.manual_seed`` and the planner's ``reseed``).
        max_steps: actions before the task is given up.
        primers, exploration, size, remembered_detections: the decision maker's env needs, as in
            :func:`occrl.envs.episodes.run_episodes` (defaults: none, random sampling, 64 pixels, off).
        on_env: called with the env before the first frame is taken (e.g. to log).

    Returns:
        A :class:`RobotEpisode`.
    """
    policy = getattr(decision_maker, "policy", decision_maker)
    if primers == () and hasattr(decision_maker, "primers"):
        primers = decision_maker.primers
    exploration = exploration if exploration is not None else getattr(decision_maker, "exploration", ExplorationType.RANDOM)
    size = size if size is not None else getattr(decision_maker, "image_size", DEFAULT_SIZE)
    if remembered_detections is None:
        remembered_detections = bool(getattr(decision_maker, "remembered_detections", False))
    if not callable(policy):
        raise TypeError(
            f"decision_maker must be a policy (a callable TensorDict module) or an occrl method, got {type(decision_maker).__name__}"
        )
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an int >= 0, got {seed!r}")
    env = robot_env(robot, detector, target_type, target_vertices, primers, size, remembered_detections, max_steps)
    if on_env is not None:
        on_env(env)
    torch.manual_seed(int(seed))
    if hasattr(policy, "reseed_worlds"):
        policy.reseed_worlds([int(seed)])
    elif hasattr(policy, "reseed"):
        policy.reseed(int(seed))
    start = time.time()
    with torch.no_grad(), set_exploration_type(exploration):
        td = env.rollout(max_steps, policy, break_when_any_done=False, break_when_all_done=True)
    seconds = time.time() - start
    base = env.base_env
    status = base.status()
    logger.info("robot task ended after %d actions (%s) in %.1f s", base.steps, status, seconds)
    actions = td.get("action")[0].detach().cpu().numpy()[: base.steps]
    return RobotEpisode(actions, list(base.detections), status, seconds, td)
