"""How wide is a network's stochastic policy? The hybrid planner's roll-outs sample from it.

    python scripts/policy_spread.py                                   # the shipped occnet
    python scripts/policy_spread.py --weights checkpoints/expert-iteration-seed0/weights.pt

Runs the network's own sampled policy on 16 tasks per stage (task seeds from 50,000,000, apart
from the held-out and validation ranges) and prints the mean and median standard deviation of
the policy per action dimension (forward, lateral, rotation, gripper) over the visited frames.
The planner picks the best of m roll-outs that start with m draws from this distribution: when
the spread is small the m candidates are nearly the same action and there is nothing to choose.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch
from torchrl.modules import set_recurrent_mode

from occrl.eval.methods import make_method
from occrl.eval.runner import rollout_tasks
from occrl.pretrained import network_name, weights_file

SPREAD_SEED_BASE = 50_000_000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default=None, help="weights file or shipped network name (default: occnet)")
    parser.add_argument("--tasks", type=int, default=16, help="tasks per stage")
    args = parser.parse_args()

    args.weights = weights_file(args.weights)
    method = make_method("stochastic-gen", args.weights)
    net = method.policy.net  # the network the sampled policy runs
    head = net.actor.module[0]  # writes "loc" and "scale" from "belief"
    print(f"network {network_name(args.weights or 'occnet')}: policy standard deviation (forward, lateral, rotation, gripper)")
    for stage in (1, 2, 3):
        seeds = list(range(SPREAD_SEED_BASE, SPREAD_SEED_BASE + args.tasks))
        td = rollout_tasks(method, stage, seeds)
        with torch.no_grad(), set_recurrent_mode(True):
            out = head(net.trunk(td.select("pixels", "is_init").copy()))
        done = td["next", "done"][..., 0]
        alive = (done.cumsum(1) - done.long()) == 0  # frames up to and including each episode's last
        scale = out["scale"][alive].numpy()
        print(f"  stage {stage}: mean {np.round(scale.mean(0), 3)}, median {np.round(np.median(scale, 0), 3)} over {len(scale)} frames")


if __name__ == "__main__":
    main()
