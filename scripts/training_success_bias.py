"""How far off is a training success rate that counts every finished episode of a batch?

    python scripts/training_success_bias.py --weights occnet-ei --stage 2

Collects one batch as the trainer does (``--envs`` worlds reset together, 50 steps each, a
world that finishes starts a new episode) with the network's own sampled policy, and prints the
success rate two ways: over every finished episode (what the trainer logged before 2026-11-22)
and over each world's first episode only (``occrl.training.episode_stats`` now). A second episode
fits in the batch only when it is short, and short episodes are mostly successes.
"""

from __future__ import annotations

import argparse

import numpy as np

from occrl.envs import world_constants as C
from occrl.eval.methods import make_method
from occrl.eval.runner import rollout_tasks
from occrl.pretrained import weights_file
from occrl.training import episode_stats

BIAS_SEED_BASE = 60_000_000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default="occnet", help="a weights file or a shipped network's name")
    parser.add_argument("--stage", type=int, default=2, choices=[1, 2, 3])
    parser.add_argument("--envs", type=int, default=128)
    args = parser.parse_args()

    weights = weights_file(args.weights)
    method = make_method("stochastic-gen", weights)
    seeds = list(range(BIAS_SEED_BASE, BIAS_SEED_BASE + args.envs))
    data = rollout_tasks(method, args.stage, seeds)
    done = data.get(("next", "done")).squeeze(-1).numpy()
    success = data.get(("next", "success")).squeeze(-1).numpy()
    every = [bool(success[b, t]) for b in range(done.shape[0]) for t in np.flatnonzero(done[b])]
    first = episode_stats(data)["success"]
    print(
        f"{args.weights}, stage {args.stage}, {args.envs} worlds x {C.MAX_EPISODE_STEPS} steps: "
        f"every finished episode {np.mean(every):.1%} ({len(every)} episodes), "
        f"first episode per world {np.mean(first):.1%} ({len(first)} episodes)"
    )


if __name__ == "__main__":
    main()
