"""The papers' simulation study (Sec. VI-C): every method over clutter density and noise level.

Two sweeps, the same task seeds for every method:

* clutter: 1 to 10 objects, noise 0 (or ``clutter_noise``: the same sweep on noisy physics, in
  its own output folder);
* noise: 0.0 to 0.25 by 0.05, with a random number of objects (1 to 10, drawn from the task seed).

Each finished point (method, sweep, value) is cached as JSON under ``out/points/``, so an
interrupted sweep resumes where it stopped, and a point can be extended by more task seeds later
(``chunk`` runs the sweep in rounds: every point first gets ``chunk`` tasks, then the next ones);
a finished sweep packs its points into ``out/points.json.gz`` (:mod:`occrl.eval.sweep_store`). ``summarize_sweep`` writes ``results.csv`` and
``results.json``; ``plot_sweep`` draws the paper's Fig. 5 layout (success, time and actions per
task against clutter and against noise, one line per method).
"""

from __future__ import annotations

import csv
import io
import json
import logging
from pathlib import Path
from typing import Sequence

import numpy as np
import torch
from matplotlib.figure import Figure  # no pyplot: leaves the caller's backend (e.g. a notebook's) alone
from torchrl.envs.utils import set_exploration_type
from tqdm import tqdm

from occrl.atomic_files import write_text_atomic
from occrl.envs import world_constants as C
from occrl.envs.episodes import EPISODE_TIMING, EpisodeResult, episode_end, seeded_task_env, task_object_count, task_scenes
from occrl.eval.film import episode_frames, save_film_strip
from occrl.eval.methods import is_planner, make_method, method_network
from occrl.eval.runner import EVAL_SEED_BASE, run_tasks, summarize
from occrl.eval.sweep_store import pack_points, point_episodes, point_path, read_point, sweep_points, unpack_points

__all__ = [
    "SWEEPS",
    "run_sweep",
    "summarize_sweep",
    "sweep_tables",
    "plot_sweep",
    "sweep_films",
    "noise_sweep_objects",
]

logger = logging.getLogger(__name__)

SWEEPS = {
    "clutter": [float(n) for n in range(1, 11)],
    "noise": [0.0, 0.05, 0.1, 0.15, 0.2, 0.25],
}
SCENE_STAGE = 2  # uniform target placement
# How a point's times were taken. Points without the key come from before occrl 0.3.0, whose
# evaluation ran every task for 50 actions (starting it again after its episode ended): their
# success, drops and actions are exact, their time is that of 50 actions.
LEGACY_TIMING = "50 actions"


def noise_sweep_objects(seed: int) -> int:
    """Number of objects of a noise-sweep task (1 to 10, fixed by the task seed).

    Examples:
        >>> from occrl.eval.sweep import noise_sweep_objects
        >>> [noise_sweep_objects(s) for s in range(5)]
        [8, 8, 7, 6, 9]
    """
    return task_object_count(seed, 1, 10)


def _run_point(
    method: str, sweep: str, value: float, seeds: list[int], batch: int, workers: int, weights, progress, clutter_noise: float, **backend
) -> list[EpisodeResult]:
    if sweep == "clutter":
        return run_tasks(method, SCENE_STAGE, seeds, clutter_noise, int(value), batch, workers, weights, progress, **backend)
    # noise sweep: a random object count per task; group tasks by count so scenes are sampled alike
    results: dict[int, EpisodeResult] = {}
    by_count: dict[int, list[int]] = {}
    for s in seeds:
        by_count.setdefault(noise_sweep_objects(s), []).append(s)
    for count, group in sorted(by_count.items()):
        for r in run_tasks(method, SCENE_STAGE, group, value, count, batch, workers, weights, progress, **backend):
            results[r.seed] = r
    return [results[s] for s in seeds]


