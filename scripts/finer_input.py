"""Turn a trained network into a ``"fine"`` one (128 x 128 input over the same window) that starts
as it: ``occrl.modules.with_finer_input`` (the same outputs as the original on the image's even
rows and columns), saved
as a weights file to train from (``occrl train --net-preset fine --init-weights OUT [--detail-lr R]``).

    python scripts/finer_input.py --weights occnet-takeover --out ~/occrl-runs/occnet-takeover-fine.pt
"""

from __future__ import annotations

import argparse

from occrl.modules import with_finer_input
from occrl.modules.weights import load_weights, save_weights
from occrl.pretrained import weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", required=True, help="a weights file or a shipped network's name (a paper network)")
    parser.add_argument("--detail-channels", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0, help="draws the detail branch's first conv")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    source = weights_file(args.weights)
    fine = with_finer_input(load_weights(source), args.detail_channels, args.seed)
    save_weights(args.out, fine, meta={"finer_input_from": str(args.weights), "detail_channels": args.detail_channels, "seed": args.seed})
    print(
        f"{args.out}: {fine.config.image_size} x {fine.config.image_size} input, detail branch of {args.detail_channels} channels, from {args.weights}"
    )


if __name__ == "__main__":
    main()
