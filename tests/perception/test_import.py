"""occrl.perception is importable without torch, and without OpenCV until a detector is made."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, env={"PYTHONPATH": str(ROOT), "PATH": ""})


def test_import_leaves_torch_out():
    done = run("import sys, occrl.perception; print('torch' in sys.modules, 'cv2' in sys.modules)")
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "False"]


def test_missing_opencv_names_the_extra():
    code = (
        "import sys; sys.modules['cv2'] = None\n"
        "from occrl.perception import CameraModel, TagCatalogue, TagDetector\n"
        "box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]\n"
        "cat = TagCatalogue.from_dict({'objects': [{'type_id': 3, 'height': 0.1, 'footprint': box,"
        " 'tags': [{'tag_id': 0, 'face': 0, 'offset': [0, 0.05], 'size': 0.03}]}]})\n"
        "TagDetector(CameraModel.from_fov(640, 480, 70.0), cat)\n"
    )
    done = run(code)
    assert done.returncode != 0
    assert 'ImportError: the tag detector and the tag sheet need OpenCV: pip install "occrl[camera]"' in done.stderr


def test_limits_are_the_observations():
    from occrl.envs import world_constants
    from occrl.envs.observation import MAX_POLY_VERTICES, MAX_SLOTS, MAX_TYPE_ID
    from occrl.perception import catalogue, checks, detector

    assert catalogue.MAX_TYPE_ID == MAX_TYPE_ID
    assert detector.MAX_DETECTIONS == MAX_SLOTS
    assert (checks.MIN_VERTICES, checks.MAX_VERTICES) == (world_constants.MIN_VERTICES, MAX_POLY_VERTICES)
