"""Run a policy on fixed tasks and measure it (success, actions, time), batched.

Tasks are scenes built from *task seeds*: task seed ``s`` is ``Scene.sample(stage, seed=s)`` and
its execution noise is seeded by ``s`` too, so every method sees the same shelves. Held-out
evaluation seeds start at :data:`EVAL_SEED_BASE`, far from anything training samples.
"""

from __future__ import annotations

import logging
import math
import multiprocessing as mp
import tempfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs.utils import set_exploration_type
from tqdm import tqdm

from occrl.distributed import WorkerDiedError, is_worker_death, require_ray, start_ray
from occrl.envs import world_constants as C
from occrl.envs.episodes import (  # noqa: F401 (re-exported)
    EpisodeResult,
    check_perception,
    check_replicate,
    check_world_settings,
    run_episodes,
    seeded_task_env,
    task_scenes,
)
from occrl.eval.methods import make_method

# EpisodeResult, run_episodes, task_scenes, seeded_task_env live in occrl.envs.episodes (importable here too)
__all__ = ["rollout_tasks", "run_tasks", "summarize", "wilson_interval", "mcnemar_p", "exclusive_wins", "EVAL_SEED_BASE"]

logger = logging.getLogger(__name__)

EVAL_SEED_BASE = 10_000_000


