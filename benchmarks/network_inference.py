"""The roll-outs' network call (one LSTM step: encoder, LSTM, policy head) on each inference path,
side by side, at the batch sizes RHP uses.

Usage:
    python benchmarks/network_inference.py [--calls 300] [--threads 1]

Paths: the TensorDict modules (``net.trunk`` + the policy head, what the planner called before
0.2), the torch modules called directly under ``torch.no_grad`` and under
``torch.inference_mode`` (:class:`occrl.planners.rhp.NetworkStepper`, the planner's path), a
frozen TorchScript trace (batch norm folded into the convolutions), ``torch.compile``, and ONNX
Runtime (needs ``pip install onnx onnxruntime``; skipped without them). For each: microseconds per
call at batch 1, 4 and 12 (one root; one and three roots x 4 roll-outs) and the largest
difference of ``loc`` from the TensorDict path (0 means bit for bit). Uses the shipped network.
Times are relative: compare the rows of one run.
"""

from __future__ import annotations

import argparse
import copy
import os
import tempfile
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import torch
from tensordict import TensorDict

from occrl.planners.rhp import NetworkStepper, StepGraph
from occrl.modules.weights import load_weights
from occrl.pretrained import weights_file

BATCHES = (1, 4, 12)


class PolicyStep(torch.nn.Module):
    """The roll-outs' call without the value head (the planner asks for values only at the horizon)."""

    def __init__(self, graph: StepGraph) -> None:
        super().__init__()
        self.graph = graph

    def forward(self, pixels, h, c):
        return self.graph.step(pixels, h, c)


def timed(fn, calls: int) -> float:
    for _ in range(10):
        fn()
    t = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t) / calls * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=300)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument(
        "--weights", default="occnet", help="a weights file or a shipped network's name (occnet-warmstart: the default before 0.3.0)"
    )
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    net = load_weights(weights_file(args.weights))
    stepper = NetworkStepper(net)
    head = net.actor.module[0]
    module = PolicyStep(StepGraph(copy.deepcopy(net))).eval()  # a copy: tracing and compiling leave the planner's net alone
    paths: dict[str, dict[int, tuple[float, float]]] = {}

    def add(name: str, batch: int, fn, loc_of, reference) -> None:
        with torch.inference_mode():
            err = float((loc_of(fn()) - reference).abs().max())
        paths.setdefault(name, {})[batch] = (timed(fn, args.calls), err)

    try:
        import onnxruntime as ort
    except ImportError:
        ort = None
    onnx_file = None
    for batch in BATCHES:
        g = torch.Generator().manual_seed(batch)
        pixels = torch.rand(batch, 3, 64, 64, generator=g)
        h, c = torch.randn(batch, 1, 128, generator=g), torch.randn(batch, 1, 128, generator=g)
        hl, cl = h.transpose(0, 1).contiguous(), c.transpose(0, 1).contiguous()
        td = TensorDict(
            {"pixels": pixels, "recurrent_state_h": h, "recurrent_state_c": c, "is_init": torch.zeros(batch, 1, dtype=torch.bool)}, [batch]
        )

        def tensordict_path():
            with torch.no_grad():
                return head(net.trunk(td.clone(False)))

        reference = tensordict_path().get("loc")
        add("TensorDict modules (before 0.2)", batch, tensordict_path, lambda out: out.get("loc"), reference)

        def eager_no_grad():
            with torch.no_grad():
                return module(pixels, hl, cl)

        add("torch modules, no_grad", batch, eager_no_grad, lambda out: out[1], reference)
        add("torch modules, inference_mode (planner)", batch, lambda: stepper.step(pixels, h, c), lambda out: out[0]["loc"], reference)
        with torch.no_grad():
            frozen = torch.jit.freeze(torch.jit.trace(module, (pixels, hl, cl)))
        add("TorchScript, traced + frozen", batch, lambda: frozen(pixels, hl, cl), lambda out: out[1], reference)
        try:
            compiled = torch.compile(module, dynamic=False)
            with torch.inference_mode():
                compiled(pixels, hl, cl)  # compile outside the timing
            add("torch.compile", batch, lambda: compiled(pixels, hl, cl), lambda out: out[1], reference)
        except Exception as err:  # no C compiler, unsupported platform
            print(f"torch.compile unavailable: {type(err).__name__}: {str(err)[:120]}")
        if ort is not None:
            if onnx_file is None:
                onnx_file = os.path.join(tempfile.mkdtemp(), "step.onnx")
                torch.onnx.export(
                    module,
                    (pixels, hl, cl),
                    onnx_file,
                    input_names=["pixels", "h", "c"],
                    output_names=["belief", "loc", "scale", "h_next", "c_next"],
                    dynamic_axes={"pixels": {0: "b"}, "h": {1: "b"}, "c": {1: "b"}},
                    dynamo=False,
                )
                options = ort.SessionOptions()
                options.intra_op_num_threads = args.threads
                options.inter_op_num_threads = 1
                session = ort.InferenceSession(onnx_file, options, providers=["CPUExecutionProvider"])
            feed = {"pixels": pixels.numpy(), "h": hl.numpy(), "c": cl.numpy()}
            add("ONNX Runtime", batch, lambda: session.run(["loc"], feed), lambda out: torch.from_numpy(out[0]), reference)
    print(f"one LSTM step of the shipped network, {args.threads} thread(s), {args.calls} calls per cell")
    print("| path | " + " | ".join(f"batch {b}: us (max |dloc|)" for b in BATCHES) + " |")
    print("| --- |" + " --- |" * len(BATCHES))
    for name, cells in paths.items():
        print(f"| {name} | " + " | ".join(f"{cells[b][0]:.0f} ({cells[b][1]:.1e})" for b in BATCHES if b in cells) + " |")
    if ort is None:
        print("ONNX Runtime: not installed (pip install onnx onnxruntime)")


if __name__ == "__main__":
    main()
