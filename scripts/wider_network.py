"""Turn a trained paper network into a wider one that computes the same (the ``"wide"`` preset).

    python scripts/wider_network.py --weights occnet-takeover --out W.pt
    occrl train ... --net-preset wide --init-weights W.pt

:func:`occrl.modules.with_wider_network`: twice the channels (16-16-32), LSTM units (256) and
hidden units (policy 256-256, value 256-128); the trained weights in the leading blocks, the new
units read by nothing until training gives them weight. Prints the parameter counts and checks
that both networks choose the same actions on a few stage-2 observations.
"""

from __future__ import annotations

import argparse

import torch

from occrl.baselines import NetPolicy
from occrl.envs import make_env
from occrl.modules import PRESETS, with_wider_network
from occrl.modules.weights import load_weights, save_weights
from occrl.pretrained import network_name, weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--weights", default="occnet-takeover", help="weights file or shipped network name")
    parser.add_argument("--out", required=True, help="where to write the wider network's weights")
    parser.add_argument("--seed", type=int, default=0, help="seeds the new units' random fan-in")
    args = parser.parse_args()
    net = load_weights(weights_file(args.weights))
    wide_cfg = PRESETS["wide"]
    wide = with_wider_network(
        net, wide_cfg.conv_channels, wide_cfg.lstm_hidden, wide_cfg.policy_hidden, wide_cfg.value_hidden, seed=args.seed
    )
    actions = []
    for n in (net, wide):
        env = make_env(batch_size=4, stage=2, seed=[1, 2, 3, 4], heatmap_target=False).append_transform(n.make_primer())
        policy = NetPolicy(n, stochastic=True)
        policy.reseed_worlds([1, 2, 3, 4])
        with torch.no_grad():
            actions.append(env.rollout(20, policy, break_when_any_done=False)["action"])
    gap = float((actions[0] - actions[1]).abs().max())
    save_weights(args.out, wide, {"widened_from": network_name(args.weights), "seed": args.seed})
    print(
        f"{network_name(args.weights)}: {net.num_parameters():,} parameters -> {wide.num_parameters():,}; "
        f"largest action difference over 4 x 20 stage-2 steps {gap:.1e}; wrote {args.out}"
    )


if __name__ == "__main__":
    main()
