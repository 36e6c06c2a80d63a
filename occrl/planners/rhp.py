"""Receding-horizon planning with an occlusion-aware heuristic (paper Alg. 2).

From every root state, ``m`` roll-outs of depth ``h`` follow the stochastic policy from the LSTM
state of the real history, in nominal pymunk worlds that render their own observations (only
objects more than 50 % visible in the roll-out's camera are drawn). A roll-out's return is
``sum_j gamma^(j-1) r_j + gamma^h V`` (no bootstrap after a terminal state). RHP returns, per
root, the first action of the best roll-out and its return. Sampled actions are clipped to
[-1, 1] (the env would clip them anyway).

:func:`rhp_batched` advances all roots x roll-outs in lock-step with one network call per depth
step; :func:`rhp_sequential` is the plain Alg. 2, kept as the reference it is tested against.
Both draw the policy's noise from the same tensor, so with the same seed they choose alike.
"""

from __future__ import annotations

import io
import warnings
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import torch

from occrl.envs import world_constants as C
from occrl.envs.observation import world_pixels
from occrl.envs.robot_frame import DEFAULT_SIZE
from occrl.envs.pymunk2d.world import ShelfWorld
from occrl.modules.occnet import POLICY_OUTPUTS, OccNet
from occrl.planners.recreate import RecreatedState, WorldPool, make_world

__all__ = ["RHPResult", "rhp_batched", "rhp_sequential", "render_pixels", "NetworkStepper", "StepGraph", "INFERENCE_BACKENDS"]


def render_pixels(worlds: Sequence[ShelfWorld], size: int = DEFAULT_SIZE) -> torch.Tensor:
    """The network input each world's camera would give: (N, 3, size, size) in [0, 1] (the
    network's ``config.image_size``, 64 for the paper's network).

    The env's own observation pipeline (:func:`occrl.envs.observation.world_pixels`): a world
    recreated from an observation renders the image of that observation, pixel for pixel.

    Examples:
        >>> import numpy as np
        >>> from occrl.planners import RecreatedState, make_world, render_pixels, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> pixels = render_pixels([make_world(with_target(state, (0.0, 0.2, 0.0)))])
        >>> pixels.shape, float(pixels.min()) >= 0.0, float(pixels.max()) <= 1.0
        (torch.Size([1, 3, 64, 64]), True, True)
    """
    return world_pixels(worlds, size)


INFERENCE_BACKENDS = ("torch", "onnxruntime")


class StepGraph(torch.nn.Module):
    """One LSTM step of an OccNet on plain tensors: encoder, LSTM, policy head (:meth:`step`) and
    value head (``forward``, what is exported to ONNX). It holds the net's own modules.

    Examples:
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners.rhp import StepGraph
        >>> graph = StepGraph(make_occnet("paper"))
        >>> state = torch.zeros(1, 2, 128)  # (layers, batch, hidden): the LSTM's layout
        >>> [x.shape[-1] for x in graph(torch.zeros(2, 3, 64, 64), state, state)]
        [128, 4, 4, 2, 128, 128]
    """

    def __init__(self, net: OccNet) -> None:
        super().__init__()
        self.encoder, self.lstm = net.encoder.module, net.lstm.lstm
        self.policy_head, self.value_head = net.actor.module[0].module, net.critic.module
        self.policy_outputs = POLICY_OUTPUTS  # the names of the head's outputs

    def step(self, pixels: torch.Tensor, h: torch.Tensor, c: torch.Tensor):
        """LSTMModule's one-step path (a time dimension of 1; state as (layers, B, H)) and the
        policy head: belief, the head's outputs (loc, scale) and the
        state after the images."""
        belief, (h_next, c_next) = self.lstm(self.encoder(pixels).unsqueeze(1), (h, c))
        belief = belief[:, -1]
        return belief, tuple(self.policy_head(belief)), h_next, c_next

    def forward(self, pixels: torch.Tensor, h: torch.Tensor, c: torch.Tensor):
        belief, policy, h_next, c_next = self.step(pixels, h, c)
        return belief, *policy, self.value_head(belief).squeeze(-1), h_next, c_next


