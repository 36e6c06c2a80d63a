"""Does a wider or narrower sampled policy solve more? The network's own policy with its
standard deviation multiplied by K (a temperature), on the same held-out tasks.

    python scripts/policy_temperature.py --weights occnet-takeover --stage 2 --tasks 200 --spreads 0,0.5,1,1.5,2,3

Runs ``stochastic-gen`` (``NetPolicy(net, stochastic=True, spread=K)``) for each K on the held-out
task seeds (from 10,000,000) of the stage, seeded per task as ``occrl eval`` seeds it (K = 1 gives
``occrl eval --method stochastic-gen``'s episodes exactly; K = 0 is the mean action with the
sampler's generators, i.e. ``greedy`` on this network), and prints success per K with its 95 %
Wilson interval and, against K = 1, the tasks only one of the two solved and the exact McNemar
p-value. PPO shrinks the spread as it trains (docs/decisions.md, *The paper's PPO*); this says
whether the spread is what the policy's success depends on.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from occrl.baselines import NetPolicy
from occrl.envs.episodes import task_scenes
from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE, mcnemar_p, wilson_interval
from occrl.pretrained import network_name, weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: occnet)")
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=200)
    parser.add_argument("--spreads", default="0,0.5,1,1.5,2,3", help="comma-separated multipliers K of the standard deviation")
    parser.add_argument("--out", default=None, help="write every episode of every K to this JSON file")
    args = parser.parse_args()
    spreads = [float(k) for k in args.spreads.split(",")]
    if any(k < 0 for k in spreads) or 1.0 not in spreads:
        raise SystemExit(f"--spreads must be numbers >= 0 and include 1 (the reference), got {args.spreads!r}")
    if args.tasks < 1:
        raise SystemExit(f"--tasks must be >= 1, got {args.tasks}")
    weights = weights_file(args.weights)
    method = make_method("stochastic-gen", weights)
    seeds = [EVAL_SEED_BASE + i for i in range(args.tasks)]
    scenes = task_scenes(args.stage, seeds)
    solved: dict[float, list[bool]] = {}
    episodes = {}
    for k in spreads:
        policy = NetPolicy(method.policy.net, stochastic=True, spread=k)
        # batches of 16 worlds, as occrl eval runs them
        results = method.run_episodes(scenes, seeds, policy=policy)
        solved[k] = [r.success for r in results]
        episodes[str(k)] = [r.to_dict() for r in results]
    print(
        f"network {network_name(args.weights or 'occnet')}, stage {args.stage}, {args.tasks} held-out tasks: own sampled policy, standard deviation x K"
    )
    print("| K | success | 95 % interval | only K / only K = 1 | McNemar p |")
    print("| --- | --- | --- | --- | --- |")
    for k in spreads:
        n = sum(solved[k])
        lo, hi = wilson_interval(n, args.tasks)
        only_k = sum(a and not b for a, b in zip(solved[k], solved[1.0]))
        only_1 = sum(b and not a for a, b in zip(solved[k], solved[1.0]))
        versus = "- | -" if k == 1.0 else f"{only_k} / {only_1} | {mcnemar_p(only_k, only_1):.3f}"
        print(f"| {k:g} | {100 * n / args.tasks:.1f} % | {100 * lo:.1f}-{100 * hi:.1f} | {versus} |")
    if args.out:
        Path(args.out).write_text(
            json.dumps({"weights": args.weights, "stage": args.stage, "tasks": args.tasks, "episodes": episodes}, indent=1)
        )


if __name__ == "__main__":
    main()
