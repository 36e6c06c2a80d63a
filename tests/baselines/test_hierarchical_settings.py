"""The hierarchical planner's settings are range-checked at construction."""

import pytest

pytest.importorskip("ompl")

from occrl.baselines import HierarchicalPlanner  # noqa: E402


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(plan_seconds=0), "plan_seconds"),
        (dict(planner="prm"), "planner"),
        (dict(sweep_from="right"), "sweep_from"),
        (dict(search_y=0.1), "search_y"),
        (dict(sweep_x=0.0), "sweep_x"),
        (dict(extract_margin=-0.01), "extract_margin"),
        (dict(place_radius=0.5), "place_radius"),
        (dict(time_limit=0.0), "time_limit"),
        (dict(restart_seconds=0.0), "restart_seconds"),
    ],
)
def test_bad_settings_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        HierarchicalPlanner(**kwargs)
