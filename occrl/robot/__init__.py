"""Running occrl on a robot: the :class:`Robot` protocol, the decision loop :func:`run_on_robot`,
and :class:`MujocoRobot`, the MuJoCo shelf behind the same protocol.

:class:`MujocoRobot` needs the MuJoCo extra (``pip install -e ".[mujoco]"``) and is imported on use.
"""

from occrl.robot.loop import RobotEnv, RobotEpisode, robot_env, run_on_robot
from occrl.robot.protocol import TASK_STATUSES, Robot

__all__ = ["Robot", "TASK_STATUSES", "RobotEnv", "RobotEpisode", "robot_env", "run_on_robot", "MujocoRobot"]


def __getattr__(name: str):
    # MuJoCo is an optional extra: import the simulated robot only when it is asked for.
    if name == "MujocoRobot":
        from occrl.robot.mujoco_robot import MujocoRobot

        return MujocoRobot
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
