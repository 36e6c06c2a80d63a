"""The hierarchical baseline (paper Alg. 3): scripted Search, OMPL plans in the recreated sim."""

import logging
import time

import numpy as np
import pytest
import torch

from occrl.baselines.hiding import HidingRegion
from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.baselines.goals import ReachGoal, grasp_poses
from occrl.baselines.kinodynamic import SimControlProblem
from occrl.baselines.motion import OPEN
from occrl.envs import ShelfWorld, make_env
from occrl.envs import world_constants as C
from tests.helpers import scene, square

# An occluder near the front right and the target 2 cm behind it, 1 cm further out: from every
# view of the Search sweep (x in [-0.2, 0.2] at y = -0.1) at most half of the target is visible.
OCCLUDER = (0.15, 0.045, 0.0, False)
HIDDEN_TARGET = (0.16, 0.105, 0.0, True)


def _perception_only(planner):
    """The policy as it must behave: it only ever gets the observation without ground truth."""

    def policy(td):
        td.set("action", planner(td.exclude("privileged"))["action"])
        return td

    return policy


def test_retrieves_a_visible_target_from_an_empty_shelf():
    env = make_env(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)])], heatmap_target=False)
    planner = HierarchicalPlanner(seed=0)
    td = env.rollout(C.MAX_EPISODE_STEPS, policy=_perception_only(planner))
    assert td["next", "success"].any()
    assert td.shape[-1] <= C.MAX_EPISODE_STEPS
    assert [p.name for p in planner.last_plans if p.success] == ["reach", "extract"]
    assert td["action"].dtype == torch.float32 and td["action"].shape[-1] == C.ACTION_DIM
    # the sweep went from the far left to the far right, outside the shelf, camera pointing in
    xs = td["gripper_pose"][0, :, 0].numpy()
    assert xs.min() < -0.19 and xs.max() > 0.19
    assert np.argmin(xs) < np.argmax(xs)
    assert planner.planning_seconds > 0.0
    # a new episode (is_init) resets the per-episode accounting
    spent = planner.planning_seconds
    planner(env.reset())
    assert planner.planning_seconds < min(spent, 0.05) and planner.last_plans == []


@pytest.mark.integration
@pytest.mark.parametrize("seed", [0, 1])
def test_hidden_target_is_found_after_rearranging_the_occluder(seed):
    env = make_env(batch_size=1, scenes=[scene([OCCLUDER, HIDDEN_TARGET])], heatmap_target=False)
    # Search, Rearrange, Move_out, Search again and Retrieve in 50 actions: the second sweep has
    # to start at the near end and stop once the target is seen (the literal left-to-right full
    # sweeps cost about 53 actions here)
    planner = HierarchicalPlanner(sweep_from="nearest", stop_when_located=True, seed=seed)
    td = env.rollout(C.MAX_EPISODE_STEPS, policy=_perception_only(planner))
    detected = td["objects", "detected"][0, :, 1].numpy()  # slot 1: the target
    first_seen = int(np.argmax(detected))
    assert detected.any() and first_seen > 12  # the whole first sweep missed it
    names = [p.name for p in planner.last_plans if p.success]
    assert names[:2] == ["reach", "place"] and names[-2:] == ["reach", "extract"]
    occluder = td["next", "privileged", "object_pose"][0, -1, 0].numpy()
    assert occluder[1] > 0.25  # it went to the back of the shelf
    assert td["next", "success"][0, -1] and not td["next", "dropped"].any()
    assert td.shape[-1] <= C.MAX_EPISODE_STEPS


def _problem(seed=0):
    world = ShelfWorld(scene([(0.0, 0.2, 0.3, True), (0.1, 0.1, 0.0, False)], gripper=(0.0, -0.1, 0.0)))
    t = world.target_index
    goal = ReachGoal(t, world.nominal_vertices, grasp_poses(world, t), world.object_poses()[t])
    return SimControlProblem(world, goal, OPEN, seed=seed)


def _control(problem, values):
    control = problem.si.allocControl()
    for k, v in enumerate(values):
        control[k] = float(v)
    return control


def test_propagation_is_deterministic():
    problem = _problem()
    start = problem.start_state()
    push = _control(problem, [1.0, 0.6, -0.4, -1.0])
    a, b = problem.space.allocState(), problem.space.allocState()
    problem.propagate(start, push, 1.0, a)
    problem.propagate(start, push, 1.0, b)
    ia, ib = problem.index_of(a), problem.index_of(b)
    assert ia != ib  # two table entries ...
    ea, eb = problem.table[ia], problem.table[ib]
    assert np.array_equal(ea.gripper_pose, eb.gripper_pose)  # ... bit-identical
    assert np.array_equal(ea.object_poses, eb.object_poses)
    assert (ea.held, ea.opening, ea.closed) == (eb.held, eb.opening, eb.closed)

    def values(st):
        return [st[0].getX(), st[0].getY(), st[0].getYaw(), st[1][0], st[1][1]]

    assert values(a) == values(b)
    assert a[0].getY() > -0.1 + 0.04  # it moved (forward 5 cm)
    # a chain of steps from the children repeats as well; another control gives another state
    c, d = problem.space.allocState(), problem.space.allocState()
    problem.propagate(a, push, 1.0, c)
    problem.propagate(b, push, 1.0, d)
    assert np.array_equal(problem.table[problem.index_of(c)].object_poses, problem.table[problem.index_of(d)].object_poses)
    other = problem.space.allocState()
    problem.propagate(start, _control(problem, [1.0, -0.6, 0.4, -1.0]), 1.0, other)
    assert not np.array_equal(problem.table[problem.index_of(other)].gripper_pose, ea.gripper_pose)
    problem.close()


