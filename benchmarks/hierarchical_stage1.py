"""Measure the hierarchical baseline (paper Alg. 3) on fixed stage-1 tasks.

Each task (seed s: ``Scene.sample(stage, seed=s)``, execution noise 0) runs alone until done
or 50 actions. Success as in
:func:`occrl.eval.runner.run_episodes`: retrieved within 50 actions and 2 minutes of wall time
(planning included), nothing dropped. Prints one line per task and a JSON summary.

    python benchmarks/hierarchical_stage1.py --first 10000000 --tasks 20
    python benchmarks/hierarchical_stage1.py --sweep-from nearest --stop-when-located
"""

from __future__ import annotations

import argparse
import json
import logging
import time

import numpy as np
import torch

from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.envs import make_env
from occrl.envs import world_constants as C
from occrl.envs.episodes import TIME_LIMIT_S, EpisodeResult, task_scenes
from occrl.eval.runner import summarize


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stage", type=int, default=1)
    ap.add_argument("--first", type=int, default=10_000_000)
    ap.add_argument("--tasks", type=int, default=20)
    ap.add_argument("--plan-seconds", type=float, default=3.0)
    ap.add_argument("--planner", default="rrt", choices=["rrt", "kpiece"])
    ap.add_argument("--sweep-from", default="left", choices=["left", "nearest"])
    ap.add_argument("--stop-when-located", action="store_true")
    ap.add_argument("--seed", type=int, default=0, help="planner seed")
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO if args.verbose else logging.ERROR, format="%(levelname)s %(name)s: %(message)s")
    torch.set_num_threads(1)
    seeds = list(range(args.first, args.first + args.tasks))
    results, planning = [], []
    for seed, scene in zip(seeds, task_scenes(args.stage, seeds)):
        env = make_env(batch_size=1, scenes=[scene], seed=[seed], heatmap_target=False)
        policy = HierarchicalPlanner(
            plan_seconds=args.plan_seconds,
            planner=args.planner,
            sweep_from=args.sweep_from,
            stop_when_located=args.stop_when_located,
            seed=args.seed,
        )
        t = time.perf_counter()
        with torch.no_grad():
            td = env.rollout(C.MAX_EPISODE_STEPS, policy, break_when_any_done=True)
        seconds = time.perf_counter() - t
        success = bool(td["next", "success"][0, -1]) and seconds < TIME_LIMIT_S
        dropped = bool(td["next", "dropped"][0, -1])
        r = EpisodeResult(seed, len(scene), success, dropped, int(td.shape[-1]), seconds)
        results.append(r)
        planning.append(policy.planning_seconds)
        plans = " ".join(f"{p.name}:{'ok' if p.success else 'FAIL'}/{len(p.actions)}" for p in policy.last_plans)
        print(
            f"{seed} objects={r.objects} {'success' if success else 'failure'} actions={r.actions} "
            f"time={seconds:.1f}s planning={policy.planning_seconds:.1f}s dropped={dropped} plans=[{plans}]",
            flush=True,
        )
    summary = summarize(results)
    summary["mean_planning_seconds"] = float(np.mean(planning))
    summary["config"] = vars(args)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