def wilson_interval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a success rate.

    Examples:
        >>> from occrl.eval.runner import wilson_interval
        >>> [round(v, 3) for v in wilson_interval(18, 20)]
        [0.699, 0.972]
    """
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    # the interval always holds the rate itself (at 0 and 1 rounding would put it 1e-16 outside)
    return (max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half)))


def mcnemar_p(only_a: int, only_b: int) -> float:
    """Exact two-sided McNemar p-value of two methods on the same tasks, from the discordant
    counts: the tasks only ``a`` solved and those only ``b`` solved.

    Examples:
        >>> from occrl.eval.runner import mcnemar_p
        >>> round(mcnemar_p(22, 10), 3), mcnemar_p(5, 5), mcnemar_p(0, 0)
        (0.05, 1.0, 1.0)
    """
    if only_a < 0 or only_b < 0:
        raise ValueError(f"discordant counts must be >= 0, got {only_a} and {only_b}")
    n, k = only_a + only_b, min(only_a, only_b)
    return min(1.0, 2 * sum(math.comb(n, i) for i in range(k + 1)) / 2**n) if n else 1.0


def exclusive_wins(a: Sequence[dict], b: Sequence[dict]) -> tuple[int, int, int]:
    """Two runs' episodes (``{"seed", "success", ...}``, as ``occrl eval --out`` writes them)
    matched by task seed: (tasks both ran, tasks only ``a`` solved, tasks only ``b`` solved), the
    counts :func:`mcnemar_p` takes.

    Examples:
        >>> from occrl.eval.runner import exclusive_wins
        >>> a = [{"seed": 1, "success": True}, {"seed": 2, "success": True}, {"seed": 3, "success": False}]
        >>> b = [{"seed": 2, "success": False}, {"seed": 3, "success": True}, {"seed": 4, "success": True}]
        >>> exclusive_wins(a, b)
        (2, 1, 1)
    """
    other = {e["seed"]: bool(e["success"]) for e in b}
    pairs = [(bool(e["success"]), other[e["seed"]]) for e in a if e["seed"] in other]
    return len(pairs), sum(x and not y for x, y in pairs), sum(y and not x for x, y in pairs)


def paired_with(episodes: Sequence[dict], baseline: Sequence[dict]) -> dict:
    """A run's episodes against a baseline's on the same tasks (matched by seed, as
    :func:`exclusive_wins`): the tasks both ran, the baseline's success rate on them, the tasks
    only each solved and the exact McNemar p-value.

    Examples:
        >>> from occrl.eval.runner import paired_with
        >>> a = [{"seed": 1, "success": True}, {"seed": 2, "success": True}, {"seed": 3, "success": False}]
        >>> b = [{"seed": 2, "success": False}, {"seed": 3, "success": True}, {"seed": 4, "success": True}]
        >>> paired_with(a, b)
        {'tasks': 2, 'baseline_success_rate': 0.5, 'only_run': 1, 'only_baseline': 1, 'p': 1.0}
    """
    tasks, only_run, only_baseline = exclusive_wins(episodes, baseline)
    ran = {e["seed"] for e in episodes}
    solved = [bool(e["success"]) for e in baseline if e["seed"] in ran]
    rate = sum(solved) / len(solved) if solved else float("nan")
    return {
        "tasks": tasks,
        "baseline_success_rate": rate,
        "only_run": only_run,
        "only_baseline": only_baseline,
        "p": mcnemar_p(only_run, only_baseline),
    }


def rollout_tasks(
    method, stage: int, seeds: Sequence[int], noise: float = 0.0, steps: int = C.MAX_EPISODE_STEPS, replicate: int = 0
) -> TensorDictBase:
    """One batch of ``method`` (a :class:`~occrl.eval.methods.Method`) on the stage's tasks of
    ``seeds``, with the full [len(seeds), steps] rollout (privileged keys included) for analysis;
    the same episodes :func:`run_episodes` scores (with the same ``replicate``). A world that
    finishes starts a new episode.

    Examples:
        >>> from occrl.eval.methods import make_method
        >>> from occrl.eval.runner import rollout_tasks
        >>> td = rollout_tasks(make_method("scripted"), 1, [3, 4], steps=5)
        >>> td.batch_size, ("privileged", "target_pose") in td.keys(True)
        (torch.Size([2, 5]), True)
    """
    env = seeded_task_env(
        method.policy,
        task_scenes(stage, seeds),
        seeds,
        noise,
        method.primers,
        size=method.image_size,
        replicate=replicate,
        remembered_detections=method.remembered_detections,
    )
    with torch.no_grad(), set_exploration_type(method.exploration):
        return env.rollout(steps, method.policy, break_when_any_done=False)


def summarize(results: Sequence[EpisodeResult]) -> dict:
    """Success rate with its 95 % Wilson interval, drops, mean actions and seconds per task.

    Examples:
        >>> from occrl.envs.episodes import EpisodeResult
        >>> from occrl.eval.runner import summarize
        >>> rs = [EpisodeResult(s, 3, s % 2 == 0, False, 20 + s, 1.0) for s in range(4)]
        >>> summary = summarize(rs)
        >>> summary["success_rate"], summary["mean_actions"]
        (0.5, 21.5)
    """
    n = len(results)
    k = sum(r.success for r in results)
    lo, hi = wilson_interval(k, n)
    return {
        "tasks": n,
        "successes": k,
        "success_rate": k / n if n else float("nan"),
        "success_ci95": [lo, hi],
        "dropped": sum(r.dropped for r in results),
        "physically_invalid": sum(r.physics_invalid for r in results),
        "mean_actions": float(np.mean([r.actions for r in results])) if n else float("nan"),
        "mean_seconds": float(np.mean([r.seconds for r in results])) if n else float("nan"),
    }


_WORKER: dict = {}


def _init_worker(method: str, weights, threads: int, settings: dict) -> None:
    """Make this process's method; ``settings`` are :func:`~occrl.eval.methods.make_method`'s planner settings."""
    torch.set_num_threads(threads)
    _WORKER["method"] = make_method(method, weights, **settings)


def _run_chunk(args) -> list[EpisodeResult]:
    stage, seeds, num_objects, noise, world, replicate, perception, shelf_height, tag_layout = args
    m = _WORKER["method"]
    options = {"perception": perception} if perception != "geometric" else {}
    options |= {"shelf_height": shelf_height} if shelf_height is not None else {}
    options |= {"tag_layout": tag_layout} if tag_layout is not None else {}
    return m.run_episodes(task_scenes(stage, seeds, num_objects), seeds, noise, len(seeds), world=world, replicate=replicate, **options)


def _run_tasks_ray(
    method: str,
    weights,
    jobs: list,
    workers: int,
    address: str | None,
    bar,
    settings: dict,
    max_restarts: int = 2,
) -> list:
    """Chunks on ``workers`` Ray actors (one CPU each); a chunk whose actor died runs again on a new
    actor (chunks are seeded by their tasks, so the repeat gives the same results)."""
    ray = require_ray("occrl eval --backend ray")
    start_ray(address, num_cpus=workers)
    weights_blob = Path(weights).read_bytes() if weights else None  # cluster nodes need not share a disk

    @ray.remote(num_cpus=1)
    class EvalWorker:
        def __init__(self) -> None:
            path = None
            if weights_blob is not None:
                path = Path(tempfile.mkdtemp()) / "weights.pt"
                path.write_bytes(weights_blob)
            _init_worker(method, path, 1, settings)

        def run(self, job):
            return _run_chunk(job)

    actors = [EvalWorker.remote() for _ in range(min(workers, len(jobs)))]
    results: list = [None] * len(jobs)
    pending = {}  # object ref -> (job index, actor)
    queue = list(range(len(jobs)))
    restarts = 0
    for actor in actors:
        if queue:
            k = queue.pop(0)
            pending[actor.run.remote(jobs[k])] = (k, actor)
    while pending:
        [ref], _ = ray.wait(list(pending), num_returns=1)
        k, actor = pending.pop(ref)
        try:
            results[k] = ray.get(ref)
        except Exception as err:
            if not is_worker_death(err):
                raise
            restarts += 1
            if restarts > max_restarts:
                raise WorkerDiedError(f"Ray evaluation workers died {restarts} times ({type(err).__name__}: {err})") from err
            logger.error("a Ray evaluation worker died (%s); running its chunk on a new worker", type(err).__name__)
            actor = EvalWorker.remote()
            actors.append(actor)  # killed with the others at the end
            queue.insert(0, k)
        else:
            bar.update(len(jobs[k][1]))
        if queue:
            k = queue.pop(0)
            pending[actor.run.remote(jobs[k])] = (k, actor)
    for actor in actors:
        ray.kill(actor)
    return results


def run_tasks(
    method: str,
    stage: int,
    seeds: Sequence[int],
    noise: float = 0.0,
    num_objects: int | None = None,
    batch: int = 16,
    workers: int = 1,
    weights=None,
    progress=True,
    backend: str = "local",
    ray_address: str | None = None,
    world: str = "pymunk",
    inference: str = "torch",
    replicate: int = 0,
    perception: str = "geometric",
    shelf_height: float | None = None,
    tag_layout: str | None = None,
) -> list[EpisodeResult]:
    """Evaluate a named method on task seeds, in chunks of ``batch`` worlds spread over
    ``workers`` processes (``backend="local"``) or Ray actors (``backend="ray"``, a local runtime
    or the cluster at ``ray_address``). Results do not depend on ``workers`` or ``backend``
    (per-task wall time aside). ``world="mujoco"`` executes in the 3D MuJoCo env (the planners
    still plan in pymunk, recreated from its detections); ``num_objects=(low, high)`` draws each
    task's object count from its seed. ``inference`` goes to the hybrid planners
    (:func:`~occrl.eval.methods.make_method`). ``replicate`` > 0 runs the same tasks with
    the decision maker's randomness drawn anew (:func:`~occrl.envs.episodes.decision_seed`; 0 is
    what every recorded result ran). ``perception="tags"`` (with ``world="mujoco"``) plans from what
    the tag detector decodes in the wrist camera's image instead of the geometric visibility rule;
    ``shelf_height`` (with ``world="mujoco"``; None: 0.30 m) the MuJoCo shelf's inside height;
    ``tag_layout`` (with ``perception="tags"``; None: the env's default) the tags
    (:data:`~occrl.envs.mujoco3d.tags.TAG_LAYOUTS`).
    ``progress``: show a progress bar with an ETA
    (``True``), none (``False``), or advance a ``tqdm`` bar the caller owns (a sweep's).

    Examples:
        >>> from occrl.eval.runner import EVAL_SEED_BASE, run_tasks, summarize
        >>> results = run_tasks("scripted", 1, [EVAL_SEED_BASE, EVAL_SEED_BASE + 1], num_objects=1, progress=False)
        >>> [r.seed for r in results], summarize(results)["success_rate"]
        ([10000000, 10000001], 1.0)
    """
    if backend not in ("local", "ray"):
        raise ValueError(f"backend must be 'local' or 'ray', got {backend!r}")
    check_replicate(replicate)
    check_world_settings(world, perception, shelf_height, tag_layout)
    chunks = [list(seeds[i : i + batch]) for i in range(0, len(seeds), batch)]
    own_bar = not hasattr(progress, "update")
    bar = tqdm(total=len(seeds), desc=f"{method} stage {stage} noise {noise}", unit="task", disable=not progress) if own_bar else progress
    results: list[list[EpisodeResult]] = [None] * len(chunks)
    jobs = [(stage, c, num_objects, noise, world, replicate, perception, shelf_height, tag_layout) for c in chunks]
    settings = dict(inference=inference)  # make_method's
    if backend == "ray":
        results = _run_tasks_ray(method, weights, jobs, max(1, workers), ray_address, bar, settings)
    elif workers <= 1:
        _init_worker(method, weights, torch.get_num_threads(), settings)
        for k, job in enumerate(jobs):
            results[k] = _run_chunk(job)
            bar.update(len(job[1]))
    else:
        with ProcessPoolExecutor(
            workers,
            mp_context=mp.get_context("spawn"),
            initializer=_init_worker,
            initargs=(method, weights, 1, settings),
        ) as pool:
            futures = {pool.submit(_run_chunk, job): k for k, job in enumerate(jobs)}
            for f in as_completed(futures):
                results[futures[f]] = f.result()
                bar.update(len(jobs[futures[f]][1]))
    if own_bar:
        bar.close()
    return [r for chunk in results for r in chunk]