class NetworkStepper:
    """One LSTM step of an OccNet on a batch of images: the roll-outs' network call.

    ``backend="torch"`` (default) calls the network's own torch modules (encoder, LSTM, policy and
    value heads) directly under ``torch.inference_mode``, skipping the TensorDict plumbing of
    ``net.trunk`` / ``net.actor`` / ``net.critic``, which on the roll-outs' batches of 1-12 images
    cost as much as the arithmetic; the outputs equal the TensorDict modules' bit for bit (tested).
    ``backend="onnxruntime"`` exports the step to ONNX once, at construction, and runs it with ONNX
    Runtime (``pip install onnx onnxruntime``), several times faster on these batches
    (``benchmarks/network_inference.py``); its outputs agree with torch's to float rounding
    (about 1e-6, tested), so decisions can differ in rare near-ties. It runs the weights the net
    had when the stepper was built.

    Examples:
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners.rhp import NetworkStepper
        >>> stepper = NetworkStepper(make_occnet("paper"))
        >>> h = c = torch.zeros(2, 1, 128)
        >>> out, h, c = stepper.step(torch.zeros(2, 3, 64, 64), h, c)
        >>> out["loc"].shape, h.shape, stepper.value(out).shape
        (torch.Size([2, 4]), torch.Size([2, 1, 128]), torch.Size([2]))
    """

    def __init__(self, net: OccNet, backend: str = "torch") -> None:
        if backend not in INFERENCE_BACKENDS:
            raise ValueError(f"backend must be one of {INFERENCE_BACKENDS}, got {backend!r}")
        self.net = net
        self.graph = StepGraph(net)  # the net's own torch modules
        self.backend = backend
        self.session = _onnx_session(net) if backend == "onnxruntime" else None

    def sync_weights(self) -> None:
        """Take up the network's current weights: ONNX Runtime runs an export of the weights the
        net had when it was made, so re-export (~0.1 s); torch reads them live (nothing to do)."""
        if self.backend == "onnxruntime":
            self.session = _onnx_session(self.net)

    def __getstate__(self) -> dict:
        # an ONNX Runtime session does not pickle (process workers): rebuilt from the net on load
        return {**self.__dict__, "session": None}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if self.backend == "onnxruntime":
            self.session = _onnx_session(self.net)

    def step(self, pixels: torch.Tensor, h: torch.Tensor, c: torch.Tensor) -> tuple[dict[str, torch.Tensor], torch.Tensor, torch.Tensor]:
        """``pixels`` (B, 3, S, S) (S: the network's ``config.image_size``) and the LSTM state
        before them, each (B, layers, H) as the tensordict stores it -> ``{"belief", "loc",
        "scale"}`` (and ``"value"`` on ONNX Runtime) and the state after them."""
        if self.session is None:
            with torch.inference_mode():
                h, c = h.transpose(0, 1).contiguous(), c.transpose(0, 1).contiguous()  # LSTM layout (layers, B, H)
                belief, policy, h_next, c_next = self.graph.step(pixels, h, c)
                return self._outputs({"belief": belief, **dict(zip(self.graph.policy_outputs, policy))}, h_next, c_next)
        # ONNX Runtime: numpy arrays in and out, no autograd to switch off
        h, c = h.detach().transpose(0, 1).contiguous(), c.detach().transpose(0, 1).contiguous()
        feed = {"pixels": pixels.detach().numpy(), "h": h.numpy(), "c": c.numpy()}
        *outputs, h_next, c_next = (torch.from_numpy(x) for x in self.session.run(None, feed))
        return self._outputs(dict(zip(("belief", *self.graph.policy_outputs, "value"), outputs)), h_next, c_next)

    def _outputs(
        self, out: dict[str, torch.Tensor], h_next: torch.Tensor, c_next: torch.Tensor
    ) -> tuple[dict[str, torch.Tensor], torch.Tensor, torch.Tensor]:
        """Either backend's outputs as :meth:`step` returns them, the state back in the
        tensordict's layout (B, layers, H)."""
        return out, h_next.transpose(0, 1), c_next.transpose(0, 1)

    def value(self, out: dict[str, torch.Tensor]) -> torch.Tensor:
        """(B,) the value head on ``out["belief"]``."""
        if "value" in out:  # ONNX Runtime computed it with the step
            return out["value"]
        with torch.inference_mode():
            return self.graph.value_head(out["belief"]).squeeze(-1)


