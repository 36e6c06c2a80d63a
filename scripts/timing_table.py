"""Planning and execution time per task for each method, as the papers report it (Fig. 5's time row).

Every method runs one task at a time (one world, as one robot would) on the clutter sweep's
tasks (stage-2 scene sampling, noise 0, seeds from 10,000,000) at the given object counts, and
each task's wall time is split into *planning* (the method's calls: network, roll-outs, OMPL) and
*execution* (the env's steps: physics, perception, rendering of the next observation). A task
ends with its episode (retrieved, dropped, or 50 actions). For the hybrid planners the table also
gives the share of decisions that weighed more than one root (the target undetected, several
heat-map peaks): only those differ between hybrid and hybrid-lim, which keeps the likeliest root.

Run it with the machine to itself: times are absolute seconds of this machine (the table says
which CPU), unlike the benchmarks' ratios. With ``--sweep DIR`` every episode is checked against
that sweep's episode of the same method and seed (same outcome, same number of actions).

Usage:
    python scripts/timing_table.py --objects 1,4,7,10 --tasks 25 --sweep results/sweep-v3 --out results/timing/timing.json
    python scripts/timing_table.py --table results/timing/timing.json   # the markdown table again
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from occrl.envs.episodes import task_scenes
from occrl.eval.methods import METHODS, is_method, make_method, method_network
from occrl.eval.runner import EVAL_SEED_BASE
from occrl.eval.sweep import SCENE_STAGE
from occrl.eval.sweep_store import point_episodes, sweep_points

STUDY_METHODS = ["hybrid-2x2", "hybrid-4x4", "hybrid-6x6", "hybrid-lim-4x4", "greedy", "stochastic", "stochastic-gen", "hierarchical"]


class CallTimer:
    """Adds up the wall time spent inside a module's calls (forward hooks)."""

    def __init__(self, module: torch.nn.Module):
        self.seconds = 0.0
        self.calls = 0
        self._start = 0.0
        module.register_forward_pre_hook(self._before)
        module.register_forward_hook(self._after)

    def _before(self, *args) -> None:
        self._start = time.perf_counter()

    def _after(self, *args) -> None:
        self.seconds += time.perf_counter() - self._start
        self.calls += 1


def time_method(name: str, objects: list[int], tasks: int, bar: tqdm) -> list[dict]:
    """One row per task: object count, seed, outcome, actions, planning and execution seconds."""
    method = make_method(name)
    timer = CallTimer(method.policy)
    rows = []
    for count in objects:
        for seed in range(EVAL_SEED_BASE, EVAL_SEED_BASE + tasks):
            timer.seconds, timer.calls = 0.0, 0
            decisions = getattr(method.policy, "decisions", None)  # the hybrid planners' record of each decision
            if decisions is not None:
                decisions.clear()
            [result] = method.run_episodes(task_scenes(SCENE_STAGE, [seed], count), [seed], batch_size=1)
            if timer.calls != result.actions:
                raise RuntimeError(f"{name} was asked {timer.calls} times for an episode of {result.actions} actions (task {seed})")
            rows.append(
                {
                    "objects": count,
                    "seed": seed,
                    "success": result.success,
                    "actions": result.actions,
                    "planning_seconds": timer.seconds,
                    "execution_seconds": result.seconds - timer.seconds,
                    # roots weighed per decision (hybrid planners): one whenever the target is detected
                    **({"roots": [len(d.roots) for d in decisions]} if decisions is not None else {}),
                }
            )
            bar.update()
    return rows


def check_against_sweep(name: str, rows: list[dict], sweep: Path) -> int:
    """Number of episodes that differ from the sweep's (outcome or action count); missing points are skipped."""
    ref = {float(p["value"]): point_episodes(p) for p in sweep_points(sweep, name, "clutter")}
    differ = 0
    for r in rows:
        e = ref.get(float(r["objects"]), {}).get(r["seed"])
        if e is not None and (e.success != r["success"] or e.actions != r["actions"]):
            differ += 1
    return differ


def cpu_name() -> str:
    """The CPU's model name (Linux), else what ``platform`` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def table(result: dict) -> str:
    objects = result["objects"]
    lines = [
        f"seconds per task, planning + execution, by the number of objects on the shelf (mean over {result['tasks']} tasks each; one task at a time on one core; {result['cpu']})",
        "",
        "| method | " + " | ".join(str(n) for n in objects) + " | planning share | ms per action | decisions with > 1 root |",
        "| --- | " + " | ".join("---" for _ in objects) + " | --- | --- | --- |",
    ]
    for name, rows in result["methods"].items():
        cells = []
        for n in objects:
            rs = [r for r in rows if r["objects"] == n]
            plan = np.mean([r["planning_seconds"] for r in rs])
            execute = np.mean([r["execution_seconds"] for r in rs])
            cells.append(f"{plan + execute:.2f} ({plan:.2f} + {execute:.2f})")
        plan_all = sum(r["planning_seconds"] for r in rows)
        total_all = plan_all + sum(r["execution_seconds"] for r in rows)
        per_action = 1000 * total_all / sum(r["actions"] for r in rows)
        roots = [k for r in rows for k in r.get("roots", [])]
        multi = f"{100 * np.mean([k > 1 for k in roots]):.0f} % of {len(roots)}" if roots else ""
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {100 * plan_all / total_all:.0f} % | {per_action:.0f} | {multi} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(STUDY_METHODS), help="comma-separated method names")
    parser.add_argument("--objects", default="1,4,7,10", help="comma-separated object counts (clutter sweep points)")
    parser.add_argument("--tasks", type=int, default=25, help="tasks per object count (seeds from 10,000,000)")
    parser.add_argument("--sweep", type=Path, default=None, help="a sweep folder to check every episode against")
    parser.add_argument("--out", type=Path, default=None, help="JSON file for every task's times")
    parser.add_argument("--table", type=Path, default=None, help="print the table of an earlier --out file and stop")
    args = parser.parse_args()
    if args.table is not None:
        print(table(json.loads(args.table.read_text())))
        return
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if not is_method(m)]
    if unknown:
        parser.error(f"unknown method(s) {unknown}; allowed: {', '.join(METHODS)} (or any hybrid-MxH / hybrid-lim-MxH / hybrid-ompl-MxH)")
    objects = [int(n) for n in args.objects.split(",")]
    if args.tasks < 1 or not all(1 <= n <= 10 for n in objects):
        parser.error(f"--tasks must be >= 1 and --objects within 1-10, got {args.tasks} and {objects}")
    torch.set_num_threads(1)
    result = {
        "command": "python scripts/timing_table.py "
        + " ".join(f"--{k} {v}" for k, v in (("methods", args.methods), ("objects", args.objects), ("tasks", args.tasks))),
        "cpu": f"{cpu_name()}, torch threads 1",
        "objects": objects,
        "tasks": args.tasks,
        "networks": {m: method_network(m, None)[0] for m in methods},
        "methods": {},
        "differ_from_sweep": {},
    }
    bar = tqdm(total=len(methods) * len(objects) * args.tasks, desc="timing", unit="task")
    for name in methods:
        result["methods"][name] = time_method(name, objects, args.tasks, bar)
        if args.sweep is not None:
            result["differ_from_sweep"][name] = check_against_sweep(name, result["methods"][name], args.sweep)
    bar.close()
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1))
    print(table(result))
    if args.sweep is not None:
        print(f"episodes that differ from {args.sweep}: {result['differ_from_sweep']}")


if __name__ == "__main__":
    main()
