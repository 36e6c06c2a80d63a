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
    return {line.split(" | ")[0].lstrip("| "): line.split(" | ")[-1].rstrip(" |") for line in out.splitlines() if line.startswith("| ")}


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


def test_a_baseline_clearly_above_the_hybrid_is_a_disagreement(tmp_path):
    rows = [
        _row("hybrid-4x4", "clutter", 1.0, 0.5),
        _row("greedy", "clutter", 1.0, 0.9),
        _row("hybrid-4x4", "clutter", 2.0, 0.5),
        _row("greedy", "clutter", 2.0, 0.9),
    ]
    verdicts = _claims(tmp_path, rows)
    assert verdicts["hybrid (4x4) beats every baseline"].startswith("disagrees (2 pairs clearly lower)")