def _onnx_session(net: OccNet):
    """The step graph of ``net`` exported to ONNX and loaded in an ONNX Runtime session that uses
    as many threads as torch does here."""
    try:
        import onnxruntime as ort
    except ImportError:
        raise ImportError("the onnxruntime inference backend needs ONNX Runtime: pip install onnx onnxruntime") from None
    graph = StepGraph(net).eval()
    pixels = torch.zeros(2, 3, net.config.image_size, net.config.image_size)
    state = torch.zeros(net.lstm.lstm.num_layers, 2, net.lstm.lstm.hidden_size)
    buffer = io.BytesIO()
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the exporter's notes on RNNs and its deprecation notice
        torch.onnx.export(
            graph,
            (pixels, state, state),
            buffer,
            input_names=["pixels", "h", "c"],
            output_names=["belief", *graph.policy_outputs, "value", "h_next", "c_next"],
            dynamic_axes={"pixels": {0: "batch"}, "h": {1: "batch"}, "c": {1: "batch"}},
            dynamo=False,
        )
    options = ort.SessionOptions()
    options.intra_op_num_threads = torch.get_num_threads()
    options.inter_op_num_threads = 1
    options.log_severity_level = 3
    return ort.InferenceSession(buffer.getvalue(), options, providers=["CPUExecutionProvider"])


@dataclass
class RHPResult:
    """Per root: the chosen first action and its return; all roll-outs' first actions and returns.

    Examples:
        >>> import numpy as np
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import RecreatedState, rhp_batched, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> root = with_target(RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, 1, box), (0.0, 0.2, 0.0))
        >>> hidden = (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
        >>> noise = torch.randn(1, 2, 2, 4, generator=torch.Generator().manual_seed(0))  # 1 root, m = h = 2
        >>> res = rhp_batched(make_occnet("paper"), [root], hidden, noise)
        >>> res.action.shape, res.returns.shape, res.first_actions.shape, res.paths.shape
        ((1, 4), (1, 2), (1, 2, 4), (1, 2, 3, 3))
        >>> bool(res.value[0] == res.returns[0].max())  # the best roll-out's return
        True
    """

    action: np.ndarray  # (R, 4)
    value: np.ndarray  # (R,)
    returns: np.ndarray  # (R, m)
    first_actions: np.ndarray  # (R, m, 4)
    steps: int  # world steps simulated
    paths: np.ndarray | None = None  # (R, m, h + 1, 3) gripper poses along each roll-out, NaN after its end

    def rows(self, roots: slice) -> RHPResult:
        """The result of some of the roots (one world's, when several worlds planned together);
        ``steps`` counts their roll-outs' steps."""
        paths = None if self.paths is None else self.paths[roots]
        steps = self.steps if paths is None else int(np.isfinite(paths[:, :, 1:, 0]).sum())
        return RHPResult(self.action[roots], self.value[roots], self.returns[roots], self.first_actions[roots], steps, paths)


def _finish(returns: np.ndarray, first: np.ndarray, steps: int, paths: np.ndarray) -> RHPResult:
    best = returns.argmax(axis=1)
    ar = np.arange(returns.shape[0])
    return RHPResult(first[ar, best], returns[ar, best], returns, first, steps, paths)


def noise_dim(net: OccNet) -> int:
    """Standard normal draws per roll-out step: one per action dimension (:func:`rollout_action`).

    Examples:
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners.rhp import noise_dim
        >>> noise_dim(make_occnet("paper"))
        4
    """
    return net.config.action_dim


