"""Convolution speed of the encoder and heat-map decoder, contiguous vs channels-last activations.

Usage:
    python benchmarks/encoder_speed.py [--threads 1]

Prints median milliseconds for inference on planner-sized batches (1, 4, 12 images) and for a
training step (forward + backward) on a minibatch of 500 frames, and the largest difference between
the two layouts' outputs. occrl's ConvEncoder and HeatmapHead use channels-last activations.
"""

from __future__ import annotations

import argparse
import time

import torch

from occrl.modules import ConvEncoder
from occrl.modules.heads import HeatmapHead


def median_ms(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return sorted(times)[len(times) // 2] * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    enc = ConvEncoder().eval()
    layers = enc.net  # the module without occrl's layout conversion

    def contiguous(x):
        return layers(x).reshape(x.shape[0], -1)

    def channels_last(x):
        return layers(x.contiguous(memory_format=torch.channels_last)).reshape(x.shape[0], -1)

    print(f"torch threads {args.threads}")
    with torch.no_grad():
        for n in (1, 4, 12):
            x = torch.rand(n, 3, 64, 64)
            a, b = median_ms(lambda: contiguous(x), 50), median_ms(lambda: channels_last(x), 50)
            diff = (contiguous(x) - channels_last(x)).abs().max().item()
            print(
                f"encoder inference, {n:>3} images: contiguous {a:6.2f} ms, channels-last {b:6.2f} ms ({a / b:.1f}x), max diff {diff:.1e}"
            )
    enc.train()
    x = torch.rand(500, 3, 64, 64)
    for name, f in (("contiguous", contiguous), ("channels-last", channels_last)):
        print(f"encoder training step, 500 frames, {name}: {median_ms(lambda: f(x).square().mean().backward(), 5):.0f} ms")
    head = HeatmapHead(128).train()
    belief = torch.rand(125, 128)

    def decode(layout):
        h = head.project(belief).reshape(-1, head.c0, head.side, head.side)
        return head.decode(h.contiguous(memory_format=layout))

    for name, layout in (("contiguous", torch.contiguous_format), ("channels-last", torch.channels_last)):
        print(
            f"heat-map decoder training step, 125 frames, {name}: {median_ms(lambda: decode(layout).square().mean().backward(), 5):.0f} ms"
        )


if __name__ == "__main__":
    main()