def run_sweep(
    methods: Sequence[str],
    out: str | Path,
    tasks: int = 300,
    first_seed: int = EVAL_SEED_BASE,
    sweeps: Sequence[str] = ("clutter", "noise"),
    values: dict | None = None,
    batch: int = 16,
    workers: int = 1,
    weights=None,
    progress: bool = True,
    backend: str = "local",
    ray_address: str | None = None,
    chunk: int | None = None,
    films: bool = False,
    clutter_noise: float = 0.0,
) -> Path:
    """Run (or resume, or extend) the sweep; returns the output folder.

    Points grow in rounds of ``chunk`` tasks (default: all ``tasks`` at once): every point gets
    its first ``chunk`` seeds before any gets more, so an interrupted sweep leaves a complete
    figure with wider intervals rather than half a figure. A cached point holding fewer seeds
    than asked is extended with the missing ones (a point run with 50 tasks grows to 300 by
    running seeds 51-300 only). ``backend="ray"`` spreads each point's tasks over Ray actors
    (see :func:`occrl.eval.runner.run_tasks`). ``films=True`` ends with :func:`sweep_films` for
    hybrid 4x4 (or the first method). ``clutter_noise``: the physics noise of the clutter sweep's
    tasks (the papers do not say theirs; 0 by default); a folder holds clutter points of one noise.

    Examples:
        >>> import os, tempfile
        >>> from occrl.eval.sweep import run_sweep
        >>> out = run_sweep(["scripted"], tempfile.mkdtemp(), tasks=1, sweeps=("clutter",),
        ...                 values={"clutter": [1.0]}, progress=False)
        >>> sorted(os.listdir(out))
        ['points.json.gz', 'results.csv', 'results.json', 'sweep.png']
    """
    if tasks < 1 or (chunk is not None and chunk < 1):
        raise ValueError(f"tasks and chunk must be >= 1, got tasks={tasks}, chunk={chunk}")
    out = Path(out)
    unpack_points(out)  # a finished sweep being extended (or an interrupted pack)
    (out / "points").mkdir(parents=True, exist_ok=True)
    chunk = chunk or tasks
    points = [(sweep, value, method) for sweep in sweeps for value in (values or SWEEPS)[sweep] for method in methods]
    all_seeds = set(range(first_seed, first_seed + tasks))
    to_run = sum(len(all_seeds - set(point_episodes(read_point(point_path(out, m, sw, v))))) for sw, v, m in points)
    # one bar (and ETA) for the whole sweep; the points advance it task by task
    bar = tqdm(total=to_run, desc=f"sweep ({len(points)} points)", unit="task", disable=not progress)
    networks = {m: method_network(m, weights) for m in methods}  # (name, SHA-256 of the weights) per method
    for upto in list(range(chunk, tasks, chunk)) + [tasks]:
        seeds = list(range(first_seed, first_seed + upto))
        for sweep, value, method in points:
            path = point_path(out, method, sweep, value)
            cached = read_point(path)  # read once: its episodes and its noise
            done = point_episodes(cached)
            if done and min(done) != first_seed:
                raise ValueError(
                    f"{path} holds task seeds from {min(done)}, not from {first_seed}: use another --out folder for other task seeds"
                )
            noise = clutter_noise if sweep == "clutter" else value
            cached_noise = _point_noise(cached) if cached is not None else noise
            if cached_noise != noise:
                raise ValueError(f"{path} holds tasks at noise {cached_noise:g}, not {noise:g}: use another --out folder for another noise")
            _check_point_network(path, cached, *networks[method])
            missing = [s for s in seeds if s not in done]
            if not missing:
                continue
            b = 1 if is_planner(method) else batch
            bar.set_postfix_str(f"{method} {sweep}={value:g}, tasks up to {upto}")
            for r in _run_point(
                method,
                sweep,
                value,
                missing,
                b,
                workers,
                weights,
                bar if progress else False,
                clutter_noise,
                backend=backend,
                ray_address=ray_address,
            ):
                done[r.seed] = r
            results = [done[s] for s in sorted(done)]
            point = {
                "method": method,
                "sweep": sweep,
                "value": value,
                "noise": noise,
                "network": networks[method][0],
                "network_sha256": networks[method][1],
                # a point extended from a legacy one keeps the legacy mark: some of its times are of 50 actions
                **({"timing": EPISODE_TIMING} if cached is None or cached.get("timing") == EPISODE_TIMING else {}),
                **summarize(results),
                "episodes": [r.to_dict() for r in results],
            }
            write_text_atomic(path, json.dumps(point))  # a point is cached whole or not at all
            logger.info("%s %s=%g (%d tasks): success %.2f", method, sweep, value, len(results), point["success_rate"])
    bar.close()
    pack_points(out)
    summarize_sweep(out)
    plot_sweep(out)
    if films:
        sweep_films(out, "hybrid-4x4" if "hybrid-4x4" in methods else methods[0], weights=weights)
    return out


def _check_point_network(path: Path, point: dict | None, name: str | None, sha256: str | None) -> None:
    """``ValueError`` when a cached point holds episodes of another network than the one its
    method now decides with (a sweep extended with other weights, or after the default network
    changed); points written before sweeps recorded their network are taken as they are, with a
    warning."""
    if point is None or sha256 is None:
        return
    if "network_sha256" not in point:
        logger.warning("%s was written before sweeps recorded their network: extending it with %s unchecked", path, name)
        return
    if point["network_sha256"] != sha256:
        raise ValueError(
            f"{path} holds episodes of the network {point.get('network')!r} (sha256 {point['network_sha256'][:12]}), not of "
            f"{name!r} (sha256 {sha256[:12]}): use another --out folder for another network"
        )


