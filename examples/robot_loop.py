"""Run an occrl planner on a robot: camera frame -> tag detections -> plan -> action.

Here the robot is the MuJoCo shelf behind occrl's Robot protocol (``MujocoRobot``); on a real arm
you implement the protocol's seven methods instead (docs/running_on_your_robot.md) and load your
lab's camera calibration and tag catalogue, exactly as done below with the simulated ones.

    python examples/robot_loop.py                      # 3 actions of hybrid-4x4 on one task
    python examples/robot_loop.py --steps 50 --seed 10000007

Needs the MuJoCo and camera extras (pip install -e ".[mujoco,camera]") and an OpenGL backend
(MUJOCO_GL=egl on a headless machine).
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

from occrl.envs.episodes import task_scenes
from occrl.eval.methods import make_method
from occrl.perception import TagCatalogue, TagDetector, load_camera, save_camera
from occrl.robot import MujocoRobot, run_on_robot


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=10_000_003, help="task seed (a held-out stage-2 shelf with 1-10 objects)")
    parser.add_argument("--steps", type=int, default=3, help="actions at most (50 for a whole task)")
    parser.add_argument("--method", default="hybrid-4x4", help="any occrl method, e.g. hybrid-2x2, stochastic")
    args = parser.parse_args(argv)

    robot = MujocoRobot(task_scenes(2, [args.seed], (1, 10))[0], seed=args.seed)
    # a lab writes these two files once (calibration, tag catalogue); here the simulated robot's
    with tempfile.TemporaryDirectory() as folder:
        save_camera(robot.observer.calibration, Path(folder) / "camera.json")
        robot.observer.catalogue.to_json(Path(folder) / "catalogue.json")
        camera = load_camera(Path(folder) / "camera.json")
        catalogue = TagCatalogue.from_json(Path(folder) / "catalogue.json")
    detector = TagDetector(camera, catalogue)
    print(
        f"camera {camera.width} x {camera.height}, {camera.horizontal_fov_deg:.0f} degrees across; {len(catalogue)} tags on {len(catalogue.type_ids)} types"
    )

    method = make_method(args.method)
    episode = run_on_robot(robot, method, detector, robot.target_type, robot.target_vertices, seed=args.seed, max_steps=args.steps)
    for k, (seen, action) in enumerate(zip(episode.detections, episode.actions)):
        types = ", ".join(
            f"{d['type_id']} at ({d['pose'][0]:+.3f}, {d['pose'][1]:+.3f}, {math.degrees(d['pose'][2]):+.0f} deg)" for d in seen
        )
        print(f"step {k + 1}: sees {types or 'no tag'}")
        print(
            f"        action forward {action[0]:+.2f}, lateral {action[1]:+.2f}, rotation {action[2]:+.2f}, gripper {'close' if action[3] > 0 else 'open'}"
        )
    print(f"status after {episode.steps} actions: {episode.status} ({episode.seconds:.1f} s)")
    robot.close()


if __name__ == "__main__":
    main()
