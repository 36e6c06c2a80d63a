"""Small constructed scenes shared by the tests."""

from __future__ import annotations

import numpy as np

from occrl.envs import Scene


def square(half: float) -> list[list[float]]:
    return [[-half, -half], [half, -half], [half, half], [-half, half]]


def scene(objects: list[tuple[float, float, float, bool]], gripper=(0.0, -0.1, 0.0), half: float = 0.02) -> Scene:
    """Squares of half-size ``half`` at (x, y, theta), the flag marking the target."""
    return Scene.from_objects(
        [{"vertices": square(half), "pose": (x, y, th), "is_target": t} for x, y, th, t in objects], gripper_pose=gripper
    )


def world_to_crop_pixel(point, gripper_pose, window=0.8, size=64, forward_offset=0.15) -> tuple[int, int]:
    """(row, col) of the robot-centric pixel whose centre is nearest to a shelf-frame point."""
    from occrl.envs.robot_frame import robot_centric_points

    pts = robot_centric_points(np.asarray(gripper_pose, float), window, size, forward_offset)
    d = np.linalg.norm(pts - np.asarray(point, float), axis=-1)
    r, c = np.unravel_index(d.argmin(), d.shape)
    return int(r), int(c)


def checkpoint_as_written_before(run_dir, config, edit) -> None:
    """Train one iteration of ``config`` in ``run_dir``, then rewrite its checkpoint with
    ``edit(checkpoint_dict)`` applied: a checkpoint as an older occrl wrote it."""
    import torch

    from occrl.training import Trainer
    from occrl.training.run_folder import CHECKPOINT

    trainer = Trainer(config, run_dir, seed=0, progress=False, tensorboard=False)
    trainer.train(iterations=1)
    trainer.close()
    checkpoint = torch.load(run_dir / CHECKPOINT, weights_only=True)
    edit(checkpoint)
    torch.save(checkpoint, run_dir / CHECKPOINT)


def first_iteration_labels(config, run_dir):
    """Train one iteration of ``config`` (from ``occnet``) in ``run_dir`` and return, per frame of
    the batch it collected, whether the teacher acted, whether the frame's episode succeeded, and
    the imitation weight the DAgger aggregate stored. The iteration trains on the very batch
    collected first: each collection is seeded, but a teacher whose plans have wall-clock budgets
    (the hierarchical planner's OMPL queries) need not repeat its episodes on a loaded machine."""
    import torch

    from occrl.pretrained import weights_file
    from occrl.training import Trainer
    from occrl.training.stats import successful_episode_frames

    trainer = Trainer(config, run_dir, seed=0, progress=False, tensorboard=False, init_weights=weights_file("occnet"))
    data = trainer._collect()
    acted = data["teacher_acts"].reshape(data.shape).to(torch.float32)
    succeeded = successful_episode_frames(data).to(torch.float32)
    trainer._collect = lambda: data
    trainer.train(iterations=1)
    trainer.close()
    (batch,) = trainer.learner.dagger.batches
    return acted, succeeded, batch["expert_weight"].reshape(batch.shape)
