import pytest
import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "sweep_claims.py"


def _row(method, sweep, value, rate, half=0.05):
    return {
        "method": method,
        "sweep": sweep,
        "value": value,
        "tasks": 300,
        "successes": int(300 * rate),
        "success_rate": rate,
        "dropped": 0,
        "mean_actions": 20.0,
        "mean_seconds": 1.0,
        "ci95_low": rate - half,
        "ci95_high": rate + half,
    }


def _claims(tmp_path, rows):
    path = tmp_path / "results.json"
    path.write_text(json.dumps(rows))
    out = subprocess.run([sys.executable, str(SCRIPT), str(path), "--tables"], capture_output=True, text=True, check=True).stdout
    assert "success (%) against objects" in out and "| hybrid-4x4 | " in out
    rows = [line.strip("| ").split(" | ") for line in out.splitlines() if line.startswith("| ") and " | " in line]
    return {cells[0]: cells[2] for cells in rows if len(cells) == 4}


def _spread(tmp_path, rows) -> dict:
    path = tmp_path / "results.json"
    path.write_text(json.dumps(rows))
    out = subprocess.run([sys.executable, str(SCRIPT), str(path)], capture_output=True, text=True, check=True).stdout
    rows = [line.strip("| ").split(" | ") for line in out.splitlines() if line.startswith("| ")]
    return {cells[0]: cells[3] for cells in rows if len(cells) == 4}


@pytest.mark.integration
def test_a_sweep_shaped_like_the_papers_agrees_with_every_claim(tmp_path):
    rows = []
    for sweep, values in (("clutter", [1.0, 10.0]), ("noise", [0.0, 0.25])):
        for i, v in enumerate(values):
            fall = 0.1 * i
            rows += [
                _row("hybrid-6x6", sweep, v, 0.95 - fall),
                _row("hybrid-4x4", sweep, v, 0.93 - fall),
                _row("hybrid-2x2", sweep, v, 0.9 - fall),
                _row("hybrid-lim-4x4", sweep, v, 0.9 - fall),
                _row("stochastic", sweep, v, 0.8 - fall - (0.1 * i if sweep == "noise" else 0)),
                _row("greedy", sweep, v, 0.6 - fall + (0.05 * i if sweep == "noise" else 0)),
                _row("stochastic-gen", sweep, v, 0.8 - fall),
                _row("hierarchical", sweep, v, 0.85 - 0.6 * i),
            ]
    verdicts = _claims(tmp_path, rows)
    assert verdicts["hybrid (4x4) beats every baseline"] == "agrees"
    assert verdicts["larger m x h helps"] == "agrees"
    assert verdicts["hybrid-lim is slightly below hybrid"] == "agrees"
    assert verdicts["stochastic beats greedy at low noise; they converge at high noise"] == "agrees"
    assert verdicts["hierarchical drops sharpest (clutter)"] == "agrees"
    assert verdicts["success falls with noise"] == "agrees"


@pytest.mark.integration
def test_a_baseline_clearly_above_the_hybrid_is_a_disagreement(tmp_path):
    rows = [
        _row("hybrid-4x4", "clutter", 1.0, 0.5),
        _row("greedy", "clutter", 1.0, 0.9),
        _row("hybrid-4x4", "clutter", 2.0, 0.5),
        _row("greedy", "clutter", 2.0, 0.9),
    ]
    verdicts = _claims(tmp_path, rows)
    assert verdicts["hybrid (4x4) beats every baseline"].startswith("disagrees (2 pairs clearly lower)")


@pytest.mark.integration
def test_methods_on_the_same_tasks_are_compared_by_mcnemar_on_the_sweeps_episodes(tmp_path):
    # 100 tasks at one point: hybrid-4x4 solves 80, hybrid-lim-4x4 solves the same 80 but 10 of
    # them swapped for 10 others (10 / 10 exclusive: p = 1); hybrid-2x2 solves 60 of 4x4's 80 (20 / 0)
    (tmp_path / "points").mkdir()
    solved = {
        "hybrid-4x4": set(range(80)),
        "hybrid-lim-4x4": set(range(10, 90)),
        "hybrid-2x2": set(range(60)),
        "hybrid-6x6": set(range(80)),
    }
    rows = []
    for method, wins in solved.items():
        episodes = [{"seed": s, "objects": 1, "success": s in wins, "dropped": False, "actions": 9, "seconds": 0.1} for s in range(100)]
        point = {"method": method, "sweep": "clutter", "value": 1.0, "episodes": episodes}
        (tmp_path / "points" / f"{method}__clutter__1.json").write_text(json.dumps(point))
        rows.append(_row(method, "clutter", 1.0, len(wins) / 100) | {"tasks": 100, "successes": len(wins)})
    spread = _spread(tmp_path, rows)
    assert (
        "within the spread (hybrid-4x4 / hybrid-lim-4x4 alone solved 10 / 10 tasks, McNemar p = 1)"
        == spread["hybrid-lim is slightly below hybrid"]
    )
    assert spread["larger m x h helps"].startswith(
        "4x4 against 2x2: beyond the spread (hybrid-4x4 / hybrid-2x2 alone solved 20 / 0 tasks, McNemar p = 1.9e-06)"
    )
    # without the episodes the pooled intervals decide: 80 % and 60 % of 100 tasks separate
    (tmp_path / "points" / "hybrid-2x2__clutter__1.json").unlink()
    assert _spread(tmp_path, rows)["larger m x h helps"].startswith("4x4 against 2x2: beyond the spread (pooled 95 % intervals")


@pytest.mark.integration
def test_means_of_points_extended_to_different_task_counts_use_the_tasks_all_ran(tmp_path):
    # hybrid-4x4's point holds 150 tasks (its first 100 with 80 solved, all of the 50 added),
    # 2x2's and 6x6's the first 100: the m x h means compare the 100 tasks all three ran
    (tmp_path / "points").mkdir()
    runs = {
        "hybrid-4x4": (150, set(range(80)) | set(range(100, 150))),
        "hybrid-2x2": (100, set(range(60))),
        "hybrid-6x6": (100, set(range(90))),
    }
    rows = []
    for method, (tasks, wins) in runs.items():
        episodes = [{"seed": s, "objects": 1, "success": s in wins, "dropped": False, "actions": 9, "seconds": 0.1} for s in range(tasks)]
        point = {"method": method, "sweep": "clutter", "value": 1.0, "episodes": episodes}
        (tmp_path / "points" / f"{method}__clutter__1.json").write_text(json.dumps(point))
        rows.append(_row(method, "clutter", 1.0, len(wins) / tasks) | {"tasks": tasks, "successes": len(wins)})
    path = tmp_path / "results.json"
    path.write_text(json.dumps(rows))
    out = subprocess.run([sys.executable, str(SCRIPT), str(path)], capture_output=True, text=True, check=True).stdout
    (figures,) = [line.split(" | ")[1] for line in out.splitlines() if line.startswith("| larger m x h helps")]
    assert figures == "hybrid-2x2 60.0 %, hybrid-4x4 80.0 %, hybrid-6x6 90.0 % (mean over the points and tasks all three ran)"
