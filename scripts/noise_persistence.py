"""Does the network's own policy lack commitment? Its sampling noise held across actions.

    python scripts/noise_persistence.py --weights occnet-takeover --stage 2 --tasks 200 --rhos 0,0.5,0.8,0.9,0.95
    python scripts/noise_persistence.py --weights occnet-takeover --rhos 0,0.5,0.8,0.9 --match-drift

``stochastic-gen`` on the held-out tasks, its normal draws made an AR(1) process per world
(``NetPolicy(..., noise_correlation=rho)``): ``z_t = rho z_{t-1} + sqrt(1 - rho^2) x_t`` (x_t the
policy's own draws, from the same per-task generators; a mixture policy's component draw is
carried the same way through its normal quantile), restarted at every episode start. Each action's distribution stays the policy's;
only successive actions share their draw, so with rho near 1 the policy keeps to one sampled
"plan" for many actions. rho = 0 is ``occrl eval --method stochastic-gen`` exactly; negative rho
makes successive draws cancel. ``--match-drift`` scales the spread by sqrt((1 - rho) / (1 + rho)),
so that the sum of many draws (how far the noise carries the gripper off the mean path) is as
wide as with rho = 0: persistence without more drift. Prints success per rho with its 95 %
Wilson interval and, against the first rho, exclusive tasks and the exact McNemar p-value.
"""

from __future__ import annotations

import argparse
import json
import math
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
    parser.add_argument(
        "--rhos", default="0,0.5,0.8,0.9,0.95", help="comma-separated AR(1) coefficients in (-1, 1); the first is the reference"
    )
    parser.add_argument("--match-drift", action="store_true", help="scale the draws by sqrt((1 - rho) / (1 + rho))")
    parser.add_argument("--out", default=None, help="write which tasks each rho solved to this JSON file")
    args = parser.parse_args()
    rhos = [float(r) for r in args.rhos.split(",")]
    if any(not -1 < r < 1 for r in rhos):
        raise SystemExit(f"--rhos must lie in (-1, 1), got {args.rhos!r}")
    if args.tasks < 1:
        raise SystemExit(f"--tasks must be >= 1, got {args.tasks}")
    method = make_method("stochastic-gen", weights_file(args.weights))
    seeds = [EVAL_SEED_BASE + i for i in range(args.tasks)]
    scenes = task_scenes(args.stage, seeds)
    solved: dict[float, list[bool]] = {}
    print(
        f"network {network_name(args.weights or 'occnet')}, stage {args.stage}, {args.tasks} held-out tasks: own sampled policy, "
        f"AR(1) noise{' (drift matched)' if args.match_drift else ''}"
    )
    print(f"| rho | success | 95 % interval | only rho / only rho = {rhos[0]:g} | McNemar p |")
    print("| --- | --- | --- | --- | --- |")
    for rho in rhos:
        spread = math.sqrt((1 - rho) / (1 + rho)) if args.match_drift else 1.0
        policy = NetPolicy(method.policy.net, stochastic=True, spread=spread, noise_correlation=rho)
        results = method.run_episodes(scenes, seeds, policy=policy)
        solved[rho] = [r.success for r in results]
        n = sum(solved[rho])
        lo, hi = wilson_interval(n, args.tasks)
        mine = sum(a and not b for a, b in zip(solved[rho], solved[rhos[0]]))
        theirs = sum(b and not a for a, b in zip(solved[rho], solved[rhos[0]]))
        versus = "- | -" if rho == rhos[0] else f"{mine} / {theirs} | {mcnemar_p(mine, theirs):.3f}"
        print(f"| {rho:g} | {100 * n / args.tasks:.1f} % | {100 * lo:.1f}-{100 * hi:.1f} | {versus} |", flush=True)
    if args.out:
        Path(args.out).write_text(
            json.dumps(
                {
                    "weights": args.weights,
                    "stage": args.stage,
                    "match_drift": args.match_drift,
                    "solved": {str(k): v for k, v in solved.items()},
                }
            )
        )


if __name__ == "__main__":
    main()
