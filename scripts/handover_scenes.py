"""Scenes a search hands over (for scripts/search_split.py): tasks whose target is hidden at the
start, and the states a decision maker's search reaches at its first sight of the target.

- :func:`hidden_target_scenes`: tasks whose target perception does not report in the first
  observation, so that the episode begins with a search. On stage 2 the network's own policy
  solves about 77 % of the tasks whose target it sees at the start and about half of the others
  (docs/decisions.md).
- :func:`collect_handover_scenes`: the worlds a decision maker's search hands over, recorded at
  the first observation reporting the target (every object where it lies then, the gripper where
  it is), for practising the retrieval from there. An episode started there begins with a fresh
  recurrent state, not the search's. Only states an episode can start from are kept: the gripper
  open and empty (a scene starts so) and every object on the shelf, apart from the others and
  from the open gripper (the checks every :class:`~occrl.envs.Scene` passes); the rest are
  counted by reason.
"""

from __future__ import annotations

import logging
from typing import Sequence

import numpy as np
from torchrl.envs.utils import step_mdp
from tqdm import tqdm

from occrl.envs import world_constants as C
from occrl.envs.episodes import seeded_task_env, task_scenes
from occrl.envs.pipeline import make_env
from occrl.envs.scene import Scene, SceneObject
from occrl.planners import recreate

__all__ = ["hidden_target_scenes", "collect_handover_scenes", "scene_of_world", "drop_reason"]

logger = logging.getLogger(__name__)

OPEN_TOLERANCE = 1e-3  # m: fingers this close to the full stroke count as open


def hidden_target_scenes(stage: int, seeds: Sequence[int], batch: int = 64, progress: bool = False) -> list[Scene]:
    """The tasks of ``seeds`` (:func:`occrl.envs.episodes.task_scenes`) whose target perception
    does not report in the first observation, in seed order.

    Examples:
        >>> from occrl.envs.episodes import task_scenes
        >>> from occrl.training.start_scenes import hidden_target_scenes
        >>> hidden = hidden_target_scenes(2, range(20))
        >>> 0 < len(hidden) < 20, {s.seed for s in hidden} < {s.seed for s in task_scenes(2, range(20))}
        (True, True)
    """
    seeds = [int(s) for s in seeds]
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch must be an int >= 1, got {batch!r}")
    hidden: list[Scene] = []
    chunks = [seeds[i : i + batch] for i in range(0, len(seeds), batch)]
    for chunk in tqdm(chunks, desc="target-hidden scenes", unit="batch", disable=not progress):
        scenes = task_scenes(stage, chunk)
        env = make_env(batch_size=len(chunk), scenes=scenes, seed=chunk, heatmap_target=False)
        td = env.reset()
        hidden += [scene for b, scene in enumerate(scenes) if not recreate(td[b]).target_detected]
        env.close()
    return hidden


def scene_of_world(world, meta: dict | None = None) -> Scene:
    """The scene of a pymunk world's current state: its objects (types, shapes, target) at their
    present poses and the gripper at its present pose.

    Raises:
        ValueError: the state is not one a scene can start from: the gripper is closed, holds an
            object or is not fully open, or Scene's checks fail (an object off the shelf or
            overlapping another, the open gripper overlapping something); the message says which.

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.training.start_scenes import scene_of_world
        >>> scene = Scene.sample(stage=2, seed=3)
        >>> world = ShelfWorld(scene)
        >>> _ = world.step([1.0, 0.0, 0.0, -1.0])
        >>> moved = scene_of_world(world)
        >>> len(moved) == len(scene), moved.gripper_pose[1] > scene.gripper_pose[1]
        (True, True)
    """
    if world.closed or world.held is not None:
        raise ValueError("the gripper is closed or holds an object")
    if world.opening < C.GRIPPER_STROKE - OPEN_TOLERANCE:
        raise ValueError(f"the gripper is not fully open ({1000 * world.opening:.1f} mm of {1000 * C.GRIPPER_STROKE:.1f})")
    poses = world.object_poses()
    objects = tuple(
        SceneObject(o.type_id, o.vertices, tuple(float(v) for v in pose), o.is_target) for o, pose in zip(world.scene.objects, poses)
    )
    return Scene(objects=objects, gripper_pose=tuple(float(v) for v in world.gripper_pose()), meta=dict(meta or {}))


