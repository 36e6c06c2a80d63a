import numpy as np
import pytest

from occrl.baselines import ScriptedRetriever
from occrl.baselines.clearing import ClearingRetriever, clearing_plan, find_spot, find_spot_by_simulation
from occrl.baselines.scripted import grasp_candidates, path_clear
from occrl.envs import ShelfEnv
from occrl.envs.episodes import run_episodes, task_scenes
from occrl.envs.geometry import polygons_overlap
from occrl.eval.runner import summarize
from tests.helpers import scene, square


def box(half: float, x: float, y: float) -> np.ndarray:
    return np.array(square(half)) + [x, y]


TARGET = box(0.02, 0.0, 0.27)
ROW = [box(0.02, x, 0.15) for x in (-0.055, 0.0, 0.055)]  # a row of blockers in front of it


def _band_count(plan, target, clutter):
    """How many clutter objects reach between the fingers on the way in to ``plan``."""
    angle, grasp = plan
    for a, grasps, band, _ in grasp_candidates(target, clutter, angle):
        if a == angle:
            k = int(np.argmin(np.linalg.norm(grasps - grasp, axis=1)))
            return int(band[:, k].sum())
    raise AssertionError("the plan is not among the candidates")


def test_the_approach_has_the_fewest_objects_to_carry_aside():
    plan = clearing_plan(TARGET, ROW)
    fewest = min(
        int(band[:, k].sum())
        for a, grasps, band, _ in grasp_candidates(TARGET, ROW)
        for k in range(len(grasps))
        if path_clear(grasps[k], a)
    )
    assert _band_count(plan, TARGET, ROW) == fewest == 1  # the row leaves no free way in, one carry opens one


def test_a_spot_takes_the_blocker_out_of_the_corridor_without_touching_anything():
    blocker, others = ROW[1], [TARGET, ROW[0], ROW[2]]
    gripper = np.array([0.0, 0.15 - 0.03, 0.0])  # the closed fingers around the middle blocker
    lanes = (np.array([0.0, 0.27 - 0.024]), 0.0, 0.085 / 2 + 0.012, -0.3, 0.045)  # a straight way in
    start, end = find_spot(gripper, blocker, others, lanes)
    moved = blocker + (end - blocker.mean(axis=0))
    assert abs(moved[:, 0]).min() > lanes[2]  # beside the corridor
    assert not any(polygons_overlap(moved, o) for o in others)
    assert start[1] <= blocker.mean(axis=0)[1] and moved[:, 1].mean() > 0.0  # backed out, still in the shelf
    packed = others + [box(0.03, x, y) for x in np.arange(-0.2, 0.21, 0.07) for y in (0.05, 0.11) if abs(x) > 0.05]
    assert find_spot(gripper, blocker, packed, lanes) is None  # no room anywhere: none


def test_a_simulated_carry_may_push_a_neighbour_when_no_spot_is_clear():
    gripper = np.array([0.0, 0.12, 0.0])  # the closed fingers around the middle blocker
    lanes = (np.array([0.0, 0.27 - 0.024]), 0.0, 0.085 / 2 + 0.012, -0.3, 0.045)
    packed = [box(0.03, x, y) for x in np.arange(-0.2, 0.21, 0.07) for y in (0.05, 0.11) if abs(x) > 0.05]
    clutter = [*ROW, *packed]
    assert find_spot(gripper, ROW[1], [TARGET, ROW[0], ROW[2], *packed], lanes) is None
    start, end = find_spot_by_simulation(gripper, 1, TARGET, clutter, lanes)
    assert abs(end[0]) - 0.02 > lanes[2]  # the spot lies beside the corridor
    far = np.array([0.0, -0.2, 0.0])
    assert find_spot_by_simulation(far, 1, TARGET, clutter, lanes) is None  # not held in the simulator: none


def test_carries_a_blocker_aside_where_the_scripted_retriever_fails():
    seed = [20007]  # a stage-2 shelf (7 objects) with the target behind clutter
    scripted = run_episodes(ScriptedRetriever(), task_scenes(2, seed), seed, batch_size=1)[0]
    clearing = ClearingRetriever()
    result = run_episodes(clearing, task_scenes(2, seed), seed, batch_size=1)[0]
    assert not scripted.success and result.success
    assert clearing.carries == 1  # one object carried aside


def test_retrieves_a_visible_target_from_an_empty_shelf_as_the_scripted_retriever_does():
    env = ShelfEnv(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)])])
    clearing, scripted = env.rollout(50, ClearingRetriever()), env.rollout(50, ScriptedRetriever())
    assert clearing["next", "success"].any() and np.array_equal(clearing["action"].numpy(), scripted["action"].numpy())


@pytest.mark.integration
def test_success_on_a_few_stage2_seeds_is_above_the_scripted_retriever():
    seeds = list(range(20000, 20020))
    clearing = summarize(run_episodes(ClearingRetriever(), task_scenes(2, seeds), seeds, batch_size=20))
    scripted = summarize(run_episodes(ScriptedRetriever(), task_scenes(2, seeds), seeds, batch_size=20))
    assert clearing["success_rate"] > scripted["success_rate"]


def test_an_unknown_clearing_mode_is_refused():
    with pytest.raises(ValueError, match="clear must be one of"):
        ClearingRetriever(clear="everything")
