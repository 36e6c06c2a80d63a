"""The hybrid planner with an OMPL proposal among its roll-outs (``hybrid-ompl-MxH``)."""

import math

import numpy as np
import pytest
import torch

from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.baselines.hybrid_ompl import HybridOMPLPlanner, rollout_actions, with_proposal
from occrl.envs import make_env
from occrl.envs import world_constants as C
from occrl.eval.methods import is_planner, make_method
from occrl.modules import make_occnet
from occrl.planners import RecreatedState, make_world, render_pixels, with_target
from occrl.planners.rhp import NetworkStepper, RHPResult

BOX = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
TOLERANCE = (0.01, math.radians(10.0))


@pytest.fixture(scope="module")
def net():
    torch.manual_seed(0)
    return make_occnet("paper").eval()


def test_rollout_actions_scores_the_actions_as_rhp_scores_a_rollout(net):
    """Rewards of the executed actions in the root's world, then the discounted value of the
    network that saw every image along the way."""
    base = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, 1, BOX)
    roots = [with_target(base, (-0.05, 0.2, 0.0)), with_target(base, (0.1, 0.15, 0.0))]
    actions = np.array([[1.0, 0.0, 0.0, -1.0], [0.5, 0.3, 0.0, -1.0], [1.0, -0.2, 0.1, -1.0]])
    hidden = (torch.randn(1, 1, 128) * 0.1, torch.randn(1, 1, 128) * 0.1)
    stepper = NetworkStepper(net)
    returns, paths = rollout_actions(stepper, roots, hidden, actions, gamma=0.9)
    for r, root in enumerate(roots):
        world = make_world(root)
        out, h, c = stepper.step(render_pixels([world]), *hidden)
        expected, discount = 0.0, 1.0
        for j, action in enumerate(actions):
            outcome = world.step(action)
            assert np.allclose(paths[r, j + 1], world.gripper_pose())
            expected += discount * outcome.reward
            discount *= 0.9
            assert not outcome.terminal
            out, h, c = stepper.step(render_pixels([world]), h, c)
        expected += discount * float(stepper.value(out)[0])
        assert returns[r] == pytest.approx(expected, abs=1e-5)
    assert paths.shape == (2, 4, 3)


def test_a_proposal_wins_its_root_only_with_a_strictly_better_return():
    result = RHPResult(
        np.zeros((2, 4)), np.array([-5.0, -2.0]), np.array([[-5.0, -6.0], [-2.0, -9.0]]), np.zeros((2, 2, 4)), 8, np.zeros((2, 2, 3, 3))
    )
    merged = with_proposal(result, np.array([-4.0, -2.0]), np.full(4, 0.5), np.zeros((2, 2, 3)))
    assert merged.returns.shape == (2, 3) and merged.first_actions.shape == (2, 3, 4)
    assert merged.action[0].tolist() == [0.5] * 4 and merged.value[0] == -4.0  # better than the policy's -5
    assert merged.action[1].tolist() == [0.0] * 4 and merged.value[1] == -2.0  # a tie stays the policy's
    assert merged.paths.shape == (2, 3, 3, 3) and np.isnan(merged.paths[:, 2, 2]).all()  # the shorter proposal padded
    assert merged.steps == 8 + 2  # one proposal step per root


class KeysSeen(HierarchicalPlanner):
    """The real hierarchical planner, recording the keys it was given and the actions it returned."""

    seen: set = set()

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.returned = []  # per forward: (worlds, 4)

    def forward(self, tensordict):
        KeysSeen.seen |= set(tensordict.keys(True, True))
        out = super().forward(tensordict)
        self.returned.append(out.get("action").reshape(-1, 4).numpy().astype(float))
        return out


@pytest.mark.integration
def test_the_executed_action_is_the_proposal_exactly_when_its_rollout_won(net):
    env = make_env(batch_size=2, stage=1, seed=3, heatmap_target=False).append_transform(net.make_primer())
    proposer = KeysSeen(plan_seconds=0.3, sweep_from="nearest", stop_when_located=True, follow_tolerance=TOLERANCE)
    planner = HybridOMPLPlanner(net, m=2, h=2, proposer=proposer)
    td = env.rollout(6, planner, break_when_any_done=False)
    assert len(planner.proposals) == len(planner.decisions) == 12
    actions = td["action"].numpy()  # (world, step, 4); the decisions go step by step, world by world
    assert len(proposer.returned) == 6
    for k, (record, decision) in enumerate(zip(planner.proposals, planner.decisions)):
        firsts = decision.result.first_actions[decision.chosen_root]
        assert firsts.shape == (3, 4)  # two roll-outs and the proposal
        # every root's last roll-out starts with this world's proposal of this step
        assert np.allclose(decision.result.first_actions[:, 2], proposer.returned[k // 2][k % 2], atol=1e-6)
        assert np.allclose(actions[k % 2, k // 2], decision.action, atol=1e-6)
        assert record.taken == (np.argmax(decision.result.returns[decision.chosen_root]) == 2)
        if record.taken:
            assert np.array_equal(decision.action, firsts[2])
        assert 1 <= record.length <= 2 and record.kind in ("search", "move_out", "reach", "extract", "rearrange_reach", "place")
    assert not any(key == "privileged" or (isinstance(key, tuple) and key[0] == "privileged") for key in KeysSeen.seen)


def test_a_call_without_the_recurrent_state_is_refused_before_the_proposer_moves_on(net):
    env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False)  # no primer
    planner = HybridOMPLPlanner(net, m=1, h=1, plan_seconds=0.2)
    with pytest.raises(KeyError, match="recurrent_state"):
        planner(env.reset())
    assert planner.proposer.episodes == [] and planner.proposals == []


def test_bad_settings_are_refused(net):
    with pytest.raises(ValueError, match="plan_seconds"):
        HybridOMPLPlanner(net, plan_seconds=0.5, proposer=HierarchicalPlanner(follow_tolerance=TOLERANCE))
    with pytest.raises(ValueError, match="follow_tolerance"):
        HybridOMPLPlanner(net, proposer=HierarchicalPlanner())
    with pytest.raises(ValueError, match="replan_inside"):
        HybridOMPLPlanner(net, replan_inside=True, proposer=HierarchicalPlanner(follow_tolerance=TOLERANCE))
    assert HybridOMPLPlanner(net).proposer.replan_inside and not HybridOMPLPlanner(net, replan_inside=False).proposer.replan_inside
    with pytest.raises(TypeError, match="HierarchicalPlanner"):
        HybridOMPLPlanner(net, proposer=object())
    with pytest.raises(RuntimeError, match="inside forward"):
        HybridOMPLPlanner(net).decide(None, np.zeros((64, 64)), None)
    with pytest.raises(ValueError, match="at least one action"):
        rollout_actions(NetworkStepper(net), [], (None, None), np.zeros((0, C.ACTION_DIM)))


def test_the_variant_is_a_named_planner():
    method = make_method("hybrid-ompl-2x3")
    assert isinstance(method.policy, HybridOMPLPlanner) and (method.policy.m, method.policy.h) == (2, 3)
    assert is_planner("hybrid-ompl-4x4") and method.network == make_method("hybrid-4x4").network