def check_noise(net: OccNet, noise: torch.Tensor) -> None:
    """``ValueError`` unless ``noise`` is (R, m, h, :func:`noise_dim`)."""
    if noise.ndim != 4 or noise.shape[-1] != noise_dim(net):
        raise ValueError(
            f"noise must be (roots, m, h, {noise_dim(net)}) standard normal draws for this network, got shape {tuple(noise.shape)}"
        )


def rollout_action(out: dict[str, torch.Tensor], eps: torch.Tensor) -> torch.Tensor:
    """The roll-outs' actions (B, A) from the network's outputs and standard normal draws ``eps``
    (B, A): the policy's Gaussian sample ``loc + scale * eps``.

    Examples:
        >>> import torch
        >>> from occrl.planners.rhp import rollout_action
        >>> out = {"loc": torch.zeros(1, 4), "scale": torch.full((1, 4), 0.5)}
        >>> rollout_action(out, torch.ones(1, 4)).tolist()
        [[0.5, 0.5, 0.5, 0.5]]
    """
    return out["loc"] + out["scale"] * eps


def rhp_batched(
    net: OccNet,
    roots: Sequence[RecreatedState],
    hidden: tuple[torch.Tensor, torch.Tensor],
    noise: torch.Tensor,
    gamma: float = C.GAMMA,
    pool: WorldPool | None = None,
    stepper: NetworkStepper | None = None,
) -> RHPResult:
    """All roots x m roll-outs in lock-step. ``hidden``: the LSTM state before the current
    observation, each (1, layers, H), or (R, layers, H) with one per root (roots of several
    worlds planned together). ``noise``: (R, m, h, 4) standard normal draws.
    ``pool``: take the roll-out worlds from this :class:`~occrl.planners.WorldPool` (kept worlds
    reused, the same results) instead of building them. ``stepper``: the network calls (default
    ``NetworkStepper(net)``, torch).

    Examples:
        >>> import numpy as np
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import RecreatedState, rhp_batched, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
        >>> roots = [with_target(state, (-0.1, 0.2, 0.0)), with_target(state, (0.1, 0.2, 0.0))]
        >>> hidden = (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
        >>> noise = torch.randn(2, 2, 2, 4, generator=torch.Generator().manual_seed(0))
        >>> res = rhp_batched(make_occnet("paper"), roots, hidden, noise)
        >>> res.action.shape, res.value.shape, res.steps  # 2 roots x 2 roll-outs x 2 steps
        ((2, 4), (2,), 8)
    """
    R, m, depth, _ = noise.shape
    check_noise(net, noise)
    size = net.config.image_size
    stepper = stepper if stepper is not None else NetworkStepper(net)
    rollout_states = [root for root in roots for _ in range(m)]
    worlds = pool.take(rollout_states) if pool is not None else [make_world(state) for state in rollout_states]
    n = len(worlds)
    # the m roll-outs of a root start from the same state: render and encode it once per root
    if hidden[0].shape[0] not in (1, R):
        raise ValueError(f"hidden must hold one LSTM state or one per root ({R}), got {hidden[0].shape[0]}")
    h0 = hidden[0].expand(R, *hidden[0].shape[1:]).contiguous()
    c0 = hidden[1].expand(R, *hidden[1].shape[1:]).contiguous()
    out, h, c = stepper.step(render_pixels(worlds[::m], size), h0, c0)
    out = {key: value.repeat_interleave(m, dim=0) for key, value in out.items()}
    h, c = h.repeat_interleave(m, dim=0), c.repeat_interleave(m, dim=0)
    eps = noise.reshape(n, depth, noise.shape[-1])
    ret = np.zeros(n)
    live = list(range(n))  # the roll-outs not yet ended, in order
    first = np.zeros((n, 4))
    paths = np.full((n, depth + 1, 3), np.nan)
    paths[:, 0] = [w.gripper_pose() for w in worlds]
    discount = 1.0
    steps = 0
    for j in range(depth):
        action = rollout_action(out, eps[:, j]).clamp(-1.0, 1.0).numpy().astype(np.float64)
        if j == 0:
            first = action.copy()
        rows = action.tolist()  # (each world's step reads its action as Python floats: the same values)
        ended = set()
        for k in live:
            outcome = worlds[k].step(rows[k])
            paths[k, j + 1] = worlds[k].gripper_pose()
            ret[k] += discount * outcome.reward
            if outcome.terminal:
                ended.add(k)
        steps += len(live)
        discount *= gamma
        if not ended and len(live) == n:  # every roll-out goes on: the step's outputs are the new rows as they are
            out, h, c = stepper.step(render_pixels(worlds, size), h, c)
            continue
        live = [k for k in live if k not in ended]
        if not live:
            break
        idx = torch.tensor(live, dtype=torch.int64)
        sub, h_new, c_new = stepper.step(render_pixels([worlds[k] for k in live], size), h[idx], c[idx])
        # live rows move on; ended rows keep their last outputs (never read again)
        out = {key: value.clone() for key, value in out.items()}
        for key, value in out.items():
            value[idx] = sub[key]
        h, c = h.clone(), c.clone()
        h[idx], c[idx] = h_new, c_new
    if live:
        # the live roll-outs' last outputs (all of them as they are when none ended)
        last = out if len(live) == n else {key: value[torch.tensor(live, dtype=torch.int64)] for key, value in out.items()}
        ret[live] += discount * stepper.value(last).numpy()
    return _finish(ret.reshape(R, m), first.reshape(R, m, 4), steps, paths.reshape(R, m, depth + 1, 3))


