"""Turn a trained network into one whose policy is a mixture of Gaussians and that starts as it
(``occrl.modules.with_mixture_policy``: every component a copy of the Gaussian policy, the means
offset by a little noise), saved as a weights file to train from
(``occrl train --net-preset mixture --init-weights OUT``; ``--components`` other than 4 needs a
matching network preset).

    python scripts/mixture_policy.py --weights occnet-takeover --out ~/occrl-runs/occnet-takeover-mixture.pt
"""

from __future__ import annotations

import argparse

from occrl.modules import with_mixture_policy
from occrl.modules.weights import load_weights, save_weights
from occrl.pretrained import weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", required=True, help="a weights file or a shipped network's name (a paper network)")
    parser.add_argument("--components", type=int, default=4)
    parser.add_argument("--spread", type=float, default=0.05, help="standard deviation of the components' mean offsets (before the tanh)")
    parser.add_argument("--seed", type=int, default=0, help="draws the offsets")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    mixture = with_mixture_policy(load_weights(weights_file(args.weights)), args.components, args.spread, args.seed)
    meta = {"mixture_policy_from": str(args.weights), "components": args.components, "spread": args.spread, "seed": args.seed}
    save_weights(args.out, mixture, meta=meta)
    print(f"{args.out}: policy a mixture of {args.components} Gaussians (offsets {args.spread}), from {args.weights}")


if __name__ == "__main__":
    main()
