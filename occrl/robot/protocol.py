"""What occrl needs of a robot: a wrist-camera image, the gripper's state and pose, a planar action
executed, and whether the task is over.

Implement these seven methods on top of your arm's driver (a UR5 with a Robotiq 2F-85 and a wrist
camera in the papers) and :func:`~occrl.robot.loop.run_on_robot` runs any occrl planner or policy on
it. :class:`~occrl.robot.mujoco_robot.MujocoRobot` is one made of the MuJoCo shelf.

Frames are occrl's (:mod:`occrl.envs.world_constants`): the shelf frame has x across the shelf, y
into it and z up from the shelf floor; the gripper frame has its origin at the palm's front
centre, y along the approach direction, x to the gripper's right and z up.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Robot", "TASK_STATUSES"]

TASK_STATUSES = ("running", "retrieved", "dropped")  # what Robot.task_status may return


@runtime_checkable
class Robot(Protocol):
    """A robot occrl can drive (see :mod:`occrl.robot.protocol` for the frames).

    Examples:
        >>> from occrl.robot import Robot
        >>> class Stub:  # the methods a robot must have; a real one talks to its arm
        ...     def camera_image(self): ...
        ...     def gripper_pose(self): ...
        ...     def gripper_transform(self): ...
        ...     def gripper_opening(self): ...
        ...     def gripper_closed(self): ...
        ...     def execute(self, action): ...
        ...     def task_status(self): ...
        >>> isinstance(Stub(), Robot), isinstance(object(), Robot)
        (True, False)
    """

    def camera_image(self) -> np.ndarray:
        """The wrist camera's current frame: (H, W, 3) uint8 RGB at the calibrated camera's size."""

    def gripper_pose(self) -> np.ndarray:
        """The gripper's planar pose (x, y, theta) in the shelf frame: what the planner reads
        (theta 0 faces into the shelf, +y)."""

    def gripper_transform(self) -> np.ndarray:
        """The gripper frame's 4 x 4 pose in the shelf frame, the one the hand-camera transform
        was calibrated against (from the arm's forward kinematics)."""

    def gripper_opening(self) -> float:
        """The distance between the fingers (m), 0 to 0.085."""

    def gripper_closed(self) -> bool:
        """The last gripper command: True after a close, False after an open (and at the start)."""

    def execute(self, action: np.ndarray) -> None:
        """Carry out one action, 4 numbers in [-1, 1]: forward, lateral and rotation in the gripper
        frame (scaled to at most 5 cm, 5 cm and 15 degrees) and the gripper command (> 0 close,
        <= 0 open; a changed command closes or opens first, then the hand moves). Return when the
        motion has ended and the scene is still."""

    def task_status(self) -> str:
        """``"running"``, ``"retrieved"`` (the target is held and out of the shelf) or
        ``"dropped"`` (an object other than the held target left the shelf): the operator's or a
        sensor's judgement on a real robot."""
