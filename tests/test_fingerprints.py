"""Behaviour guard: seeded episodes and presets equal their recorded fingerprints
(occrl/fingerprints.py; re-record with scripts/record_fingerprints.py only for a change that
alters behaviour on purpose)."""

import json
from pathlib import Path

import numpy as np
import pytest

from occrl.fingerprints import ACTION_TOLERANCE, EPISODES, episode_fingerprint, preset_fingerprints, same_episode

RECORDED = json.loads((Path(__file__).parent / "data" / "fingerprints.json").read_text())


def test_presets_are_unchanged():
    assert preset_fingerprints() == RECORDED["presets"]


@pytest.mark.parametrize("method,stage,seed", EPISODES)
def test_seeded_episode_is_unchanged(method, stage, seed):
    fingerprint, recorded = episode_fingerprint(method, stage, seed), RECORDED["episodes"][f"{method}/stage{stage}/seed{seed}"]
    if not same_episode(fingerprint, recorded):
        outcome = {k: (fingerprint[k], recorded[k]) for k in ("steps", "success", "dropped")}
        n = min(fingerprint["steps"], recorded["steps"])
        moved = np.abs(np.asarray(fingerprint["actions"][:n]) - np.asarray(recorded["actions"][:n])).max(axis=1)
        first = int(np.argmax(moved > ACTION_TOLERANCE)) if (moved > ACTION_TOLERANCE).any() else None
        pytest.fail(f"(now, recorded): {outcome}; first action off by more than {ACTION_TOLERANCE:g}: {first}")


def test_the_comparison_tells_a_changed_episode():
    recorded = RECORDED["episodes"][f"{EPISODES[0][0]}/stage{EPISODES[0][1]}/seed{EPISODES[0][2]}"]
    nudged = [list(a) for a in recorded["actions"]]
    nudged[-1][0] += 2 * ACTION_TOLERANCE
    assert same_episode({**recorded, "actions": nudged}, recorded) is False
    nudged[-1][0] = recorded["actions"][-1][0] + ACTION_TOLERANCE / 2
    assert same_episode({**recorded, "actions": nudged}, recorded) is True
    assert same_episode({**recorded, "steps": recorded["steps"] + 1}, recorded) is False
