"""occrl.robot: the Robot protocol, run_on_robot, and MujocoRobot deciding exactly as the MuJoCo
env's tag path does. Real MuJoCo (an OpenGL backend), real OpenCV, the shipped network."""

import numpy as np
import pytest
import torch

pytest.importorskip("mujoco")
pytest.importorskip("dm_control")
pytest.importorskip("cv2")

from torchrl.envs.utils import check_env_specs, set_exploration_type  # noqa: E402

from occrl.envs.episodes import seeded_task_env, task_scenes  # noqa: E402
from occrl.envs.mujoco3d.camera import gl_available  # noqa: E402
from occrl.eval.methods import make_method  # noqa: E402
from occrl.robot import MujocoRobot, Robot, RobotEnv, robot_env, run_on_robot  # noqa: E402

pytestmark = pytest.mark.skipif(not gl_available()[0], reason=f"no OpenGL backend for MuJoCo: {gl_available()[1]}")

SEED = 10_000_003  # a held-out stage-2 task whose camera sees several tags from the start


def test_mujoco_robot_is_a_robot_and_its_env_has_the_simulated_specs():
    robot = MujocoRobot(task_scenes(2, [SEED], (1, 10))[0], seed=SEED)
    assert isinstance(robot, Robot)
    image = robot.camera_image()
    assert image.shape == (480, 640, 3) and image.dtype == np.uint8
    assert robot.gripper_transform()[:3, 3].tolist() == pytest.approx([*robot.gripper_pose()[:2], 0.045])
    assert robot.task_status() == "running" and not robot.gripper_closed()
    env = robot_env(robot, robot.detector(), robot.target_type, robot.target_vertices)
    check_env_specs(env.base_env)
    td = env.reset()
    assert td["pixels"].shape == (1, 3, 64, 64) and "privileged" not in td.keys()


def test_loop_decides_bit_for_bit_as_the_env_tag_path():
    """The hybrid planner on the robot loop and on make_env(world="mujoco", perception="tags") for
    the same seeded task: the same detections, network inputs and actions, bit for bit."""
    method = make_method("hybrid-2x2")
    scenes, steps = task_scenes(2, [SEED], (1, 10)), 4
    env = seeded_task_env(method.policy, scenes, [SEED], primers=method.primers, world="mujoco", perception="tags")
    with torch.no_grad(), set_exploration_type(method.exploration):
        expected = env.rollout(steps, method.policy, break_when_any_done=False, break_when_all_done=True)
    robot = MujocoRobot(scenes[0], seed=SEED)
    episode = run_on_robot(robot, method, robot.detector(), robot.target_type, robot.target_vertices, seed=SEED, max_steps=steps)
    got = episode.trajectory
    assert episode.steps == steps and episode.status == "running"
    assert np.array_equal(episode.actions, expected["action"][0].numpy())
    for key in ("objects", "gripper_pose", "gripper_opening", "pixels"):
        assert (got["next", key] == expected["next", key]).all(), key
    assert sum(len(d) for d in episode.detections) > steps  # tags were decoded along the way


class ScriptedRobot:
    """A robot of the protocol whose camera sees nothing (a blank frame): the loop must run, the
    planner searching without detections, and stop where the robot says."""

    def __init__(self, status_after: int, status: str = "retrieved") -> None:
        self.pose = np.array([0.0, -0.1, 0.0])
        self.executed: list[np.ndarray] = []
        self.status_after, self.status = status_after, status

    def camera_image(self):
        return np.full((480, 640, 3), 200, np.uint8)

    def gripper_pose(self):
        return self.pose.copy()

    def gripper_transform(self):
        t = np.eye(4)
        t[:3, 3] = (self.pose[0], self.pose[1], 0.045)
        return t

    def gripper_opening(self):
        return 0.085

    def gripper_closed(self):
        return False

    def execute(self, action):
        self.executed.append(np.asarray(action))
        self.pose[1] += 0.05 * float(action[0])

    def task_status(self):
        return self.status if len(self.executed) >= self.status_after else "running"


def test_loop_stops_when_the_robot_reports_the_task_over_and_at_the_step_limit():
    detector = MujocoRobot(task_scenes(1, [3])[0], seed=3).detector()  # any calibrated detector
    box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
    method = make_method("stochastic")
    robot = ScriptedRobot(status_after=3)
    episode = run_on_robot(robot, method, detector, 1, box, seed=0)
    assert episode.status == "retrieved" and episode.steps == 3 == len(robot.executed)
    assert episode.trajectory["next", "success"][0, -1].item() and all(d == [] for d in episode.detections)
    dropped = run_on_robot(ScriptedRobot(status_after=2, status="dropped"), method, detector, 1, box, seed=0)
    assert dropped.status == "dropped" and dropped.trajectory["next", "reward"][0, -1].item() == -51.0
    limited = run_on_robot(ScriptedRobot(status_after=100), method, detector, 1, box, seed=0, max_steps=5)
    assert limited.status == "running" and limited.steps == 5 and limited.trajectory["next", "truncated"][0, -1].item()


def test_bad_robots_and_arguments_are_refused():
    detector = MujocoRobot(task_scenes(1, [3])[0], seed=3).detector()
    box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
    with pytest.raises(TypeError, match="lacks"):
        RobotEnv(object(), detector, 1, box)
    with pytest.raises(TypeError, match="TagDetector"):
        RobotEnv(ScriptedRobot(1), "detector", 1, box)
    with pytest.raises(ValueError, match="seed must be"):
        run_on_robot(ScriptedRobot(1), make_method("stochastic"), detector, 1, box, seed=-1)
    with pytest.raises(ValueError, match="must return one of"):
        run_on_robot(ScriptedRobot(1, status="done"), make_method("stochastic"), detector, 1, box, seed=0)
    with pytest.raises(ValueError, match="target_type"):  # the task's type id is checked as the observation's
        run_on_robot(ScriptedRobot(1), make_method("stochastic"), detector, 0, box, seed=0)
