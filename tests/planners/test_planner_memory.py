"""The hybrid planner's memory of objects (``remember_objects``): it feeds the recreated worlds
only, leaves the target to the heat-map, starts afresh each episode and changes nothing it reads."""

import pytest
import torch

from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner


def first_observation(seed: int = 4):
    """A stage-2 shelf's first observation with at least two objects other than the target detected."""
    net = make_occnet("paper").eval()
    env = make_env(batch_size=1, stage=2, seed=seed, heatmap_target=False).append_transform(net.make_primer())
    td = env.reset()
    return net, td


def planned_types(planner: HybridPlanner) -> set[int]:
    """The types of the objects other than the target in the state the last decision planned in
    (its first root's; the target's pose there is the heat-map's while it is not detected)."""
    return {o.type_id for o in planner.decisions[-1].roots[0].state.objects if not o.is_target}


def hide(td, types):
    """The same observation, not the first of its episode, with the slots of ``types`` undetected."""
    out = td.clone()
    out.set("is_init", torch.zeros_like(out.get("is_init")))
    objects = out.get("objects")
    hidden = torch.isin(objects.get("type_id"), torch.tensor(sorted(types)))
    objects.set("detected", objects.get("detected") & ~hidden)
    return out


def seen_types(td) -> tuple[list[int], int]:
    objects = td.get("objects")
    types = objects.get("type_id")[0][objects.get("detected")[0]].tolist()
    return types, int(td.get("target_type").reshape(-1)[0])


def test_objects_seen_before_stay_in_the_recreated_world_while_the_target_does_not():
    net, td = first_observation()
    types, target = seen_types(td)
    others = [t for t in types if t != target]
    assert target in types and len(others) >= 2, "the fixture's shelf must show the target and two other objects"
    hidden = {others[0], target}
    later = hide(td, hidden)
    before = later.get(("objects", "detected")).clone()
    for remember, expected in ((False, set(others) - hidden), (True, set(others))):
        planner = HybridPlanner(net, m=1, h=1, remember_objects=remember)
        planner(td.clone())
        assert planned_types(planner) == set(others)
        planner(later)
        assert planned_types(planner) == expected
        assert torch.equal(later.get(("objects", "detected")), before)  # the observation itself is unchanged
    # what the recreated worlds read: the hidden object remembered, the hidden target not
    planner = HybridPlanner(net, m=1, h=1, remember_objects=True)
    planner(td.clone())
    objects = planner.remembered(later.reshape(-1)).get("objects")
    planned = set(objects.get("type_id")[0][objects.get("detected")[0]].tolist())
    assert planned == set(types) - {target}


def test_an_episode_start_forgets_and_a_moved_object_is_dropped():
    net, td = first_observation()
    types, target = seen_types(td)
    other = next(t for t in types if t != target)
    planner = HybridPlanner(net, m=1, h=1, remember_objects=True)
    planner(td.clone())
    start = hide(td, {other})
    start.set("is_init", torch.ones_like(start.get("is_init")))  # a new episode: nothing remembered
    planner(start)
    assert other not in planned_types(planner)
    planner(hide(td, {other}))  # ... and remembers only what it saw after the start
    assert other not in planned_types(planner)
    # seen again, then the gripper moves onto where it was: the memory takes it to have moved
    planner(td.clone())
    later = hide(td, {other})
    objects = later.get("objects")
    slot = int((objects.get("type_id")[0] == other).nonzero()[0, 0])
    later.set("gripper_pose", objects.get("pose")[:, slot].clone())
    planner(later)
    assert other not in planned_types(planner)


def test_remember_objects_must_be_a_bool():
    with pytest.raises(TypeError, match="remember_objects must be a bool"):
        HybridPlanner(make_occnet("paper"), remember_objects="yes")
