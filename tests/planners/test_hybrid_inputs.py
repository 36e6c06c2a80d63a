"""Decision makers called without the LSTM's state entries say what is missing and how to add it."""

import pytest

from occrl.baselines import NetPolicy
from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner


@pytest.mark.parametrize("make", [lambda net: HybridPlanner(net, m=2, h=2), lambda net: NetPolicy(net, stochastic=True)])
def test_missing_recurrent_state_names_the_primer(make):
    net = make_occnet("paper")
    td = make_env(batch_size=1, seed=0).reset()  # no net.make_primer() on the env
    with pytest.raises(KeyError, match=r"recurrent_state_h.*append_transform\(net.make_primer\(\)\)"):
        make(net)(td)
    td = make_env(batch_size=1, seed=0).append_transform(net.make_primer()).reset()
    assert make(net)(td)["action"].shape == (1, 4)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(m=0), "m must be an int >= 1"),
        (dict(h=2.5), "h must be an int >= 1"),
        (dict(max_roots=0), "max_roots"),
        (dict(gamma=0.0), "gamma must be in"),
    ],
)
def test_planner_settings_are_range_checked(kwargs, match):
    with pytest.raises(ValueError, match=match):
        HybridPlanner(make_occnet("paper"), **kwargs)
    with pytest.raises(TypeError, match="OccNet"):
        HybridPlanner("occnet")
