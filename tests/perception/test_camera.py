"""The camera model and its files: values, round trips, and clear errors for bad calibrations."""

import json
import math
import sys

import numpy as np
import pytest

from occrl.perception import CameraModel, forward_looking_hand_camera, load_camera, save_camera


def good() -> dict:
    return CameraModel.from_fov(640, 480, 70.0, hand_camera=forward_looking_hand_camera((0.0, 0.0, 0.025))).to_dict()


def test_from_fov_is_an_ideal_camera():
    camera = CameraModel.from_fov(640, 480, 70.0)
    assert camera.fx == camera.fy == pytest.approx(320 / math.tan(math.radians(35)))
    assert (camera.cx, camera.cy) == (319.5, 239.5)
    assert camera.horizontal_fov_deg == pytest.approx(70.0)
    np.testing.assert_array_equal(camera.intrinsic_matrix[2], [0, 0, 1])
    # the optical axis is the gripper's approach axis, the image's down is the gripper's -z
    np.testing.assert_array_equal(camera.hand_camera[:3, 2], [0, 1, 0])
    np.testing.assert_array_equal(camera.hand_camera[:3, 1], [0, 0, -1])


@pytest.mark.parametrize("suffix", [".json", ".yaml", ".yml"])
def test_file_round_trip(tmp_path, suffix):
    camera = CameraModel(**{**good(), "distortion": (0.1, -0.2, 0.001, 0.002, 0.05)})
    save_camera(camera, tmp_path / f"camera{suffix}")
    assert load_camera(tmp_path / f"camera{suffix}") == camera


def test_distortion_defaults_to_zero(tmp_path):
    data = good()
    del data["distortion"]
    (tmp_path / "c.json").write_text(json.dumps(data))
    assert load_camera(tmp_path / "c.json").distortion == (0.0,) * 5


def test_the_model_is_read_only():
    camera = CameraModel.from_fov(640, 480, 70.0)
    with pytest.raises(ValueError):
        camera.hand_camera[0, 3] = 1.0
    with pytest.raises(AttributeError):
        camera.fx = 1.0


@pytest.mark.parametrize(
    "change, message",
    [
        ({"cx": 700.0}, r"cx must lie in the image, \[0, 640\) pixels, got 700.0"),
        ({"cy": -1.0}, r"cy must lie in the image, \[0, 480\) pixels"),
        ({"fx": 0.0}, r"fx must be a finite number above 0 \(focal length in pixels\), got 0.0"),
        ({"fy": float("nan")}, r"fy must be a finite number above 0"),
        ({"fx": 457.0, "fy": 1500.0}, r"fx / fy = 0.305 is not a camera's pixel aspect"),
        ({"width": 640.0}, r"width must be an int, got 640.0"),
        ({"height": 4}, r"height must be in \[8, 100000\), got 4"),
        ({"distortion": [0.1, 0.2]}, r"distortion must be 5 numbers \(k1, k2, p1, p2, k3\), OpenCV's order"),
        (
            {"hand_camera": np.diag([1.0, 1.0, -1.0, 1.0]).tolist()},
            r"hand_camera must be a rigid transform: its rotation has determinant -1",
        ),
        ({"hand_camera": (2 * np.eye(4)).tolist()}, r"hand_camera must have the last row \(0, 0, 0, 1\)"),
        ({"hand_camera": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, r"hand_camera must be a 4x4 homogeneous transform"),
    ],
)
def test_bad_calibration_is_named(tmp_path, change, message):
    with pytest.raises((ValueError, TypeError), match=message):
        CameraModel(**{**good(), **change})
    (tmp_path / "c.json").write_text(json.dumps({**good(), **change}))
    with pytest.raises((ValueError, TypeError), match="camera file .*c.json: " + message):
        load_camera(tmp_path / "c.json")


def test_missing_and_unknown_keys(tmp_path):
    data = good()
    del data["hand_camera"], data["fy"]
    (tmp_path / "c.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"is missing \['fy', 'hand_camera'\]; required: "):
        load_camera(tmp_path / "c.json")
    (tmp_path / "c.json").write_text(json.dumps({**good(), "k1": 0.1}))
    with pytest.raises(ValueError, match=r"unknown keys \['k1'\]"):
        load_camera(tmp_path / "c.json")
    (tmp_path / "c.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="must hold a mapping"):
        load_camera(tmp_path / "c.json")
    (tmp_path / "c.json").write_text("{")
    with pytest.raises(ValueError, match="is not valid JSON"):
        load_camera(tmp_path / "c.json")


def test_missing_file_and_bad_suffix(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_camera(tmp_path / "nowhere.json")
    with pytest.raises(ValueError, match=r"the suffix must be .json, .yaml or .yml, got '.txt'"):
        load_camera(tmp_path / "camera.txt")


def test_yaml_without_pyyaml_names_the_pip_command(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "yaml", None)
    with pytest.raises(ImportError, match="pip install pyyaml"):
        save_camera(CameraModel.from_fov(640, 480, 70.0), tmp_path / "c.yaml")
    assert not (tmp_path / "c.yaml").exists()
