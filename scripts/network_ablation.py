"""A trained network with one of its heads put back to its untrained state: which part of the
network a planner's success rests on.

The hybrid planner reads three heads of the same network: the policy (the roll-outs' actions), the
value (the roll-outs' returns at the horizon) and the heat-map (the roots while the target is
hidden). Over 24 networks its success hardly followed the network's own policy
(``scripts/planner_vs_policy.py``); putting one head back to a freshly initialised one (the
network's own configuration, the initialisation :func:`occrl.modules.make_occnet` gives under
``--seed``), everything else as trained, says what each head is worth to it:

    python scripts/network_ablation.py --weights occnet-takeover --part policy --out W.pt
    occrl eval --method hybrid-4x4 --stage 2 --tasks 100 --workers 1 --weights W.pt --out F.json

``--part`` is ``policy`` (the actor head: means and spreads of the actions), ``value`` (the critic
head) or ``heatmap`` (the heat-map head); the encoder, the LSTM and the other heads keep their
trained weights, and batch-norm statistics stay the trained network's.
"""

from __future__ import annotations

import argparse

import torch

from occrl.modules import make_occnet
from occrl.modules.weights import load_weights, save_weights
from occrl.pretrained import network_name, weights_file

# each part's module in OccNet
PARTS = {"policy": "actor", "value": "critic", "heatmap": "heatmap_head"}


def untrained_part(net, part: str, seed: int):
    """``net`` with the head ``part`` (a key of :data:`PARTS`) replaced, in place, by the same head
    of a freshly initialised network of ``net``'s configuration (``torch.manual_seed(seed)``
    before :func:`make_occnet`). Returns ``net``."""
    if part not in PARTS:
        raise ValueError(f"unknown part {part!r}; one of {', '.join(PARTS)}")
    if part == "heatmap" and not net.config.heatmap:
        raise ValueError("this network has no heat-map head (config.heatmap is False)")
    torch.manual_seed(seed)
    fresh = make_occnet(net.config, heatmap=net.config.heatmap)
    getattr(net, PARTS[part]).load_state_dict(getattr(fresh, PARTS[part]).state_dict())
    return net


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--weights", default="occnet", help="the trained network: a pretrained name or a weights file")
    parser.add_argument("--part", required=True, choices=sorted(PARTS), help="the head to put back to its untrained state")
    parser.add_argument("--seed", type=int, default=0, help="seeds the fresh head's initialisation")
    parser.add_argument("--out", required=True, help="weights file to write")
    args = parser.parse_args(argv)
    net = untrained_part(load_weights(weights_file(args.weights)), args.part, args.seed)
    note = f"scripts/network_ablation.py: {network_name(args.weights)} with an untrained {args.part} head (seed {args.seed})"
    save_weights(args.out, net, {"note": note})
    print(f"wrote {args.out} ({note})")


if __name__ == "__main__":
    main()