def test_planning_failure_in_a_tiny_budget_returns_cleanly(caplog):
    problem = _problem()
    t = time.perf_counter()
    plan = problem.solve(1e-3)
    assert time.perf_counter() - t < 1.0
    assert not plan.success and plan.actions == [] and plan.status
    problem.close()
    # in the policy: a logged failure, then the fallback (move out, search again); no hang
    env = make_env(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)])], heatmap_target=False)
    planner = HierarchicalPlanner(plan_seconds=1e-3, seed=0)
    with caplog.at_level(logging.WARNING, logger="occrl.baselines.hierarchical"):
        t = time.perf_counter()
        td = env.rollout(30, policy=_perception_only(planner))
        elapsed = time.perf_counter() - t
    assert td.shape[-1] == 30 and not td["next", "success"].any() and elapsed < 20.0
    failures = [p for p in planner.last_plans if not p.success]
    assert failures and all(p.name == "reach" for p in failures)
    assert any("plan not found within" in r.getMessage() for r in caplog.records)
    # after a failure the robot sweeps again: the far left is visited twice
    xs = td["gripper_pose"][0, :, 0].numpy()
    assert (np.diff((xs < -0.19).astype(int)) == 1).sum() >= 2


def test_hiding_region_covers_the_hidden_target_only():
    occluder = scene([OCCLUDER, HIDDEN_TARGET]).objects[0].world_vertices()
    views = [(np.array([x, -0.1, 0.0]), [occluder]) for x in np.arange(-0.2, 0.201, 0.05)]
    region = HidingRegion(np.array(square(0.02)), views, [occluder])
    inside = region(np.array([HIDDEN_TARGET[:2], (-0.1, 0.2), (0.0, 0.3), (0.15, 0.045), (0.0, -0.1)]))
    assert inside.tolist() == [True, False, False, False, False]
    assert region.mask.mean() < 0.05


def test_rejects_bad_arguments():
    with pytest.raises(ValueError, match="planner"):
        HierarchicalPlanner(planner="prm")
    with pytest.raises(ValueError, match="search_y"):
        HierarchicalPlanner(search_y=0.1)


def test_move_out_backs_straight_out_when_every_candidate_motion_is_rejected(monkeypatch):
    import occrl.baselines.primitives as primitives
    from occrl.planners import recreate

    env = make_env(batch_size=1, scenes=[scene([(0.1, 0.3, 0.0, True)], gripper=(0.0, 0.15, 0.0))], heatmap_target=False)
    obs = env.reset()[0].exclude("privileged")
    monkeypatch.setattr(primitives, "motion_allowed", lambda *args, **kwargs: False)  # every simulated candidate "collides"
    pose = obs["gripper_pose"].numpy().astype(float)
    actions, poses = primitives.move_out(recreate(obs), pose, None, search_y=HierarchicalPlanner().search_y)
    assert len(actions) > 1 and len(poses) == len(actions)
    assert poses[-1][1] < poses[0][1]  # the simulated poses move out of the shelf
    assert all(a[0] < 0 and a[3] <= 0 for a in actions)  # backwards, gripper open


def test_replan_inside_plans_from_where_the_gripper_is():
    """The paper's planner backs a gripper out of the shelf before it searches; with
    ``replan_inside`` it plans the retrieval of a target it has seen from where the gripper is: at
    the start of a Search inside the shelf, and when the world leaves a Move_out plan."""
    tolerance = (0.01, np.radians(10.0))
    inside = (0.0, 0.04, 0.0)  # the gripper's fingers in the shelf, the target in view ahead

    def first_steps(replan_inside, switch_on_after_push=False):
        env = make_env(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)], gripper=inside)], heatmap_target=False)
        planner = HierarchicalPlanner(seed=0, plan_seconds=0.5, follow_tolerance=tolerance, replan_inside=replan_inside)
        td = env.reset()
        kinds = []
        for t in range(3):
            td = planner(td.exclude("privileged")).update(td.select("privileged"))
            kinds.append(planner.last_action_kinds[0])
            if t == 0 and kinds[0] == "move_out":  # leave the Move_out plan: sideways instead
                td["action"] = torch.tensor([[0.0, 1.0, 0.0, -1.0]])
                if switch_on_after_push:
                    planner.replan_inside = True
            td = env.step(td)["next"]
        return kinds, planner.episodes[0]

    kinds, ep = first_steps(replan_inside=False)  # the paper: out first, and out again after the push
    assert kinds[:2] == ["move_out", "move_out"] and ep.replans == 1
    kinds, ep = first_steps(replan_inside=True)  # the target is in view: reach from inside at once
    assert kinds[0] == "reach" and ep.replans == 0
    kinds, ep = first_steps(replan_inside=False, switch_on_after_push=True)  # a Move_out plan left
    assert kinds[:2] == ["move_out", "reach"] and ep.replans == 1

    with pytest.raises(ValueError, match="follow_tolerance"):
        HierarchicalPlanner(replan_inside=True)
