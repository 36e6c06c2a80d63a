"""Behaviour guard: seeded episodes and presets equal their recorded fingerprints
(occrl/fingerprints.py; re-record with scripts/record_fingerprints.py only for a change that
alters behaviour on purpose)."""

import json
from pathlib import Path

import pytest

from occrl.fingerprints import EPISODES, episode_fingerprint, preset_fingerprints

RECORDED = json.loads((Path(__file__).parent / "data" / "fingerprints.json").read_text())


def test_presets_are_unchanged():
    assert preset_fingerprints() == RECORDED["presets"]


@pytest.mark.parametrize("method,stage,seed", EPISODES)
def test_seeded_episode_is_unchanged(method, stage, seed):
    assert episode_fingerprint(method, stage, seed) == RECORDED["episodes"][f"{method}/stage{stage}/seed{seed}"]
