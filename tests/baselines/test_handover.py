"""SearchThenRetrieve: the searcher acts until the target is first detected, the retriever after."""

import numpy as np
import torch
from torchrl.envs.utils import step_mdp

from occrl.baselines import ScriptedRetriever
from occrl.baselines.handover import SearchThenRetrieve
from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner, recreate


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
