"""The hybrid planner with an OMPL proposal among its roll-outs (beyond the papers; a named variant).

Why it is part of the library: it is the strongest variant of the hybrid planner measured here
(``occrl eval --method hybrid-ompl-4x4 --stage 2 --tasks 200 --weights occnet-takeover``: 69.5 %
of the held-out stage-2 tasks, above the paper's hybrid planner on the same network;
docs/lab/baselines.md), and it is the bridge between the papers' two planners: the network's
hybrid planner and the hierarchical OMPL planner decide together, one candidate set holding the
policy's roll-outs and the OMPL plan.

On every network trained here the paper's hybrid planner fails the same stage-2 tasks (deep
targets behind clutter, targets beside a wall), the ones the hierarchical OMPL planner solves by
planning a grasp and a pull-out in the recreated world. This variant lets the hybrid planner
*choose* such a plan: each decision, the hierarchical planner (run alongside, closed-loop, fed
every observation) proposes its next actions, and from every root one extra roll-out executes
them open-loop (its next action and up to ``h - 1`` actions still queued by its current
low-level plan), scored like the policy's roll-outs: the rewards along it plus the discounted
value at its end (none after a terminal state). Per root the best of the ``m + 1`` roll-outs
gives the root's action and return; roots are chosen as in Alg. 1
(:func:`~occrl.planners.select_root`). When the proposal is not taken the world leaves the
hierarchical plan and the proposer re-plans from the next observation (``follow_tolerance``).

Both decision makers read only observations. The network, the heat-map roots and the m x h
roll-outs are the paper's; only the candidate set grows by one. ``proposals`` records every
decision's proposal and what became of it.

Timing: a :class:`~occrl.planners.Decision`'s ``seconds`` are the roll-outs' (the proposer plans
before them, in :meth:`HybridOMPLPlanner.forward`); evaluations time whole episodes.

Reproducibility: the roll-outs are seeded as the hybrid planner's; the proposer's OMPL queries
are bounded in wall time, as the hierarchical baseline's are, so an episode repeats exactly only
while every query ends the same within its budget (under another load a few differ).

Layer: it combines a planner (:mod:`occrl.planners`) with a baseline
(:mod:`occrl.baselines.hierarchical`), so it lives with the baselines, above both.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import torch
from tensordict import TensorDictBase

from occrl.envs import world_constants as C
from occrl.modules.occnet import OccNet, require_recurrent_state
from occrl.planners import HybridPlanner, RecreatedState, make_world, render_pixels
from occrl.planners.hybrid import Decision
from occrl.planners.rhp import NetworkStepper, RHPResult

from occrl.baselines.hierarchical import HierarchicalPlanner

__all__ = ["HybridOMPLPlanner", "ProposalRecord", "make_proposer", "rollout_actions", "with_proposal"]

# the proposer's settings: those of the hierarchical DAgger teacher (docs/lab/baselines.md), which
# acts well on states another policy chose: closed-loop, searching from the nearer end and
# stopping as soon as the target is seen, 1 s per OMPL query; unlike the teacher it keeps the
# planner's default episode planning limit (120 s, the task's limit)
PROPOSER_FOLLOW_TOLERANCE = (0.01, math.radians(10.0))
PROPOSER_PLAN_SECONDS = 1.0


def make_proposer(plan_seconds: float = PROPOSER_PLAN_SECONDS, seed: int = 0, replan_inside: bool = False) -> HierarchicalPlanner:
    """The hierarchical planner as :class:`HybridOMPLPlanner` runs it: closed-loop
    (``follow_tolerance`` 1 cm / 10 degrees), searching from the nearer end and stopping at first
    sight, ``plan_seconds`` per OMPL query; with ``replan_inside`` (HybridOMPLPlanner's default)
    it plans from inside the shelf instead of backing out to search
    (:class:`~occrl.baselines.hierarchical.HierarchicalPlanner`).

    Examples:
        >>> from occrl.baselines.hybrid_ompl import make_proposer
        >>> proposer = make_proposer()
        >>> proposer.sweep_from, proposer.stop_when_located, proposer.plan_seconds
        ('nearest', True, 1.0)
    """
    return HierarchicalPlanner(
        plan_seconds=plan_seconds,
        sweep_from="nearest",
        stop_when_located=True,
        seed=seed,
        follow_tolerance=PROPOSER_FOLLOW_TOLERANCE,
        replan_inside=replan_inside,
    )


@dataclass
class ProposalRecord:
    """What became of one decision's proposal (:attr:`HybridOMPLPlanner.proposals`): what the
    proposer was doing (one of :data:`~occrl.baselines.hierarchical.ACTION_KINDS`), how many
    actions it proposed, whether its action was executed, and, from the chosen root, the
    proposal's return against the best of the policy's m roll-outs."""

    kind: str
    length: int
    taken: bool
    proposal_return: float
    policy_return: float


def rollout_actions(
    stepper: NetworkStepper,
    roots: list[RecreatedState],
    hidden: tuple[torch.Tensor, torch.Tensor],
    actions: np.ndarray,
    gamma: float = C.GAMMA,
) -> tuple[np.ndarray, np.ndarray]:
    """One open-loop roll-out of the given actions from every root, scored as RHP scores its
    roll-outs: ``sum_j gamma^(j-1) r_j + gamma^k V`` after the k actions (no value after a
    terminal state). ``hidden``: the LSTM state before the current observation, each (1, layers, H).
    Returns the returns (R,) and the gripper poses along each roll-out (R, k + 1, 3; NaN after its
    end).

    Examples:
        >>> import numpy as np
        >>> import torch
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import RecreatedState, with_target
        >>> from occrl.planners.rhp import NetworkStepper
        >>> from occrl.baselines.hybrid_ompl import rollout_actions
        >>> box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
        >>> root = with_target(RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, 1, box), (0.0, 0.2, 0.0))
        >>> hidden = (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
        >>> returns, paths = rollout_actions(NetworkStepper(make_occnet("paper")), [root], hidden, np.array([[1.0, 0, 0, -1]]))
        >>> returns.shape, paths.shape, bool(paths[0, 1, 1] > paths[0, 0, 1])  # one step forward
        ((1,), (1, 2, 3), True)
    """
    actions = np.asarray(actions, dtype=float).reshape(-1, C.ACTION_DIM)
    if len(actions) == 0:
        raise ValueError("rollout_actions needs at least one action")
    worlds = [make_world(state) for state in roots]
    n, size = len(worlds), stepper.net.config.image_size
    h = hidden[0].expand(n, *hidden[0].shape[1:]).contiguous()
    c = hidden[1].expand(n, *hidden[1].shape[1:]).contiguous()
    out, h, c = stepper.step(render_pixels(worlds, size), h, c)
    returns = np.zeros(n)
    alive = np.ones(n, dtype=bool)
    paths = np.full((n, len(actions) + 1, 3), np.nan)
    paths[:, 0] = [w.gripper_pose() for w in worlds]
    discount = 1.0
    for j, action in enumerate(actions):
        for k in np.flatnonzero(alive):
            outcome = worlds[k].step(action)
            paths[k, j + 1] = worlds[k].gripper_pose()
            returns[k] += discount * outcome.reward
            alive[k] = not outcome.terminal
        discount *= gamma
        if not alive.any():
            break
        out, h, c = stepper.step(render_pixels(worlds, size), h, c)  # finished worlds' rows are not read
    if alive.any():
        returns[alive] += discount * stepper.value(out).numpy()[alive]
    return returns, paths


def with_proposal(result: RHPResult, returns: np.ndarray, first_action: np.ndarray, paths: np.ndarray) -> RHPResult:
    """``result`` with one more roll-out per root (the last column): the proposal's returns (R,),
    its first action and its paths (R, k + 1, 3); each root's action and return become those of
    its best roll-out among the m + 1 (the policy's roll-outs win ties).

    Examples:
        >>> import numpy as np
        >>> from occrl.planners.rhp import RHPResult
        >>> from occrl.baselines.hybrid_ompl import with_proposal
        >>> res = RHPResult(np.zeros((1, 4)), np.array([-5.0]), np.array([[-5.0, -6.0]]), np.zeros((1, 2, 4)), 4)
        >>> out = with_proposal(res, np.array([-3.0]), np.ones(4), np.zeros((1, 2, 3)))
        >>> out.returns.shape, float(out.value[0]), out.action[0].tolist()
        ((1, 3), -3.0, [1.0, 1.0, 1.0, 1.0])
    """
    R, m = result.returns.shape
    all_returns = np.concatenate([result.returns, returns.reshape(R, 1)], axis=1)
    first = np.concatenate([result.first_actions, np.broadcast_to(first_action, (R, 1, C.ACTION_DIM))], axis=1)
    best = all_returns.argmax(axis=1)
    rows = np.arange(R)
    merged_paths = None
    if result.paths is not None:
        depth = max(result.paths.shape[2], paths.shape[1])
        merged_paths = np.full((R, m + 1, depth, 3), np.nan)
        merged_paths[:, :m, : result.paths.shape[2]] = result.paths
        merged_paths[:, m, : paths.shape[1]] = paths
    steps = result.steps + int(np.isfinite(paths[:, 1:, 0]).sum())
    return RHPResult(first[rows, best], all_returns[rows, best], all_returns, first, steps, merged_paths)


class HybridOMPLPlanner(HybridPlanner):
    """The hybrid planner with the hierarchical OMPL planner's next actions as one more roll-out
    per root: ``env.rollout(policy=HybridOMPLPlanner(net))``; method ``hybrid-ompl-MxH`` in
    ``occrl eval``.

    Args:
        net, m, h, limited, max_roots, gamma, seed, batched, inference: as
            :class:`~occrl.planners.HybridPlanner` (``batch_worlds`` is not offered: the proposals
            are made world by world).
        plan_seconds: time budget of one OMPL query of the default proposer (1 s; not with
            ``proposer``).
        replan_inside: the default proposer plans from inside the shelf instead of backing out
            to search (:func:`make_proposer`; ``False``: it backs out, as the hierarchical
            baseline does; not with ``proposer``).
        proposer: the hierarchical planner that proposes (default :func:`make_proposer`:
            closed-loop, nearest-end search stopping at first sight, ``plan_seconds`` per query,
            seeded with ``seed``); it must
            have a ``follow_tolerance``, since the hybrid planner often leaves its plans.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.baselines.hybrid_ompl import HybridOMPLPlanner
        >>> net = make_occnet("paper").eval()
        >>> env = make_env(batch_size=1, stage=1, seed=0, heatmap_target=False).append_transform(net.make_primer())
        >>> planner = HybridOMPLPlanner(net, m=2, h=2, plan_seconds=0.2)
        >>> td = env.rollout(2, planner)
        >>> td["action"].shape, planner.decisions[-1].result.returns.shape  # 2 roll-outs + the proposal
        (torch.Size([1, 2, 4]), (1, 3))
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
        plan_seconds: float | None = None,
        proposer: HierarchicalPlanner | None = None,
        replan_inside: bool | None = None,
    ) -> None:
        if proposer is not None and plan_seconds is not None:
            raise ValueError("plan_seconds sets the default proposer's budget; with proposer= given, set it on that planner")
        if proposer is not None and replan_inside is not None:
            raise ValueError("replan_inside sets the default proposer's option; with proposer= given, set it on that planner")
        super().__init__(net, m, h, limited, max_roots, gamma, seed, batched, inference, batch_worlds=False)
        if proposer is None:
            seconds = PROPOSER_PLAN_SECONDS if plan_seconds is None else plan_seconds
            proposer = make_proposer(seconds, seed, replan_inside=True if replan_inside is None else replan_inside)
        if not isinstance(proposer, HierarchicalPlanner):
            raise TypeError(f"proposer must be a HierarchicalPlanner, got {type(proposer).__name__}")
        if proposer.follow_tolerance is None:
            raise ValueError("the proposer must re-plan when the world leaves its plan: give it a follow_tolerance")
        self.proposer = proposer
        self.proposals: list[ProposalRecord] = []  # the last decisions' proposals (as many as ``decisions``)
        self._proposals: list[tuple[np.ndarray, str]] = []  # this forward's proposals and kinds, one per world, in order

    def reseed(self, seed: int) -> None:
        super().reseed(seed)
        self.proposer.reseed(seed)

    @torch.no_grad()
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        require_recurrent_state(tensordict, "HybridOMPLPlanner")  # before the proposer's memory moves on
        flat = tensordict.reshape(-1)
        proposed = self.proposer(flat.select(*self.proposer.in_keys).copy()).get("action").numpy().astype(float)
        kinds = self.proposer.last_action_kinds
        self._proposals = [
            (np.concatenate([proposed[b : b + 1], self.proposer.planned_actions(b, self.h - 1)]), kinds[b]) for b in range(flat.shape[0])
        ]
        try:
            return super().forward(tensordict)
        finally:
            self._proposals = []

    def decide_many(self, observations, heatmaps, hidden):
        raise NotImplementedError("HybridOMPLPlanner decides world by world (each world has its own proposal): keep batch_worlds False")

    def decide(self, obs: TensorDictBase, heatmap: np.ndarray, hidden) -> Decision:
        """One planning step for one world: the paper's RHP and the proposal's roll-out from
        every root (the proposal of the world whose turn it is in :meth:`forward`)."""
        if not self._proposals:
            raise RuntimeError("HybridOMPLPlanner.decide runs inside forward (the proposer must see the observation first)")
        proposal, kind = self._proposals.pop(0)
        t0 = time.perf_counter()
        roots = self.roots(obs, heatmap)
        result = self.rollouts(roots, hidden)  # the paper's m x h roll-outs
        returns, paths = rollout_actions(self.stepper, [r.state for r in roots], hidden, proposal, self.gamma)
        result = with_proposal(result, returns, proposal[0], paths)
        decision = self.record(roots, result, time.perf_counter() - t0, heatmap)
        chosen = result.returns[decision.chosen_root]
        taken = bool(np.argmax(chosen) == self.m)  # the proposal's roll-out is the root's best
        proposal_return = float(chosen[-1])
        self.proposals.append(ProposalRecord(kind, len(proposal), taken, proposal_return, float(chosen[:-1].max())))
        if len(self.proposals) > len(self.decisions):  # kept as long as the decisions are
            del self.proposals[: len(self.proposals) - len(self.decisions)]
        return decision