def drop_reason(message: str) -> str:
    """A short name for why :func:`scene_of_world` refused a state (its message)."""
    for key, reason in (
        ("closed or holds", "gripper closed or holding"),
        ("not fully open", "gripper not fully open"),
        ("open gripper", "open gripper overlaps something"),
        ("overlap", "objects overlap"),
        ("outside the shelf", "object off the shelf"),
    ):
        if key in message:
            return reason
    return message


def collect_handover_scenes(
    policy,
    stage: int,
    seeds: Sequence[int],
    primers: Sequence = (),
    size: int = 64,
    remembered_detections: bool = False,
    noise: float = 0.0,
    batch: int = 16,
    progress: bool = False,
) -> tuple[list[Scene], dict]:
    """Run ``policy`` on the tasks of ``seeds`` (``batch`` worlds at a time, seeded as
    :func:`occrl.envs.episodes.run_episodes` seeds them) and record each world at its first
    observation reporting the target (:func:`scene_of_world`; the scene's ``meta`` names the
    task seed and the step). Returns the scenes and counts: ``tasks``, ``handed_over`` (the
    target reported before the episode ended), ``kept``, per reason the hand-overs dropped
    (``dropped``), and per task seed the step of the first report (``first_sight``; None where
    the episode ended without one).

    Args:
        policy: a decision maker writing ``"action"`` (e.g. ``NetPolicy(net, stochastic=True)``).
        stage: the tasks' curriculum stage.
        seeds: task seeds (use seeds apart from the held-out ones, which start at 10,000,000).
        primers: the env transforms the policy needs (``net.make_primer()``).
        size: the network's image size.
        remembered_detections: the network's ``config.remembered_detections``.
        noise: execution noise.
        batch: worlds stepped together.
        progress: show a progress bar.
    """
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds must name at least one task")
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch must be an int >= 1, got {batch!r}")
    scenes: list[Scene] = []
    counts: dict = {"tasks": len(seeds), "handed_over": 0, "kept": 0, "dropped": {}, "first_sight": dict.fromkeys(seeds)}
    chunks = [seeds[i : i + batch] for i in range(0, len(seeds), batch)]
    for chunk in tqdm(chunks, desc="hand-over scenes", unit="batch", disable=not progress):
        env = seeded_task_env(
            policy, task_scenes(stage, chunk), chunk, noise=noise, primers=primers, size=size, remembered_detections=remembered_detections
        )
        if hasattr(policy, "reset"):
            policy.reset()
        worlds = env.base_env.worlds
        pending = np.ones(len(chunk), dtype=bool)
        td = env.reset()
        for step in range(C.MAX_EPISODE_STEPS):
            for b in np.flatnonzero(pending):
                if recreate(td[b]).target_detected:
                    pending[b] = False
                    counts["handed_over"] += 1
                    counts["first_sight"][chunk[b]] = step
                    try:
                        scenes.append(scene_of_world(worlds[b], meta={"task_seed": chunk[b], "stage": stage, "step": step}))
                        counts["kept"] += 1
                    except ValueError as err:
                        reason = drop_reason(str(err))
                        counts["dropped"][reason] = counts["dropped"].get(reason, 0) + 1
            if not pending.any():
                break
            td = env.step(policy(td))
            pending &= ~td.get(("next", "done")).reshape(-1).numpy()
            td = step_mdp(td)
        env.close()
    logger.info("hand-over scenes: %s", {k: v for k, v in counts.items() if k != "first_sight"})
    return scenes, counts
