"""Is it the planner's model of the world or its network that holds the hybrid planner back?

    python scripts/oracle_roots.py --stage 2 --tasks 200 --roots state|target|own [--to-the-end] [--weights W] [--baseline F.json] [--out F.json]

The hybrid 4x4 planner (paper Alg. 1-2, the network's policy and value unchanged) plans from
roots that it could not know, on the README's held-out tasks (the planner reseeded per task as
`occrl eval` does):

- ``--roots state``: one root, the true state: every object on the shelf at its true pose and
  shape, hidden ones included, and the target where it is. At noise 0 the roll-outs then
  simulate the real future exactly (up to the policy's sampling); what fails is the policy the
  roll-outs follow and the value that scores them.
- ``--roots target``: the recreated state (detected objects only) with the target at its true
  pose while it is not detected, one root: a perfect heat-map; the objects the camera has not
  seen stay missing from the roll-outs, as in the planner.
- ``--roots own``: the planner's own roots (its heat-map's peaks, nothing privileged read); with
  ``--to-the-end`` the plain planner with its value replaced by roll-outs to the end.

``--to-the-end``: each roll-out runs to the episode's 50-action limit and its return is the
sum of the rewards (no value at a horizon): the policy's own outcome from each root, a Monte-Carlo
stand-in for a perfect value of this policy (slow: ~10 s per task).

Against the planner's own episodes on the same tasks (``--baseline``, an `occrl eval --out`
file) it prints the success of both, the tasks only one solved and the exact McNemar p-value.
A diagnosis for issue 16 (docs/decisions.md); it reads ``"privileged"`` (the true state), so
it is analysis, never a method.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch
from tqdm import tqdm

from occrl.baselines.oracle_planner import ORACLE_ROOTS as ROOTS
from occrl.baselines.oracle_planner import OracleRootsPlanner
from occrl.envs.episodes import task_scenes
from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE, paired_with, summarize
from occrl.pretrained import network_name, weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=200)
    parser.add_argument("--roots", default="state", choices=ROOTS)
    parser.add_argument("--to-the-end", action="store_true", help="roll-outs to the action limit, no value at a horizon")
    parser.add_argument("--weights", default=None, help="the planner's network: a weights file or a shipped name (default: occnet)")
    parser.add_argument("--baseline", default=None, help="an `occrl eval --out` file of hybrid 4x4 on the same tasks")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    method = make_method("hybrid-4x4", weights_file(args.weights))
    planner = OracleRootsPlanner(method.policy.net, args.roots, args.to_the_end, m=4, h=4)
    name = f"hybrid {'4 roll-outs to the end' if args.to_the_end else '4x4'} from " + (
        "its own roots" if args.roots == "own" else f"the true {args.roots}"
    )
    settings = {"stage": args.stage, "roots": args.roots, "to_the_end": args.to_the_end, "weights": network_name(args.weights or "occnet")}
    report_planner_run(method, planner, name, args.stage, args.tasks, settings, args.baseline, args.out)


def report_planner_run(method, planner, name: str, stage: int, tasks: int, settings: dict, baseline: str | None, out: str | None) -> dict:
    """Run ``planner`` (in ``method``'s env settings) on the first ``tasks`` held-out tasks of
    ``stage``, one world per task as `occrl eval` runs the planners, print its success (and, with
    ``baseline``, an `occrl eval --out` file, the tasks only one of them solved and the exact
    McNemar p), and write ``settings``, the summary and the episodes to ``out``."""
    seeds = list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + tasks))
    t0 = time.time()
    results = []
    for seed in tqdm(seeds, desc=name, unit="task"):
        results += method.run_episodes(task_scenes(stage, [seed]), [seed], batch_size=1, policy=planner)
    summary = summarize(results)
    lo, hi = summary["success_ci95"]
    print(
        f"{name}, stage {stage}: {100 * summary['success_rate']:.1f} % "
        f"({100 * lo:.1f}-{100 * hi:.1f}) of {len(results)} tasks, {summary['dropped']} dropped; {time.time() - t0:.0f} s"
    )
    report = {**settings, **summary}
    report["episodes"] = [r.to_dict() for r in results]
    if baseline:
        pair = paired_with(report["episodes"], json.loads(open(baseline).read())["episodes"])
        print(
            f"the baseline ({baseline}) on the same {pair['tasks']} tasks: {100 * pair['baseline_success_rate']:.1f} %; solved only "
            f"by this planner: {pair['only_run']}, only by the baseline: {pair['only_baseline']} (McNemar p = {pair['p']:.3f})"
        )
        report["baseline"] = {"file": baseline, **pair}
    if out:
        with open(out, "w") as f:
            json.dump(report, f, indent=1)
    return report


if __name__ == "__main__":
    main()
