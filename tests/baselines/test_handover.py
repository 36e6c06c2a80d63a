"""SearchThenRetrieve: the searcher acts until the target is first detected, the retriever after."""

import pytest
import numpy as np
import torch
from torchrl.envs.utils import step_mdp

from occrl.baselines import ScriptedRetriever
from occrl.baselines.handover import SearchThenRetrieve
from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner, recreate


@pytest.mark.integration
def test_hand_over_at_the_first_detection():
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    # the target hidden in world 0 at the start, seen in world 1
    env = make_env(batch_size=2, stage=2, seed=1, heatmap_target=False).append_transform(net.make_primer())
    policy = SearchThenRetrieve(HybridPlanner(net, m=2, h=2, seed=1), ScriptedRetriever())
    assert "privileged" in policy.in_keys and "pixels" in policy.in_keys  # what its parts read
    alone, scripted = HybridPlanner(net, m=2, h=2, seed=1), ScriptedRetriever()
    td = env.reset()
    seen = np.zeros(2, bool)
    kinds = []
    for _ in range(8):
        seen |= np.array([recreate(td[b]).target_detected for b in range(2)])
        td = policy(td)
        own = alone(td.clone())["action"]  # the planner on the same history decides alike
        retrieved = scripted(td.select(*scripted.in_keys).copy())["action"]
        for b in range(2):
            expected = retrieved[b] if seen[b] else own[b]
            assert torch.equal(td["action"][b], expected)
        assert np.array_equal(policy.handed, seen)
        kinds.append(seen.copy())
        td = step_mdp(env.step(td))
    kinds = np.array(kinds)
    assert kinds.any() and not kinds.all()  # both parts acted in this test
    assert policy.handovers == int(kinds[-1].sum())
    policy.reset()
    assert policy.handed is None and policy.handovers == 0


@pytest.mark.integration
def test_a_following_retriever_decides_on_the_whole_history():
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    env = make_env(batch_size=2, stage=2, seed=1, heatmap_target=False).append_transform(net.make_primer())
    policy = SearchThenRetrieve(ScriptedRetriever(), HybridPlanner(net, m=2, h=2, seed=1), retriever_follows=True)
    alone, scripted = HybridPlanner(net, m=2, h=2, seed=1), ScriptedRetriever()
    state_keys = [k for k in alone.out_keys if k != "action"]
    assert state_keys and set(state_keys) <= set(policy.out_keys)  # the retriever's recurrent state is written
    td = env.reset()
    seen = np.zeros(2, bool)
    kinds = []
    for _ in range(8):
        seen |= np.array([recreate(td[b]).target_detected for b in range(2)])
        own = alone(td.clone())  # the planner alone on the same history, from the episode's start
        searched = scripted(td.select(*scripted.in_keys).copy())["action"]
        td = policy(td)
        for b in range(2):
            assert torch.equal(td["action"][b], own["action"][b] if seen[b] else searched[b])
        for key in state_keys:  # its memory follows every step, before the hand-over too
            assert torch.equal(td[key], own[key])
        kinds.append(seen.copy())
        td = step_mdp(env.step(td))
    kinds = np.array(kinds)
    assert kinds.any() and not kinds.all()  # both parts acted in this test


def test_the_hierarchical_search_is_asked_only_where_it_goes_on():
    from occrl.baselines import HierarchicalPlanner
    from occrl.baselines.observed_clearing import ObservedClearingRetriever

    env = make_env(batch_size=3, stage=2, seed=1, heatmap_target=False)
    searcher = HierarchicalPlanner(sweep_from="nearest", stop_when_located=True, seed=0)
    retriever, alone = ObservedClearingRetriever(), ObservedClearingRetriever()
    policy = SearchThenRetrieve(searcher, retriever, retriever_follows=True)
    td = env.reset()
    asked = np.zeros(3, int)
    for _ in range(6):
        searching = ~np.array([recreate(td[b]).target_detected for b in range(3)]) & ~(
            policy.handed if policy.handed is not None else np.zeros(3, bool)
        )
        asked += searching
        own = alone(td.select(*alone.in_keys).copy())["action"]  # the retriever alone, from the episode's start
        td = policy(td)
        for b in np.flatnonzero(~searching):
            assert torch.equal(td["action"][b], own[b])
        td = step_mdp(env.step(td))
    assert [ep.step for ep in searcher.episodes] == asked.tolist()  # the handed-over worlds' searches stood still
    assert 0 < asked.sum() < 18
