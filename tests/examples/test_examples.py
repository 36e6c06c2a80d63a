import runpy
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_plan_from_detections_runs(capsys):
    runpy.run_path(str(EXAMPLES / "plan_from_detections.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "root states:" in out and "action: forward" in out


def test_compose_components_runs(capsys):
    runpy.run_path(str(EXAMPLES / "compose_components.py"), run_name="__main__")
    out = capsys.readouterr().out
    assert "loss_heatmap" in out and "gradient reaches the swapped encoder: True" in out
