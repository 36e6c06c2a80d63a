"""How often the hybrid planner takes the OMPL proposal among its roll-outs, and why not.

    python scripts/proposal_uptake.py --stage 2 --tasks 50 --out results/diagnosis/proposal_uptake_s2.json

Runs ``hybrid-ompl-MxH`` (:class:`occrl.baselines.hybrid_ompl.HybridOMPLPlanner`) on the first
held-out tasks of a stage, one task at a time and seeded as ``occrl eval`` seeds them (the same
episodes), and sums up its decisions' :class:`~occrl.baselines.hybrid_ompl.ProposalRecord`:
per kind of proposal (what the hierarchical planner was doing: search, move_out, reach, extract,
rearrange_reach, place) the number of decisions, the share in which the proposal's roll-out was
the chosen root's best (its action executed), and the mean of (best policy roll-out's return -
the proposal's return) from the chosen root: how far the network's value puts the plan below its
own policy. With ``--compare`` (a result file of the same tasks, e.g. hybrid 4x4) it counts the
tasks solved by one and not the other.

The proposer's OMPL queries are bounded in wall time (1 s), as the hierarchical baseline's are,
so an episode repeats ``occrl eval``'s exactly only while every query ends the same within its
budget: under a different load a few episodes differ (1 of 50 stage-2 tasks in the recorded run).
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np

from occrl.envs.episodes import task_scenes
from occrl.eval.methods import make_method, ompl_hybrid_setting
from occrl.eval.runner import EVAL_SEED_BASE
from occrl.pretrained import weights_file


def uptake(records) -> dict:
    """Per kind (and "all"): decisions, share taken, mean and median return gap (policy - proposal)."""
    by_kind = defaultdict(list)
    for r in records:
        by_kind[r.kind].append(r)
        by_kind["all"].append(r)
    table = {}
    for kind, rs in sorted(by_kind.items(), key=lambda kv: (kv[0] != "all", kv[0])):
        gap = np.array([r.policy_return - r.proposal_return for r in rs])
        table[kind] = {
            "decisions": len(rs),
            "taken": float(np.mean([r.taken for r in rs])),
            "mean_gap": float(gap.mean()),
            "median_gap": float(np.median(gap)),
        }
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--method", default="hybrid-ompl-4x4", help="a hybrid-ompl-MxH name")
    parser.add_argument("--stage", type=int, default=2, choices=[1, 2, 3])
    parser.add_argument("--tasks", type=int, default=50, help="the first TASKS held-out tasks of the stage")
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: occnet)")
    parser.add_argument(
        "--compare", default=None, help="a result JSON of the same tasks (occrl eval --out) to count exclusive wins against"
    )
    parser.add_argument(
        "--replan-inside",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="the proposer plans from inside the shelf instead of backing out to search (the default; "
        "--no-replan-inside: it backs out, as in the runs recorded before 2026-12-03's second session)",
    )
    parser.add_argument(
        "--proposal-bonus",
        type=float,
        default=0.0,
        help="added to the proposal roll-out's return before the comparison (HybridOMPLPlanner(proposal_bonus=); default 0)",
    )
    parser.add_argument("--out", default=None, help="write the figures as JSON here")
    args = parser.parse_args()
    if ompl_hybrid_setting(args.method) is None:
        parser.error(f"--method must be a hybrid-ompl-MxH name, got {args.method!r}")
    if args.tasks < 1:
        parser.error(f"--tasks must be >= 1, got {args.tasks}")
    if not np.isfinite(args.proposal_bonus):
        parser.error(f"--proposal-bonus must be a finite number, got {args.proposal_bonus}")

    method = make_method(args.method, weights_file(args.weights))
    planner = method.policy
    planner.proposer.replan_inside = args.replan_inside
    planner.proposal_bonus = args.proposal_bonus
    seeds = [EVAL_SEED_BASE + i for i in range(args.tasks)]
    records, solved, actions = [], {}, {}
    for seed in seeds:
        planner.decisions.clear()
        planner.proposals.clear()
        [result] = method.run_episodes(task_scenes(args.stage, [seed]), [seed], batch_size=1, policy=planner)
        records += planner.proposals
        solved[seed] = bool(result.success)
        actions[seed] = int(result.actions)
        taken = sum(r.taken for r in planner.proposals)
        print(
            f"task {seed}: {'solved' if result.success else 'failed'} in {result.actions} actions, proposal taken {taken} of {len(planner.proposals)}"
        )
    report = {
        "method": args.method,
        "stage": args.stage,
        "tasks": args.tasks,
        "network": method.network,
        "replan_inside": args.replan_inside,
        "proposal_bonus": args.proposal_bonus,
        "success_rate": float(np.mean(list(solved.values()))),
        "uptake": uptake(records),
        "solved": {str(s): v for s, v in solved.items()},
        "actions": {str(s): v for s, v in actions.items()},
    }
    if args.compare:
        other = {e["seed"]: bool(e["success"]) for e in json.load(open(args.compare))["episodes"]}
        missing = [s for s in seeds if s not in other]
        if missing:
            raise SystemExit(f"{args.compare} lacks {len(missing)} of the tasks (first {missing[0]}); compare results of the same tasks")
        report["compare"] = {
            "file": args.compare,
            "its_success_rate": float(np.mean([other[s] for s in seeds])),
            "only_this": sum(solved[s] and not other[s] for s in seeds),
            "only_it": sum(other[s] and not solved[s] for s in seeds),
        }
    print(f"{args.method}, stage {args.stage}, {args.tasks} tasks: success {report['success_rate']:.1%}")
    print(f"{'proposal kind':16s} {'decisions':>9s} {'taken':>7s} {'policy - proposal (mean / median)':>36s}")
    for kind, row in report["uptake"].items():
        print(f"{kind:16s} {row['decisions']:9d} {row['taken']:7.1%} {row['mean_gap']:18.1f} / {row['median_gap']:.1f}")
    if "compare" in report:
        c = report["compare"]
        print(
            f"against {c['file']} ({c['its_success_rate']:.1%} on these tasks): solved only here {c['only_this']}, only there {c['only_it']}"
        )
    if args.out:
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
