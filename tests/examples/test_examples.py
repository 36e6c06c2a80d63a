import runpy
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_plan_from_detections_runs(capsys):
    runpy.run_path(str(EXAMPLES / "plan_from_detections.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "root states:" in out and "action: forward" in out


def test_compose_components_runs(capsys):
    runpy.run_path(str(EXAMPLES / "compose_components.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "loss_heatmap" in out and "gradient reaches the swapped encoder: True" in out


def test_robot_loop_runs(capsys, monkeypatch):
    import pytest

    pytest.importorskip("mujoco")
    pytest.importorskip("cv2")
    from occrl.envs.mujoco3d.camera import gl_available

    if not gl_available()[0]:
        pytest.skip(f"no OpenGL backend for MuJoCo: {gl_available()[1]}")
    monkeypatch.setattr("sys.argv", ["robot_loop.py"])  # its defaults: 3 actions of hybrid-4x4
    runpy.run_path(str(EXAMPLES / "robot_loop.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "step 3: sees" in out and "status after 3 actions: running" in out


@pytest.mark.integration
def test_calibrate_simulated_camera_recovers_the_camera(capsys, monkeypatch, tmp_path):
    pytest.importorskip("mujoco")
    pytest.importorskip("cv2")
    from occrl.envs.mujoco3d.camera import gl_available

    if not gl_available()[0]:
        pytest.skip(f"no OpenGL backend for MuJoCo: {gl_available()[1]}")
    monkeypatch.setattr("sys.argv", ["calibrate_simulated_camera.py", "--out", str(tmp_path)])
    runpy.run_path(str(EXAMPLES / "calibrate_simulated_camera.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "the board in 16 of 16 images" in out and "the board in 12 of 12 images" in out
    assert (tmp_path / "camera.json").is_file() and (tmp_path / "hand" / "poses.json").is_file()
