"""Behaviour guard: seeded episodes and presets equal their recorded fingerprints
(occrl/fingerprints.py; re-record with scripts/record_fingerprints.py only for a change that
alters behaviour on purpose)."""

import json
from pathlib import Path

import pytest

from occrl.fingerprints import ACTION_TOLERANCE, EPISODES, episode_fingerprint, preset_fingerprints, recorded_difference, same_episode

RECORDED = json.loads((Path(__file__).parent / "data" / "fingerprints.json").read_text())


def test_presets_are_unchanged():
    """Every preset's settings equal the recorded ones read as a checkpoint's are: settings removed
    since were recorded at their "off" value (anything else is refused), the others are equal."""
    from occrl.training import TrainConfig

    recorded = {name: TrainConfig.from_dict(settings).to_dict() for name, settings in RECORDED["presets"].items()}
    assert preset_fingerprints() == recorded


@pytest.mark.integration
@pytest.mark.parametrize("method,stage,seed", EPISODES)
def test_seeded_episode_is_unchanged(method, stage, seed):
    key = f"{method}/stage{stage}/seed{seed}"
    difference = recorded_difference(
        episode_fingerprint(method, stage, seed), RECORDED["episodes"][key], RECORDED.get("alternates", {}).get(key, [])
    )
    assert difference is None, difference


def test_the_comparison_tells_a_changed_episode():
    recorded = RECORDED["episodes"][f"{EPISODES[0][0]}/stage{EPISODES[0][1]}/seed{EPISODES[0][2]}"]
    nudged = [list(a) for a in recorded["actions"]]
    nudged[-1][0] += 2 * ACTION_TOLERANCE
    assert same_episode({**recorded, "actions": nudged}, recorded) is False
    nudged[-1][0] = recorded["actions"][-1][0] + ACTION_TOLERANCE / 2
    assert same_episode({**recorded, "actions": nudged}, recorded) is True
    assert same_episode({**recorded, "steps": recorded["steps"] + 1}, recorded) is False


def test_an_alternate_passes_only_its_own_episode():
    recorded = RECORDED["episodes"][f"{EPISODES[0][0]}/stage{EPISODES[0][1]}/seed{EPISODES[0][2]}"]
    other = {**recorded, "actions": [list(a) for a in recorded["actions"]], "machine": "another CPU"}
    other["actions"][0][0] += 0.5
    assert recorded_difference(other, recorded) is not None
    assert recorded_difference(other, recorded, [other]) is None
    assert recorded_difference(recorded, recorded, [other]) is None
    third = {**other, "actions": [list(a) for a in other["actions"]]}
    third["actions"][0][0] += 0.5
    assert "alternate" in recorded_difference(third, recorded, [other])
