import json

import numpy as np
import pytest

from occrl.envs import Scene
from occrl.envs.scene_files import SCENES_FORMAT, load_scenes, save_scenes


def test_scenes_come_back_bit_for_bit(tmp_path):
    scenes = [Scene.sample(stage=s % 3 + 1, seed=s) for s in range(6)]
    path = tmp_path / "pool.json"
    save_scenes(path, scenes, meta={"stage": 2})
    back, meta = load_scenes(path)
    assert meta == {"stage": 2}
    assert len(back) == len(scenes)
    for a, b in zip(back, scenes):
        assert a.gripper_pose == b.gripper_pose and (a.stage, a.seed) == (b.stage, b.seed)
        for oa, ob in zip(a.objects, b.objects):
            assert np.array_equal(oa.vertices, ob.vertices) and oa.pose == ob.pose and oa.is_target == ob.is_target


def test_bad_scenes_files_are_refused_with_the_reason(tmp_path):
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps({"format": "something-else", "scenes": []}))
    with pytest.raises(ValueError, match="expected a scenes file of format 'occrl-scenes-v1', got 'something-else'"):
        load_scenes(wrong)
    with pytest.raises(ValueError, match="not a readable scenes file"):
        load_scenes(tmp_path / "missing.json")
    # a scene that breaks Scene's checks (two objects on top of each other) names its index
    path = tmp_path / "pool.json"
    save_scenes(path, [Scene.sample(stage=1, seed=0), Scene.sample(stage=2, seed=1)])
    data = json.loads(path.read_text())
    data["scenes"][1]["objects"][1]["pose"] = data["scenes"][1]["objects"][0]["pose"]
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="scene 1 is invalid .*overlap"):
        load_scenes(path)
    assert data["format"] == SCENES_FORMAT
    with pytest.raises(TypeError, match="occrl.envs.Scene"):
        save_scenes(tmp_path / "x.json", ["not a scene"])
