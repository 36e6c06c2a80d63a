"""Print what the hybrid planner weighed at each step of one task: roots, roll-out returns, first actions.

    python scripts/planner_decisions.py --stage 2 --seed 10000083 --steps 12

For each decision: the gripper's depth (y < 0 is outside the shelf), the number of roots, the
chosen action, and per root the m roll-outs' returns with the forward component of their first
actions. Roll-outs from the same state whose returns differ by tens while their first actions
point both ways are a planner choosing on noise (docs/experiments.md, *Why stage 2 stops here*).
"""

from __future__ import annotations

import argparse

import numpy as np

from occrl.eval.methods import make_method
from occrl.eval.runner import rollout_tasks
from occrl.pretrained import weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--method", default="hybrid-4x4", choices=["hybrid-2x2", "hybrid-4x4", "hybrid-6x6", "hybrid-lim-4x4"])
    parser.add_argument("--stage", type=int, default=2, choices=[1, 2, 3])
    parser.add_argument("--seed", type=int, default=10_000_083, help="task seed (held-out ones start at 10,000,000)")
    parser.add_argument("--steps", type=int, default=12)
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: occnet)")
    args = parser.parse_args()

    method = make_method(args.method, weights_file(args.weights))
    td = rollout_tasks(method, args.stage, [args.seed], steps=args.steps)
    np.set_printoptions(precision=1, suppress=True)
    for t, decision in enumerate(method.policy.decisions):
        result = decision.result
        print(
            f"step {t}: gripper y {float(td['gripper_pose'][0, t, 1]):+.3f} m, {len(decision.roots)} root(s), "
            f"root {decision.chosen_root} chosen, action {decision.action}"
        )
        for r in range(result.returns.shape[0]):
            spread = result.returns[r].max() - result.returns[r].min()
            print(
                f"    root {r}: returns {result.returns[r]} (spread {spread:.1f}), first forward commands {result.first_actions[r, :, 0]}"
            )


if __name__ == "__main__":
    main()
