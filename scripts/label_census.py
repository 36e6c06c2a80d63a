"""What the observation-only clearing teacher says on the learner's own states.

    python scripts/label_census.py [--weights occnet-takeover] [--worlds 8] [--stage 2] [--seed 5]

The network's sampled policy acts in a batch of worlds for 50 steps; the observed clearing
retriever (``occrl.baselines.observed_clearing``) labels every frame from the first sight of the
target on, as DAgger would (``OnlineTeacherPolicy(from_first_sight=True)`` with beta = 0). Prints
the share of those labels that are "back out" ([-1, 0, 0, open]: the scripted approach backs
out whenever the gripper is inside the shelf and not lined up with its plan) or "hold still",
and the mean label against the learner's mean action. A diagnosis for issue 16
(docs/decisions.md: trained on such labels the learner learned to back out).
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from occrl.baselines.observed_clearing import ObservedClearingRetriever
from occrl.envs import make_env
from occrl.modules.weights import load_weights
from occrl.pretrained import weights_file
from occrl.training.dagger import OnlineTeacherPolicy, since_first_sight

BACK_OUT = [-1.0, 0.0, 0.0, -1.0]
HOLD_STILL = [0.0, 0.0, 0.0, -1.0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", default="occnet-takeover", help="weights file or shipped network name")
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--stage", type=int, default=2, choices=(1, 2, 3))
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(args.seed)
    net = load_weights(weights_file(args.weights))
    env = make_env(batch_size=args.worlds, stage=args.stage, seed=args.seed).append_transform(net.make_primer())
    policy = OnlineTeacherPolicy(net.policy, ObservedClearingRetriever(), beta=0.0, from_first_sight=True)
    with set_exploration_type(ExplorationType.RANDOM), torch.no_grad():
        data = env.rollout(50, policy, break_when_any_done=False)
    labelled = since_first_sight(data)
    labels, actions = data["expert_action"][labelled].numpy(), data["action"][labelled].numpy()
    print(f"{args.worlds} worlds x 50 steps, stage {args.stage}: {int(labelled.sum())} of {labelled.numel()} frames after the first sight")
    print(
        f"labels that back out: {np.all(np.isclose(labels, BACK_OUT), axis=1).mean():.2f}; hold still: {np.all(np.isclose(labels, HOLD_STILL), axis=1).mean():.2f}"
    )
    print(
        f"mean label {[round(float(v), 2) for v in labels.mean(0)]}, the learner's mean action {[round(float(v), 2) for v in actions.mean(0)]}"
    )


if __name__ == "__main__":
    main()