def _point_noise(point: dict) -> float:
    """The physics noise of a point's tasks (points from before it was recorded: clutter points
    ran at noise 0, noise points at their value)."""
    return float(point.get("noise", point["value"] if point["sweep"] == "noise" else 0.0))


def summarize_sweep(out: str | Path) -> list[dict]:
    """Collect the points of ``out`` (:func:`~occrl.eval.sweep_store.sweep_points`) into ``results.json`` and ``results.csv``
    (one row per method, sweep and value, with the success rate's 95 % interval); returns the rows.

    Examples:
        >>> import json, tempfile
        >>> from pathlib import Path
        >>> from occrl.envs.episodes import EpisodeResult
        >>> from occrl.eval.runner import summarize
        >>> from occrl.eval.sweep import summarize_sweep
        >>> out = Path(tempfile.mkdtemp())
        >>> (out / "points").mkdir()
        >>> episodes = [EpisodeResult(seed=0, objects=1, success=True, dropped=False, actions=9, seconds=0.3)]
        >>> point = {"method": "scripted", "sweep": "clutter", "value": 1.0, **summarize(episodes)}
        >>> _ = (out / "points" / "scripted__clutter__1.json").write_text(json.dumps(point))
        >>> row, = summarize_sweep(out)
        >>> row["method"], row["success_rate"], row["mean_actions"], (out / "results.csv").exists()
        ('scripted', 1.0, 9.0, True)
    """
    out = Path(out)
    rows = []
    for p in sweep_points(out):
        rows.append(
            {k: p[k] for k in ("method", "sweep", "value", "tasks", "successes", "success_rate", "dropped", "mean_actions", "mean_seconds")}
            | {"noise": _point_noise(p), "timing": p.get("timing", LEGACY_TIMING)}
            | {"ci95_low": p["success_ci95"][0], "ci95_high": p["success_ci95"][1]}
        )
    rows.sort(key=lambda r: (r["sweep"], r["method"], r["value"]))
    write_text_atomic(out / "results.json", json.dumps(rows, indent=2))
    if rows:
        table = io.StringIO(newline="")
        w = csv.DictWriter(table, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
        write_text_atomic(out / "results.csv", table.getvalue())
    return rows


def sweep_tables(rows: list[dict]) -> str:
    """Success (%) per method (rows) and sweep value (columns), one Markdown table per sweep,
    with the tasks per point: the one-screen summary ``occrl eval --sweep`` ends with.

    Examples:
        >>> rows = [{"method": "scripted", "sweep": "clutter", "value": v, "tasks": 4, "success_rate": r}
        ...         for v, r in ((1.0, 1.0), (2.0, 0.75))]
        >>> print(sweep_tables(rows))
        success (%) against clutter (4 tasks per point):
        | method | 1 | 2 |
        | --- | --- | --- |
        | scripted | 100 | 75 |
    """
    blocks = []
    for sweep in sorted({r["sweep"] for r in rows}):
        mine = [r for r in rows if r["sweep"] == sweep]
        values = sorted({r["value"] for r in mine})
        methods = list(dict.fromkeys(r["method"] for r in mine))
        cell = {(r["method"], r["value"]): r for r in mine}
        tasks = sorted({r["tasks"] for r in mine})
        per_point = f"{tasks[0]}" if len(tasks) == 1 else f"{tasks[0]}-{tasks[-1]}"
        noisy = "".join(f" at noise {n:g}" for n in sorted({r.get("noise", 0.0) for r in mine} - {0.0})) if sweep == "clutter" else ""
        lines = [
            f"success (%) against {sweep}{noisy} ({per_point} tasks per point):",
            "| method | " + " | ".join(f"{v:g}" for v in values) + " |",
            "| --- |" + " --- |" * len(values),
        ]
        for m in methods:
            lines.append(
                f"| {m} | " + " | ".join(f"{100 * cell[m, v]['success_rate']:.0f}" if (m, v) in cell else "" for v in values) + " |"
            )
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def plot_sweep(out: str | Path) -> Path:
    """Fig. 5 layout: columns success rate, time per task, actions per task; rows clutter, noise.
    Points from before occrl 0.3.0 timed 50 actions per task, and the time axis says so.

    Examples:
        >>> import json, tempfile
        >>> from pathlib import Path
        >>> from occrl.envs.episodes import EpisodeResult
        >>> from occrl.eval.runner import summarize
        >>> from occrl.eval.sweep import plot_sweep
        >>> out = Path(tempfile.mkdtemp())
        >>> (out / "points").mkdir()
        >>> episodes = [EpisodeResult(seed=0, objects=1, success=True, dropped=False, actions=9, seconds=0.3)]
        >>> point = {"method": "scripted", "sweep": "clutter", "value": 1.0, **summarize(episodes)}
        >>> _ = (out / "points" / "scripted__clutter__1.json").write_text(json.dumps(point))
        >>> path = plot_sweep(out)
        >>> path.name, path.stat().st_size > 0
        ('sweep.png', True)
    """
    out = Path(out)
    rows = summarize_sweep(out)
    fig = Figure(figsize=(13, 7))
    axes = fig.subplots(2, 3)
    for i, sweep in enumerate(("clutter", "noise")):
        for method in sorted({r["method"] for r in rows if r["sweep"] == sweep}):
            pts = sorted((r for r in rows if r["sweep"] == sweep and r["method"] == method), key=lambda r: r["value"])
            x = [r["value"] for r in pts]
            y = np.array([r["success_rate"] for r in pts])
            err = np.array([[r["success_rate"] - r["ci95_low"], r["ci95_high"] - r["success_rate"]] for r in pts]).T
            axes[i, 0].errorbar(x, y, yerr=err, marker="o", capsize=3, label=method)
            axes[i, 1].plot(x, [r["mean_seconds"] for r in pts], marker="o", label=method)
            axes[i, 2].plot(x, [r["mean_actions"] for r in pts], marker="o", label=method)
        clutter_noise = sorted({r["noise"] for r in rows if r["sweep"] == "clutter"} - {0.0})
        xlabel = "noise level" if sweep == "noise" else "number of objects" + "".join(f" (noise {n:g})" for n in clutter_noise)
        timings = {r["timing"] for r in rows if r["sweep"] == sweep}
        time_label = {frozenset({EPISODE_TIMING}): "time per task (s)", frozenset({LEGACY_TIMING}): "time per 50 actions (s)"}.get(
            frozenset(timings), "time per task (s; some of 50 actions)"
        )
        for ax, ylabel in zip(axes[i], ("success rate", time_label, "actions per task")):
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    path = out / "sweep.png"
    fig.savefig(path, dpi=100)
    return path


def sweep_films(out: str | Path, method: str, solved: int = 3, failed: int = 1, weights=None) -> list[Path]:
    """Film strips (paper Fig. 6 style) of ``solved`` successful and ``failed`` failed sweep
    episodes of ``method``, from the most cluttered clutter point that has both, written to
    ``out/films/``. Every episode is replayed from its task seed exactly as the sweep ran it;
    a replay whose outcome differs from the cached one raises ``RuntimeError``.

    Examples:
        >>> import tempfile
        >>> from occrl.eval.sweep import run_sweep, sweep_films
        >>> out = run_sweep(["scripted"], tempfile.mkdtemp(), tasks=2, sweeps=("clutter",),
        ...                 values={"clutter": [1.0]}, progress=False)
        >>> [p.name for p in sweep_films(out, "scripted", solved=1, failed=0)]
        ['scripted__clutter__1__seed10000000__solved.png']
    """
    out = Path(out)
    points = sorted(sweep_points(out, method, "clutter"), key=lambda p: -p["value"])
    for point in points:
        wins = [e for e in point["episodes"] if e["success"]][:solved]
        losses = [e for e in point["episodes"] if not e["success"]][:failed]
        if len(wins) == solved and len(losses) == failed:
            break
    else:
        raise ValueError(f"no clutter point of {method!r} in {out} has {solved} solved and {failed} failed episodes")
    m = make_method(method, weights)
    (out / "films").mkdir(exist_ok=True)
    paths = []
    for e in wins + losses:
        seed = int(e["seed"])
        env = seeded_task_env(
            m.policy,
            task_scenes(SCENE_STAGE, [seed], int(point["value"])),
            [seed],
            _point_noise(point),
            m.primers,
            size=m.image_size,
            remembered_detections=m.remembered_detections,
        )
        decisions = getattr(m.policy, "decisions", None)
        if decisions is not None:
            decisions.clear()
        with torch.no_grad(), set_exploration_type(m.exploration):
            td = env.rollout(C.MAX_EPISODE_STEPS, m.policy, break_when_any_done=False, break_when_all_done=True)[0]
        end = episode_end(td.get(("next", "done")).squeeze(-1).numpy())
        if bool(td.get(("next", "success"))[end]) != bool(e["success"]) or end + 1 != e["actions"]:
            raise RuntimeError(f"replay of task {seed} ({method}, {int(point['value'])} objects) differs from the sweep's episode")
        frames = episode_frames(td[: end + 1], decisions=decisions)
        tag = "solved" if e["success"] else "failed"
        name = f"{method}__clutter__{point['value']:g}__seed{seed}__{tag}.png"
        paths.append(save_film_strip(frames, out / "films" / name))
    return paths
