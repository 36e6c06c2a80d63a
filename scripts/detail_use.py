"""How much does a ``"fine"`` network read the detail of its 128 x 128 image?

    python scripts/detail_use.py --weights RUN/weights.pt [--tasks 8] [--steps 20]

It runs the network's own policy on the first held-out stage-2 tasks and, for every image it
saw, compares the policy's mean action (one step from a fresh LSTM state) on the image with that
on its even pixels repeated 2 x 2 (what the paper's encoder reads): the mean absolute difference,
against the actions' mean size. 0 for a network just converted by
``occrl.modules.with_finer_input``; it grows as the detail branch learns (its last conv's mean
absolute weight is printed too).
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch
from tensordict import TensorDict

from occrl.eval.methods import make_method
from occrl.eval.runner import EVAL_SEED_BASE, rollout_tasks
from occrl.pretrained import weights_file


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", required=True, help="a fine network's weights file")
    parser.add_argument("--tasks", type=int, default=8)
    parser.add_argument("--steps", type=int, default=20)
    args = parser.parse_args()
    method = make_method("stochastic-gen", weights_file(args.weights))
    net = method.policy.net
    if not net.config.detail_channels:
        raise SystemExit(f"{args.weights} is not a fine network (it has no detail branch)")
    images = rollout_tasks(method, 2, list(range(EVAL_SEED_BASE, EVAL_SEED_BASE + args.tasks)), steps=args.steps)["pixels"]
    images = images.reshape(-1, *images.shape[-3:])
    even = images[..., ::2, ::2].repeat_interleave(2, -1).repeat_interleave(2, -2)

    def mean_action(pixels: torch.Tensor) -> torch.Tensor:
        inputs = TensorDict({"pixels": pixels, "is_init": torch.ones(len(pixels), 1, dtype=torch.bool)}, [len(pixels)])
        with torch.no_grad():
            return net.policy(inputs)["loc"]

    full, coarse = mean_action(images), mean_action(even)
    difference, size = float((full - coarse).abs().mean()), float(full.abs().mean())
    weight = float(net.encoder.module.detail[2].weight.detach().abs().mean())
    print(
        f"{len(images)} images: mean |action(image) - action(even pixels)| {difference:.4f} against mean |action| {size:.3f} "
        f"({100 * difference / size:.1f} %); detail branch's last conv mean |weight| {weight:.4f}"
    )


if __name__ == "__main__":
    main()
