"""Does the hybrid planner choose better when each candidate action is scored by several continuations?

    python scripts/averaged_rollouts.py --stage 2 --tasks 100 --m 4 --k 4 [--h 4] [--weights W] [--baseline F.json] [--out F.json]

The paper's planner (Alg. 2) scores each of its m candidate first actions per root by one sampled
roll-out: the action's reward, then h - 1 more of the policy's sampled actions, then the value.
Where a success takes many favourable draws, one continuation says little about its first action
and the best of m is mostly the luckiest continuation (docs/decisions.md, *What the paper's
planner makes of its policy's samples*). This probe keeps the m first actions the policy samples
from each root and rolls each out ``k`` times, the continuations drawn independently after the
shared first action, and scores the action by the mean of its k returns: m x k roll-outs per
root, as many as the paper's planner with m x k candidates (``occrl eval --method
hybrid-{m*k}x{h}`` is the control with the same work). Roots, root selection, the network and its
value are the paper's; the planner is reseeded per task as `occrl eval` does, on the README's
held-out tasks. A diagnosis for issue 16, not a method of the papers.

Against another run on the same tasks (``--baseline``, an `occrl eval --out` file) it prints the
success of both, the tasks only one solved and the exact McNemar p-value.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch

from occrl.eval.methods import make_method
from occrl.planners import HybridPlanner, Root
from occrl.planners.rhp import RHPResult, noise_dim, rhp_batched, rhp_sequential
from occrl.pretrained import network_name, weights_file
from oracle_roots import report_planner_run  # scripts/, beside this one


class AveragedRolloutsPlanner(HybridPlanner):
    """The hybrid planner with each of its m first actions per root rolled out ``k`` times (the
    same first action, independent continuations) and scored by the mean of the k returns."""

    def __init__(self, net, k: int, **kwargs) -> None:
        super().__init__(net, **kwargs)
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
            raise ValueError(f"k must be an int >= 1, got {k!r}")
        self.k = int(k)

    def rollouts(self, roots: list[Root], hidden) -> RHPResult:
        R, m, k, h, d = len(roots), self.m, self.k, self.h, noise_dim(self.net)
        first = torch.randn(R, m, 1, 1, d, generator=self.generator)
        noise = torch.randn(R, m, k, h, d, generator=self.generator)
        noise[:, :, :, :1] = first.expand(R, m, k, 1, d)  # one first action per group of k roll-outs
        noise = noise.reshape(R, m * k, h, d)
        states = [r.state for r in roots]
        if self.batched:
            res = rhp_batched(self.net, states, hidden, noise, self.gamma, self.rollout_min_scale, pool=self.pool, stepper=self.stepper)
        else:
            res = rhp_sequential(self.net, states, hidden, noise, self.gamma, self.rollout_min_scale)
        returns = res.returns.reshape(R, m, k).mean(axis=2)
        first_actions = res.first_actions.reshape(R, m, k, -1)[:, :, 0]
        paths = None if res.paths is None else res.paths.reshape(R, m, k, h + 1, -1)[:, :, 0]
        best = returns.argmax(axis=1)
        rows = np.arange(R)
        return RHPResult(first_actions[rows, best], returns[rows, best], returns, first_actions, res.steps, paths)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--tasks", type=int, default=100)
    parser.add_argument("--m", type=int, default=4, help="candidate first actions per root")
    parser.add_argument("--k", type=int, default=4, help="continuations per candidate, their returns averaged")
    parser.add_argument("--h", type=int, default=4, help="roll-out depth")
    parser.add_argument("--weights", default=None, help="the planner's network: a weights file or a shipped name (default: occnet)")
    parser.add_argument("--baseline", default=None, help="an `occrl eval --out` file of a planner on the same tasks")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    method = make_method("hybrid-4x4", weights_file(args.weights))
    try:
        planner = AveragedRolloutsPlanner(method.policy.net, args.k, m=args.m, h=args.h)
    except ValueError as error:
        parser.error(str(error))
    name = f"hybrid {args.m}x{args.h}, each first action's {args.k} continuations averaged"
    settings = {"stage": args.stage, "m": args.m, "k": args.k, "h": args.h, "weights": network_name(args.weights or "occnet")}
    report_planner_run(method, planner, name, args.stage, args.tasks, settings, args.baseline, args.out)


if __name__ == "__main__":
    main()
