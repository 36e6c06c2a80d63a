"""Seeded tasks and the episodes of a decision maker on them (what evaluation and the training's
promotion checks run).

Tasks are scenes built from *task seeds*: task seed ``s`` is ``Scene.sample(stage, seed=s)`` and
its execution noise is seeded by ``s`` too, so every method sees the same shelves.
:func:`run_episodes` runs any policy (a TensorDict module writing ``"action"``) on them and
scores each episode (:class:`EpisodeResult`).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Callable, Sequence

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.envs import world_constants as C
from occrl.envs.pipeline import make_env
from occrl.envs.robot_frame import DEFAULT_SIZE
from occrl.envs.scene import Scene

__all__ = [
    "EpisodeResult",
    "task_scenes",
    "task_object_count",
    "check_replicate",
    "check_perception",
    "check_world_settings",
    "decision_seed",
    "seeded_task_env",
    "episode_end",
    "run_episodes",
    "TIME_LIMIT_S",
    "EPISODE_TIMING",
]

# What a result's times are (the "timing" key of results and sweep points): since occrl 0.3.0 each
# task's own episode, planning and execution, as run_episodes measures it.
EPISODE_TIMING = "episode"

TIME_LIMIT_S = 120.0  # a task's time limit (the papers' 2 minutes)


@dataclass
class EpisodeResult:
    """The outcome of one task: its seed and object count, success, a drop, actions and seconds,
    and the physics' health over the episode: the deepest penetration (m) after any action and
    whether a physically invalid state was reached (NaN / False where the world does not measure,
    and in results written before occrl measured it).

    Examples:
        >>> from occrl.envs.episodes import EpisodeResult
        >>> EpisodeResult(seed=3, objects=4, success=True, dropped=False, actions=21, seconds=0.4).to_dict()["actions"]
        21
    """

    seed: int
    objects: int
    success: bool
    dropped: bool
    actions: int
    seconds: float
    max_penetration: float = math.nan
    physics_invalid: bool = False

    def to_dict(self) -> dict:
        return asdict(self)


def task_object_count(seed: int, low: int, high: int) -> int:
    """The object count of task ``seed`` when tasks draw it uniformly from ``low..high``.

    Examples:
        >>> from occrl.envs.episodes import task_object_count
        >>> [task_object_count(s, 1, 10) for s in range(5)] == [task_object_count(s, 1, 10) for s in range(5)]
        True
        >>> all(1 <= task_object_count(s, 1, 10) <= 10 for s in range(100))
        True
    """
    return int(np.random.default_rng([int(seed), 7]).integers(low, high + 1))


def task_scenes(stage: int, seeds: Sequence[int], num_objects: int | tuple[int, int] | None = None) -> list[Scene]:
    """The scenes of task seeds: the stage's object counts, a fixed count, or (low, high) for a
    count drawn per task from its seed (the papers' "random number of objects, up to 10").

    Examples:
        >>> from occrl.envs.episodes import task_scenes
        >>> [len(s) for s in task_scenes(2, [0, 1, 2], num_objects=3)]
        [3, 3, 3]
        >>> a, b = task_scenes(1, [7])[0], task_scenes(1, [7])[0]  # a task seed names one shelf
        >>> all((x.pose == y.pose) for x, y in zip(a.objects, b.objects))
        True
    """
    if isinstance(num_objects, (tuple, list)):
        low, high = (int(v) for v in num_objects)
        if not 1 <= low <= high:
            raise ValueError(f"an object-count range needs 1 <= low <= high, got {num_objects}")
        return [Scene.sample(stage, seed=int(s), num_objects=task_object_count(s, low, high)) for s in seeds]
    return [Scene.sample(stage, seed=int(s), num_objects=num_objects) for s in seeds]


def check_replicate(replicate: int) -> None:
    """``ValueError`` unless ``replicate`` is an integer >= 0 (see :func:`decision_seed`).

    Examples:
        >>> from occrl.envs.episodes import check_replicate
        >>> check_replicate(2)
        >>> check_replicate(1.5)
        Traceback (most recent call last):
            ...
        ValueError: replicate must be an integer >= 0, got 1.5
    """
    if isinstance(replicate, bool) or not isinstance(replicate, (int, np.integer)) or replicate < 0:
        raise ValueError(f"replicate must be an integer >= 0, got {replicate!r}")


def check_perception(perception: str, world: str) -> None:
    """``ValueError`` unless ``perception`` is one the ``world`` offers: ``"geometric"`` everywhere,
    ``"tags"`` (the tag detector on the wrist camera's image) in ``"mujoco"``.

    Examples:
        >>> from occrl.envs.episodes import check_perception
        >>> check_perception("tags", "mujoco")
        >>> check_perception("tags", "pymunk")
        Traceback (most recent call last):
            ...
        ValueError: perception='tags' needs world='mujoco' (the 2D world has no camera image); the pymunk world offers 'geometric'
    """
    modes = ("geometric", "tags")  # MujocoShelfEnv.PERCEPTION_MODES (not imported: MuJoCo is optional)
    if perception not in modes:
        raise ValueError(f"perception must be one of {modes}, got {perception!r}")
    if perception != "geometric" and world != "mujoco":
        raise ValueError(
            f"perception={perception!r} needs world='mujoco' (the 2D world has no camera image); the {world} world offers 'geometric'"
        )


def check_world_settings(world: str, perception: str = "geometric", shelf_height: float | None = None, tag_layout=None) -> None:
    """``ValueError`` unless the settings fit together and each is one allowed: ``perception`` as
    :func:`check_perception`; ``shelf_height`` (None: the env's) only in the ``"mujoco"`` world and
    within :data:`~occrl.envs.mujoco3d.model.SHELF_HEIGHT_RANGE`; ``tag_layout`` (None: the env's)
    only with ``perception="tags"`` and one :func:`~occrl.envs.mujoco3d.tags.as_tag_layout` takes.

    Examples:
        >>> from occrl.envs.episodes import check_world_settings
        >>> check_world_settings("mujoco", "tags", shelf_height=0.4, tag_layout="at-most-3cm")
        >>> check_world_settings("mujoco", shelf_height=0.4, tag_layout="at-most-3cm")
        Traceback (most recent call last):
            ...
        ValueError: tag_layout sizes the tags the detector reads: it needs perception='tags', got perception='geometric'
    """
    check_perception(perception, world)
    if shelf_height is not None:
        if world != "mujoco":
            raise ValueError(f"shelf_height needs world='mujoco' (the 2D world has no height), got world={world!r}")
        from occrl.envs.mujoco3d.model import check_shelf_height  # MuJoCo is optional: imported when a height is given

        check_shelf_height(shelf_height)
    if tag_layout is not None:
        if perception != "tags":
            raise ValueError(f"tag_layout sizes the tags the detector reads: it needs perception='tags', got perception={perception!r}")
        from occrl.envs.mujoco3d.tags import as_tag_layout

        as_tag_layout(tag_layout)


def decision_seed(task_seed: int, replicate: int = 0) -> int:
    """The seed of the decision maker's randomness in replicate ``replicate`` of a task: the task
    seed itself for replicate 0 (every recorded result), a seed drawn from (task seed, replicate)
    for the others. Replicates run the same shelf with the same execution noise; only the
    decision maker's own draws (a stochastic policy's actions, a planner's roll-outs) differ.

    Examples:
        >>> from occrl.envs.episodes import decision_seed
        >>> decision_seed(10_000_000), decision_seed(10_000_000, 1) == decision_seed(10_000_000, 1)
        (10000000, True)
        >>> len({decision_seed(7, r) for r in range(4)})
        4
        >>> decision_seed(7, -1)
        Traceback (most recent call last):
            ...
        ValueError: replicate must be an integer >= 0, got -1
    """
    check_replicate(replicate)
    if replicate == 0:
        return int(task_seed)
    return int(np.random.SeedSequence([int(task_seed), int(replicate)]).generate_state(1)[0])


def seeded_task_env(
    policy: Callable,
    scenes: Sequence[Scene],
    seeds: Sequence[int],
    noise: float = 0.0,
    primers: Sequence = (),
    heatmap_target: bool = False,
    world: str = "pymunk",
    size: int = DEFAULT_SIZE,
    replicate: int = 0,
    remembered_detections: bool = False,
    perception: str = "geometric",
    shelf_height: float | None = None,
    tag_layout: str | None = None,
):
    """The env of a batch of tasks, with the env and the decision maker seeded by the task seeds:
    what :func:`run_episodes` runs, and what a replay of one of its episodes must build.

    Each world's execution noise follows its own task seed; the decision maker's randomness too
    where it can (``reseed_worlds``, e.g. :class:`~occrl.baselines.NetPolicy`), else the batch's
    first seed (``reseed``, e.g. the planners, run one task per batch). Either way results do not
    depend on how tasks are spread over processes. ``replicate`` > 0 seeds the decision maker by
    :func:`decision_seed` instead (the env keeps the task seeds). ``perception="tags"`` makes the
    MuJoCo env report what its tag detector decodes (:class:`~occrl.envs.MujocoShelfEnv`);
    ``shelf_height`` (MuJoCo only; None: the env's 0.30 m) sets its shelf's inside height, and
    ``tag_layout`` (with ``perception="tags"``; None: the env's default) its tags.

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs.episodes import seeded_task_env, task_scenes
        >>> env = seeded_task_env(ScriptedRetriever(), task_scenes(1, [3, 4]), [3, 4])
        >>> env.batch_size
        torch.Size([2])
    """
    decision_seeds = [decision_seed(s, replicate) for s in seeds]  # a bad replicate fails before any env is built
    check_world_settings(world, perception, shelf_height, tag_layout)
    env = make_env(
        batch_size=len(scenes),
        scenes=list(scenes),
        noise=noise,
        seed=[int(s) for s in seeds],
        heatmap_target=heatmap_target,
        world=world,
        size=size,
        remembered_detections=remembered_detections,
        **({"perception": perception} if perception != "geometric" else {}),
        **({"shelf_height": shelf_height} if shelf_height is not None else {}),
        **({"tag_layout": tag_layout} if tag_layout is not None else {}),
    )
    for p in primers:
        env.append_transform(p.clone() if hasattr(p, "clone") else p)
    torch.manual_seed(decision_seeds[0])
    if hasattr(policy, "reseed_worlds"):
        policy.reseed_worlds(decision_seeds)
    elif hasattr(policy, "reseed"):
        policy.reseed(decision_seeds[0])
    return env


def episode_end(done: np.ndarray) -> int:
    """Index of the step that ended the episode in one world's ``done`` flags (the last step
    when it did not end).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.episodes import episode_end
        >>> episode_end(np.array([False, False, True, False])), episode_end(np.zeros(5, dtype=bool))
        (2, 4)
    """
    ends = np.flatnonzero(done)
    return int(ends[0]) if len(ends) else len(done) - 1


def run_episodes(
    policy: Callable,
    scenes: Sequence[Scene],
    seeds: Sequence[int],
    noise: float = 0.0,
    batch_size: int = 16,
    primers: Sequence = (),
    exploration: ExplorationType = ExplorationType.RANDOM,
    heatmap_target: bool = False,
    world: str = "pymunk",
    size: int = DEFAULT_SIZE,
    replicate: int = 0,
    remembered_detections: bool = False,
    on_env: Callable[[EnvBase], None] | None = None,
    on_rollout: Callable[[TensorDictBase], None] | None = None,
    perception: str = "geometric",
    shelf_height: float | None = None,
    tag_layout: str | None = None,
) -> list[EpisodeResult]:
    """Run ``policy`` once on each scene (batches of ``batch_size`` worlds stepped together);
    ``replicate`` > 0 draws the decision maker's randomness anew (:func:`decision_seed`);
    ``remembered_detections`` and ``size`` make the env a network needs (``make_env``);
    ``perception``, ``shelf_height`` and ``tag_layout`` are the MuJoCo env's (:func:`seeded_task_env`).
    Diagnoses look inside through two hooks: ``on_env`` gets each batch's env before its
    roll-out (e.g. to hand a policy the worlds' true state: ``env.base_env.worlds``),
    ``on_rollout`` each batch's trajectory (batch, time) after it.

    Success requires retrieval in under 50 actions and under 2 minutes, with nothing dropped.
    The batch stops when each of its worlds has ended its episode (a world that ended is not
    stepped again, and the policy is not asked again for a batch of one); per-task time is the
    batch's wall time, planning and execution, divided among its tasks.

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import Scene
        >>> from occrl.envs.episodes import run_episodes
        >>> [r] = run_episodes(ScriptedRetriever(), [Scene.sample(1, seed=0, num_objects=1)], seeds=[0])
        >>> r.success, r.dropped, r.actions < 50
        (True, False, True)
    """
    results: list[EpisodeResult] = []
    for start in range(0, len(scenes), batch_size):
        chunk = list(scenes[start : start + batch_size])
        chunk_seeds = list(seeds[start : start + batch_size])
        env = seeded_task_env(
            policy,
            chunk,
            chunk_seeds,
            noise,
            primers,
            heatmap_target,
            world,
            size,
            replicate,
            remembered_detections,
            perception,
            shelf_height,
            tag_layout,
        )
        if on_env is not None:
            on_env(env)
        t = time.time()
        with torch.no_grad(), set_exploration_type(exploration):
            td = env.rollout(C.MAX_EPISODE_STEPS, policy, break_when_any_done=False, break_when_all_done=True)
        per_task = (time.time() - t) / len(chunk)
        if on_rollout is not None:
            on_rollout(td)
        done = td.get(("next", "done")).squeeze(-1).numpy()
        success = td.get(("next", "success")).squeeze(-1).numpy()
        dropped = td.get(("next", "dropped")).squeeze(-1).numpy()
        penetration = td.get(("next", "privileged", "penetration")).squeeze(-1).numpy()
        invalid = td.get(("next", "privileged", "physics_invalid")).squeeze(-1).numpy()
        for b, scene in enumerate(chunk):
            end = episode_end(done[b])
            ok = bool(success[b, end]) and end + 1 < C.MAX_EPISODE_STEPS + 1 and per_task < TIME_LIMIT_S
            deepest = float(np.max(penetration[b, : end + 1]))
            results.append(
                EpisodeResult(int(chunk_seeds[b]), len(scene), ok, bool(dropped[b, end]), end + 1, per_task, deepest, bool(invalid[b, end]))
            )
    return results
