"""The hybrid planner (paper Alg. 1) as a TorchRL-style policy.

Each decision: run the network on the real observation (this advances its LSTM over the real
history and gives the heat-map), recreate the known state from the detections, generate weighted
root states from the heat-map, run batched RHP from every root and pick an action by the
weighted returns.

Weighting. Returns are negative (-1 per action), so ``w x R`` as printed in Alg. 1 would favour
*unlikely* roots. The planner scores root ``r`` by ``w_r x (R_r - L)`` with ``L`` one less than
the lowest root return of this decision: every score is positive and raising a root's weight (the
others renormalised) never lowers its own score nor raises another's, so it never lowers the
chance that its action is chosen (tested).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.envs import world_constants as C
from occrl.envs.perception import OBSERVATION_KEYS
from occrl.modules.occnet import OccNet, require_recurrent_state
from occrl.planners.recreate import WorldPool, recreate
from occrl.planners.rhp import INFERENCE_BACKENDS, NetworkStepper, RHPResult, noise_dim, rhp_batched, rhp_sequential
from occrl.planners.states import Root, generate_states

__all__ = ["HybridPlanner", "select_root", "Decision"]


def select_root(weights: np.ndarray, returns: np.ndarray) -> int:
    """Index of the root whose action is executed: argmax of ``w x (R - L)``, L = min(R) - 1.

    Examples:
        >>> from occrl.planners import select_root
        >>> select_root([0.5, 0.5], [-3.0, -5.0])  # equal weights: the better return
        0
        >>> select_root([0.1, 0.9], [-3.0, -4.0])  # a much likelier root wins a small return gap
        1
    """
    w = np.asarray(weights, float)
    r = np.asarray(returns, float)
    return int(np.argmax(w * (r - (r.min() - 1.0))))


@dataclass
class Decision:
    """What one planning step did, for pictures and analysis.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import HybridPlanner
        >>> net = make_occnet("paper")
        >>> env = make_env(batch_size=1, seed=0, heatmap_target=False).append_transform(net.make_primer())
        >>> planner = HybridPlanner(net, m=2, h=2)
        >>> td = planner(env.reset())
        >>> d = planner.decisions[-1]
        >>> d.action.shape, d.result.returns.shape, d.chosen_root, d.heatmap.shape
        ((4,), (1, 2), 0, (64, 64))
    """

    roots: list[Root]
    result: RHPResult
    chosen_root: int
    action: np.ndarray
    seconds: float
    heatmap: np.ndarray = field(repr=False, default=None)


class HybridPlanner(TensorDictModuleBase):
    """Hybrid planner policy: ``env.rollout(policy=HybridPlanner(net))``.

    The env needs the network's recurrent-state primer (``env.append_transform(net.make_primer())``)
    so that the real observation history is carried between steps.

    Args:
        net: a three-headed OccNet (the heat-map head proposes where the target may be).
        m, h: roll-outs per root and their depth (paper: 2x2, 4x4, 6x6).
        limited: evaluate only the most likely root (Hybrid-limited).
        max_roots: at most this many heat-map peaks become roots.
        seed: seeds the roll-outs' policy noise; a decision is a function of the observation
            history and this seed.
        batched: use the lock-step RHP (False: the sequential reference).
        inference: how the roll-outs call the network (batched RHP): ``"torch"`` (the torch
            modules, bit for bit as the TensorDict modules) or ``"onnxruntime"`` (the network
            exported once, at construction, several times faster per call, equal to float
            rounding; ``pip install onnx onnxruntime``; it keeps the weights of that moment:
            :meth:`sync_weights` after changing them).
        batch_worlds: decide the worlds of a batched observation together, all their roll-outs
            in one batched RHP (:meth:`decide_many`): 1.4x faster per world's decision on batches
            of 8 (``benchmarks/planner_latency.py --worlds-together``), equal to deciding one
            world at a time up to float rounding (the larger network batches round differently,
            about 1e-6), so off by default: evaluations stay bit for bit as recorded. The
            trainer's planner teachers use it.

    Examples:
        >>> import torch
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import HybridPlanner
        >>> net = make_occnet("paper").eval()
        >>> env = make_env(batch_size=1, stage=1, seed=0, heatmap_target=False).append_transform(net.make_primer())
        >>> td = env.rollout(2, HybridPlanner(net, m=2, h=2))
        >>> td["action"].shape
        torch.Size([1, 2, 4])
    """

    def __init__(
        self,
        net: OccNet,
        m: int = 4,
        h: int = 4,
        limited: bool = False,
        max_roots: int = 3,
        gamma: float = C.GAMMA,
        seed: int = 0,
        batched: bool = True,
        inference: str = "torch",
        batch_worlds: bool = False,
    ) -> None:
        super().__init__()
        if not isinstance(net, OccNet):
            raise TypeError(f"net must be an occrl OccNet (make_occnet / load_pretrained), got {type(net).__name__}")
        if net.heatmap is None:
            raise ValueError("the hybrid planner needs a network with a heat-map head (make_occnet(heatmap=True))")
        for name, value in (("m", m), ("h", h), ("max_roots", max_roots)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be an int >= 1, got {value!r}")
        if not 0.0 < gamma <= 1.0:
            raise ValueError(f"gamma must be in (0, 1], got {gamma}")
        device = next(net.parameters()).device
        if device.type != "cpu":
            # roll-outs call the network on a few states at a time between pymunk steps: on an
            # accelerator the transfers would cost more than the arithmetic (docs/design/planner.md)
            raise ValueError(f"the hybrid planner runs its network on the CPU; this one is on {device}: pass net.to('cpu')")
        self.net = net.eval()
        self.m, self.h = int(m), int(h)
        self.limited = limited
        self.max_roots = 1 if limited else int(max_roots)
        self.gamma = gamma
        self.batched = batched
        self.generator = torch.Generator().manual_seed(int(seed))
        self.pool = WorldPool()  # roll-out worlds kept between decisions (batched RHP)
        if inference not in INFERENCE_BACKENDS:
            raise ValueError(f"inference must be one of {INFERENCE_BACKENDS}, got {inference!r}")
        self.inference = inference
        self.batch_worlds = bool(batch_worlds)
        self.stepper = NetworkStepper(self.net, backend=inference)
        self.decisions: list[Decision] = []
        self.in_keys = ["pixels", "is_init", "recurrent_state_h", "recurrent_state_c", *OBSERVATION_KEYS]
        self.out_keys = ["action", ("next", "recurrent_state_h"), ("next", "recurrent_state_c"), "heatmap"]

    def reseed(self, seed: int) -> None:
        self.generator.manual_seed(int(seed))

    def sync_weights(self) -> None:
        """Plan with the network's current weights after they changed in place (training): needed
        with ``inference="onnxruntime"``, which runs an export of the weights at construction."""
        self.stepper.sync_weights()

    @torch.no_grad()
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        require_recurrent_state(tensordict, "HybridPlanner")
        flat = tensordict.reshape(-1)
        hidden_h = flat.get("recurrent_state_h").clone()
        hidden_c = flat.get("recurrent_state_c").clone()
        is_init = flat.get("is_init").reshape(-1)
        hidden_h[is_init] = 0.0  # the LSTM starts afresh at an episode start
        hidden_c[is_init] = 0.0
        # the real observation advances the LSTM over the real history (net.heatmap's modules,
        # called directly: the same values as the TensorDict modules, tested)
        embed = self.stepper.graph.encoder(flat.get("pixels"))
        belief, (next_h, next_c) = self.stepper.graph.lstm(
            embed.unsqueeze(1), (hidden_h.transpose(0, 1).contiguous(), hidden_c.transpose(0, 1).contiguous())
        )
        heatmap = torch.sigmoid(self.net.heatmap_head.module[0].module(belief[:, -1]))  # "belief" -> "heatmap_logits"
        heat = heatmap[:, 0].numpy()
        if self.batch_worlds and self.batched and flat.shape[0] > 1:  # every world's roll-outs in one batched RHP
            decisions = self.decide_many([flat[b] for b in range(flat.shape[0])], heat, (hidden_h, hidden_c))
        else:
            decisions = [self.decide(flat[b], heat[b], (hidden_h[b : b + 1], hidden_c[b : b + 1])) for b in range(flat.shape[0])]
        action = torch.as_tensor(np.stack([d.action for d in decisions]), dtype=torch.float32)
        tensordict.set("action", action.reshape(*tensordict.shape, C.ACTION_DIM))
        tensordict.set("heatmap", heatmap.reshape(*tensordict.shape, *heatmap.shape[1:]))
        for key, value in ((("next", "recurrent_state_h"), next_h), (("next", "recurrent_state_c"), next_c)):
            value = value.transpose(0, 1)  # as the tensordict stores it: (B, layers, H)
            tensordict.set(key, value.reshape(*tensordict.shape, *value.shape[1:]))
        return tensordict

    def decide(self, obs: TensorDictBase, heatmap: np.ndarray, hidden) -> Decision:
        """One planning step for one world (observation without batch dims)."""
        t0 = time.perf_counter()
        roots = self.roots(obs, heatmap)
        return self.record(roots, self.rollouts(roots, hidden), time.perf_counter() - t0, heatmap)

    def rollouts(self, roots: list[Root], hidden) -> RHPResult:
        """The m x h roll-outs from every root of one world (Alg. 2), their noise drawn from the
        planner's generator; ``hidden``: that world's LSTM state, each (1, layers, H)."""
        noise = torch.randn(len(roots), self.m, self.h, noise_dim(self.net), generator=self.generator)
        states = [r.state for r in roots]
        if self.batched:
            return rhp_batched(self.net, states, hidden, noise, self.gamma, pool=self.pool, stepper=self.stepper)
        return rhp_sequential(self.net, states, hidden, noise, self.gamma)

    def decide_many(self, observations: list[TensorDictBase], heatmaps: np.ndarray, hidden) -> list[Decision]:
        """One planning step for each of several worlds, all their roll-outs in one batched RHP:
        one network call per depth step for every world instead of one per world (fewer, larger
        calls). The roll-outs' noise is drawn world by world as :meth:`decide` draws it, so the
        decisions are those of deciding one world at a time up to the float rounding of the
        larger batches (near-ties aside). ``hidden``: the LSTM states, each (B, layers, H)."""
        t0 = time.perf_counter()
        roots_per_world, noise = [], []
        for obs, heatmap in zip(observations, heatmaps):
            roots = self.roots(obs, heatmap)
            roots_per_world.append(roots)
            noise.append(torch.randn(len(roots), self.m, self.h, noise_dim(self.net), generator=self.generator))
        counts = [len(roots) for roots in roots_per_world]
        owner = torch.from_numpy(np.repeat(np.arange(len(counts)), counts))
        states = [r.state for roots in roots_per_world for r in roots]
        result = rhp_batched(
            self.net,
            states,
            (hidden[0][owner], hidden[1][owner]),
            torch.cat(noise),
            self.gamma,
            pool=self.pool,
            stepper=self.stepper,
        )
        seconds = (time.perf_counter() - t0) / len(counts)  # the batch's time, shared
        bounds = np.cumsum([0, *counts])
        return [
            self.record(roots, result.rows(slice(start, stop)), seconds, heatmap)
            for roots, heatmap, start, stop in zip(roots_per_world, heatmaps, bounds[:-1], bounds[1:])
        ]

    def roots(self, obs: TensorDictBase, heatmap: np.ndarray) -> list[Root]:
        """The weighted root states of one observation (Alg. 1's state generation): the recreated
        state, with the target at the heat-map's peaks while it is not detected. A subclass may
        plan from other roots."""
        roots = generate_states(heatmap, recreate(obs), self.max_roots)
        if self.limited:
            roots = [max(roots, key=lambda r: r.weight)]
            roots[0].weight = 1.0
        return roots

    def record(self, roots: list[Root], result: RHPResult, seconds: float, heatmap: np.ndarray) -> Decision:
        """Choose the root (:func:`select_root`) and keep the decision in :attr:`decisions`."""
        chosen = select_root(np.array([r.weight for r in roots]), result.value)
        decision = Decision(roots, result, chosen, result.action[chosen], seconds, heatmap)
        self.decisions.append(decision)
        if len(self.decisions) > 200:
            del self.decisions[:100]
        return decision
