import numpy as np
import pytest

from occrl.baselines import ScriptedRetriever
from occrl.baselines.scripted import plan_grasp
from occrl.envs import ShelfEnv
from occrl.envs.episodes import run_episodes, task_scenes
from occrl.eval.runner import summarize
from tests.helpers import scene


def test_retrieves_a_visible_target_from_an_empty_shelf():
    td = ShelfEnv(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)])]).rollout(50, ScriptedRetriever())
    assert td["next", "success"].any() and td.shape[-1] < 20


def test_plans_avoid_walls_and_clutter():
    target = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]) + [0.0, 0.2]
    blocker = np.array([[-0.008, -0.008], [0.008, -0.008], [0.008, 0.008], [-0.008, 0.008]]) + [0.0, 0.12]  # straight in front
    angle, grasp = plan_grasp(target, [blocker])
    assert angle != 0.0  # a straight approach would push the blocker into the target
    angle0, grasp0 = plan_grasp(target, [])
    assert angle0 == 0.0 and grasp0[0] == pytest.approx(0.0, abs=1e-9)


def test_success_on_a_few_stage1_seeds():
    seeds = list(range(12))
    results = run_episodes(ScriptedRetriever(), task_scenes(1, seeds), seeds, batch_size=12)
    assert summarize(results)["success_rate"] >= 0.8


@pytest.mark.slow
def test_success_on_200_stage1_seeds_is_at_least_95_percent():
    seeds = list(range(200))
    results = run_episodes(ScriptedRetriever(), task_scenes(1, seeds), seeds, batch_size=20)
    assert summarize(results)["success_rate"] >= 0.95
