"""The gripper's contact test read from Chipmunk's arbiter list (occrl.envs.pymunk2d.contact_list)
answers as pymunk's each_arbiter does, so the worlds step bit for bit as with each_arbiter."""

import pymunk
import pytest
import torch

from occrl.baselines import ScriptedRetriever
from occrl.envs import make_env
from occrl.envs.pymunk2d import contact_list
from occrl.envs.pymunk2d.world import ShelfWorld


def _episodes(noise: float):
    env = make_env(batch_size=3, stage=2, noise=noise, seed=5, heatmap_target=False)
    return env.rollout(45, ScriptedRetriever(), break_when_any_done=False)


def test_the_layout_check_passes_on_the_installed_pymunk():
    assert contact_list.AVAILABLE  # else the worlds silently ask each_arbiter (slower)


def test_the_head_agrees_with_each_arbiter_through_contact_and_release():
    space = pymunk.Space()
    space.add(pymunk.Segment(space.static_body, (-1.0, 0.0), (1.0, 0.0), 0.01))
    body = pymunk.Body(1.0, 1.0)
    space.add(body, pymunk.Poly.create_box(body, (0.1, 0.1)))
    head = contact_list.arbiter_head(body)
    answers = []
    for y in (2.0, 0.05, 0.06, 3.0, 0.04, 1.0):
        body.position = (0.0, y)
        space.step(0.01)
        seen = []
        body.each_arbiter(seen.append)
        assert contact_list.has_arbiters(head) == bool(seen), y
        answers.append(bool(seen))
    assert answers == [False, True, True, False, True, False]


@pytest.mark.integration
@pytest.mark.parametrize("noise", [0.0, 0.15])
def test_worlds_step_as_with_each_arbiter_bit_for_bit(noise, monkeypatch):
    answers = []
    each_arbiter_test = ShelfWorld._gripper_touches

    def recorded(world, head=None):
        answers.append(each_arbiter_test(world, head))
        return answers[-1]

    monkeypatch.setattr(ShelfWorld, "_gripper_touches", recorded)
    fast = _episodes(noise)
    assert not answers  # the substeps read the arbiter list inline
    monkeypatch.setattr(contact_list, "AVAILABLE", False)
    slow = _episodes(noise)
    assert any(answers) and not all(answers)  # each_arbiter answered: the gripper touched and did not
    for key in (("next", "privileged", "object_pose"), ("next", "gripper_pose"), ("next", "gripper_opening"), ("next", "reward")):
        assert torch.equal(fast[key], slow[key]), key