def rhp_sequential(
    net: OccNet,
    roots: Sequence[RecreatedState],
    hidden: tuple[torch.Tensor, torch.Tensor],
    noise: torch.Tensor,
    gamma: float = C.GAMMA,
) -> RHPResult:
    """Alg. 2 as printed: for each root, for each roll-out, step by step (the reference).

    Examples:
        >>> import numpy as np
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import RecreatedState, rhp_batched, rhp_sequential, with_target
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> root = with_target(RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, 1, box), (0.0, 0.2, 0.0))
        >>> net, hidden = make_occnet("paper"), (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
        >>> noise = torch.randn(1, 2, 2, 4, generator=torch.Generator().manual_seed(0))
        >>> seq, bat = rhp_sequential(net, [root], hidden, noise), rhp_batched(net, [root], hidden, noise)
        >>> bool(np.allclose(seq.returns, bat.returns)), bool(np.allclose(seq.action, bat.action))
        (True, True)
    """
    R, m, depth, _ = noise.shape
    check_noise(net, noise)
    size = net.config.image_size
    stepper = NetworkStepper(net)
    returns = np.zeros((R, m))
    first = np.zeros((R, m, 4))
    paths = np.full((R, m, depth + 1, 3), np.nan)
    steps = 0
    for r, root in enumerate(roots):
        for i in range(m):
            world = make_world(root)
            paths[r, i, 0] = world.gripper_pose()
            out, h, c = stepper.step(render_pixels([world], size), hidden[0], hidden[1])
            ret, discount, terminal = 0.0, 1.0, False
            for j in range(depth):
                action = rollout_action(out, noise[r, i, j][None]).clamp(-1.0, 1.0).numpy().astype(np.float64)[0]
                if j == 0:
                    first[r, i] = action
                outcome = world.step(action)
                paths[r, i, j + 1] = world.gripper_pose()
                steps += 1
                ret += discount * outcome.reward
                discount *= gamma
                if outcome.terminal:
                    terminal = True
                    break
                out, h, c = stepper.step(render_pixels([world], size), h, c)
            if not terminal:
                ret += discount * float(stepper.value(out)[0])
            returns[r, i] = ret
    return _finish(returns, first, steps, paths)
