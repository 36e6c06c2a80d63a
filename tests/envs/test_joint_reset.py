"""Kept joints with their impulses zeroed (occrl.envs.pymunk2d.joint_reset) step the worlds bit for
bit as new joints built at every action do."""

import pytest
import torch

from occrl.baselines import ScriptedRetriever
from occrl.envs import make_env
from occrl.envs.pymunk2d import joint_reset


def _episodes(noise: float):
    env = make_env(batch_size=3, stage=2, noise=noise, seed=5, heatmap_target=False)
    return env.rollout(45, ScriptedRetriever(), break_when_any_done=False)


def test_the_layout_check_passes_on_the_installed_pymunk():
    assert joint_reset.AVAILABLE  # else the worlds silently fall back to new joints (slower)


@pytest.mark.integration
@pytest.mark.parametrize("noise", [0.0, 0.15])
def test_kept_joints_step_as_new_joints_bit_for_bit(noise, monkeypatch):
    kept = _episodes(noise)
    monkeypatch.setattr(joint_reset, "AVAILABLE", False)
    new = _episodes(noise)
    assert kept["next", "privileged", "target_held"].any()  # grasps: the weld joints come and go
    for key in (("next", "privileged", "object_pose"), ("next", "gripper_pose"), ("next", "gripper_opening"), ("next", "reward")):
        assert torch.equal(kept[key], new[key]), key


def test_a_layout_probe_that_fails_or_raises_means_the_fallback(caplog):
    from occrl.envs.pymunk2d.chipmunk_layout import layout_confirmed

    assert layout_confirmed(lambda: True, "unused")
    with caplog.at_level("INFO", logger="occrl.envs.pymunk2d.chipmunk_layout"):
        assert not layout_confirmed(lambda: False, "the slow path")
        assert not layout_confirmed(lambda: {}["missing"], "the slow path")
    assert caplog.text.count("the slow path") == 2
