"""The tools behind the docs' tables and figures (scripts/) run and report what they say."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _run(*args: str) -> str:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, check=True, cwd=ROOT).stdout


def _result(path: Path, method: str, stage: int, outcomes: list[bool]) -> Path:
    episodes = [
        {"seed": 10_000_000 + i, "objects": 5, "success": ok, "dropped": False, "actions": 20 if ok else 50, "seconds": 1.0}
        for i, ok in enumerate(outcomes)
    ]
    path.write_text(
        json.dumps(
            {
                "method": method,
                "network": "occnet",
                "stage": stage,
                "objects": None,
                "noise": 0.0,
                "world": "pymunk",
                "first_seed": 10_000_000,
                "tasks": len(outcomes),
                "success_rate": sum(outcomes) / len(outcomes),
                "episodes": episodes,
            }
        )
    )
    return path


@pytest.mark.integration
def test_perception_identity_passes_on_itself_and_fails_on_a_changed_render(tmp_path):
    out = _run("scripts/perception_identity.py", "--reference", str(ROOT), "--batches", "2")
    assert out.startswith("identical:")
    changed = tmp_path / "checkout"
    shutil.copytree(ROOT / "occrl", changed / "occrl", ignore=shutil.ignore_patterns("__pycache__"))
    render = changed / "occrl" / "envs" / "palette.py"
    source = render.read_text()
    assert "[128, 128, 128],  # observable: grey" in source
    render.write_text(source.replace("[128, 128, 128],  # observable: grey", "[127, 128, 128],  # observable: grey"))
    proc = subprocess.run(
        [sys.executable, "scripts/perception_identity.py", "--reference", str(changed), "--batches", "2"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode == 1 and "differs" in proc.stdout


def test_results_table_names_the_world_perception_tag_layout_and_shelf():
    import runpy

    row = runpy.run_path(str(ROOT / "scripts/results_table.py"))["row"]
    d = {"method": "hybrid-4x4", "network": "occnet-selfimit", "stage": 2, "objects": "1-8", "noise": 0.0, "tasks": 200}
    d |= {"success_rate": 0.8, "success_ci95": [0.74, 0.85], "dropped": 15, "mean_actions": 19.9, "mean_seconds": 5.1}
    assert "| pymunk, stage 2, objects 1-8 |" in row(d)
    d |= {"world": "mujoco", "perception": "tags", "tag_layout": "at-most-3cm", "shelf_height": 0.4}
    assert "| mujoco (tags, at-most-3cm), shelf 0.4 m, stage 2, objects 1-8 |" in row(d)


@pytest.mark.integration
def test_results_table_compares_two_runs_task_by_task(tmp_path):
    a = _result(tmp_path / "a.json", "hybrid-4x4", 2, [True, True, True, False])
    b = _result(tmp_path / "b.json", "hybrid-4x4", 2, [True, False, False, True])
    out = _run("scripts/results_table.py", "--compare", str(a), str(b))
    assert "1 of 4 episodes the same" in out
    assert "4 tasks in both: solved 3 / 2; only by the first 2, only by the second 1; exact McNemar p = 1.000" in out


@pytest.mark.integration
def test_timing_table_splits_each_task_into_planning_and_execution(tmp_path):
    out = tmp_path / "timing.json"
    text = _run(
        "scripts/timing_table.py",
        "--methods",
        "scripted,hybrid-2x2",
        "--objects",
        "1",
        "--tasks",
        "1",
        "--sweep",
        "results/sweep-v4",  # the default networks' sweep
        "--out",
        str(out),
    )
    result = json.loads(out.read_text())
    for name in ("scripted", "hybrid-2x2"):
        [row] = result["methods"][name]
        assert row["seed"] == 10_000_000 and row["objects"] == 1 and 1 <= row["actions"] <= 50
        assert row["planning_seconds"] > 0 and row["execution_seconds"] > 0
    assert result["differ_from_sweep"]["hybrid-2x2"] == 0  # the sweep has this episode; the same seed replays it
    assert "| hybrid-2x2 |" in text and "planning share" in text
    assert len(result["methods"]["hybrid-2x2"][0]["roots"]) == result["methods"]["hybrid-2x2"][0]["actions"]
    assert "roots" not in result["methods"]["scripted"][0]
    assert _run("scripts/timing_table.py", "--table", str(out)) == text.split("episodes that differ")[0]


@pytest.mark.integration
def test_sweep_compare_counts_the_tasks_each_folder_alone_solved(tmp_path):
    from occrl.eval.sweep_store import pack_points

    for name, wins in (("a", {1, 2, 3}), ("b", {2, 3, 4})):
        (tmp_path / name / "points").mkdir(parents=True)
        for value in (1, 2):
            episodes = [
                {"seed": s, "objects": value, "success": s in wins, "dropped": False, "actions": 9, "seconds": 0.1} for s in range(6)
            ]
            point = {"method": "greedy", "sweep": "clutter", "value": float(value), "episodes": episodes}
            (tmp_path / name / "points" / f"greedy__clutter__{value}.json").write_text(json.dumps(point))
    out = _run("scripts/sweep_compare.py", str(tmp_path / "a"), str(tmp_path / "b"), "--method", "greedy", "--groups", "1-2")
    assert "| 1 | 6 | 3 / 3 | 1 / 1 | 1 |" in out and "| 1-2 | 12 | 6 / 6 | 2 / 2 | 1 |" in out
    pack_points(tmp_path / "b")  # a finished sweep's folder reads the same
    assert _run("scripts/sweep_compare.py", str(tmp_path / "a"), str(tmp_path / "b"), "--method", "greedy", "--groups", "1-2") == out


@pytest.mark.integration
def test_planner_vs_policy_pairs_each_network_and_fits_the_line(tmp_path):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import planner_vs_policy as pvp
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    rows = pvp.pairs()
    assert len(rows) == len(pvp.NETWORKS)
    s = pvp.summary(rows)
    # the fitted line goes through the points: its residuals sum to zero
    residual = sum(p["success_rate"] - (s["slope"] * o["success_rate"] + s["intercept"]) for _, o, p in rows)
    assert abs(residual) < 1e-9 and -1 <= s["correlation"] <= 1
    table_rows = [line for line in pvp.table(rows).splitlines() if line.startswith("| ")]
    assert s["policy_range"][0] <= s["policy_range"][1] and len(table_rows) == len(rows) + 2  # header, rule, a row each
    positions = [line for line in pvp.by_target_position(rows).splitlines() if line.startswith("| ") and "quartile" not in line]
    assert len(positions) == 1 + 8 and sum(int(line.split("|")[2]) for line in positions[1:5]) == 200  # rule, 4 + 4 quartiles
    t = pvp.task_structure(rows)
    assert t["planner_all"] + t["planner_none"] + t["planner_some"] == 200
    own, planner = pvp.replicates("occnet-takeover")
    assert [d.get("replicate", 0) for d in own] == [d.get("replicate", 0) for d in planner] == [0, 1, 2]  # 0: the recorded run
    same = _result(tmp_path / "a.json", "hybrid-4x4", 2, [True, False, True, True])
    other = _result(tmp_path / "b.json", "hybrid-4x4", 2, [True, True, False, True])
    runs = [pvp.json.loads(f.read_text()) for f in (same, same, other)]
    assert pvp.agreement(runs) == pytest.approx((1 + 0.5 + 0.5) / 3)
    # a file of another method or other tasks is refused with what was expected
    wrong = _result(tmp_path / "w.json", "hybrid-4x4", 3, [True, False])
    with pytest.raises(ValueError, match="expected stochastic-gen on the 200 held-out stage-2 tasks"):
        pvp.load(wrong, "stochastic-gen")
    with pytest.raises(ValueError, match="replicate 1"):  # a replicate-0 file where replicate 1 belongs
        pvp.load(pvp.NETWORKS[0].planner, "hybrid-4x4", replicate=1)
    out = tmp_path / "plot.png"
    pvp.plot(rows[:3], out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the archived evaluations are the files as committed, none of them also in the tree
    archived = pvp.archived_evaluations()
    assert archived and not [path for path in archived if (ROOT / path).exists()]
    history = subprocess.run(["git", "cat-file", "-e", "53b1240^{commit}"], cwd=ROOT, capture_output=True).returncode == 0
    for path in archived if history else []:  # a clone without that history checks the rest only
        assert (
            json.loads(subprocess.run(["git", "show", f"53b1240:{path}"], cwd=ROOT, capture_output=True, check=True).stdout)
            == archived[path]
        )


@pytest.mark.integration
def test_episode_film_films_the_evaluations_episode(tmp_path):
    """The film's episode is the evaluation's: the same outcome and length as ``occrl eval`` on that task seed."""
    from PIL import Image

    result = tmp_path / "scripted.json"
    _run("-m", "occrl.cli", "eval", "--method", "scripted", "--stage", "2", "--tasks", "2", "--workers", "1", "--out", str(result))
    episode = json.loads(result.read_text())["episodes"][1]
    out = _run(
        "scripts/episode_film.py", "--method", "scripted", "--stage", "2", "--seed", str(episode["seed"]), "--out", str(tmp_path / "f.png")
    )
    outcome = "success" if episode["success"] else ("dropped an object" if episode["dropped"] else "not retrieved")
    assert f"task {episode['seed']}: {outcome} after {episode['actions']} actions" in out
    assert Image.open(tmp_path / "f.png").size[0] > 1000  # a strip of frames
    bad = subprocess.run(
        [sys.executable, "scripts/episode_film.py", "--method", "scripted", "--seed", "1", "--out", str(tmp_path / "f.jpg")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert bad.returncode != 0 and "--out must end in .png" in bad.stderr


@pytest.mark.integration
def test_tag_target_recall_replays_the_lost_tasks_and_counts_the_target(tmp_path):
    pytest.importorskip("mujoco")
    pytest.importorskip("cv2")
    run = {"method": "scripted", "network": None, "stage": 2, "objects": "1", "world": "mujoco", "perception": "tags"}
    tags, reference = tmp_path / "tags.json", tmp_path / "reference.json"
    tags.write_text(json.dumps(run | {"episodes": [{"seed": 10_000_000, "success": False}, {"seed": 10_000_001, "success": False}]}))
    reference.write_text(json.dumps(run | {"episodes": [{"seed": 10_000_000, "success": True}, {"seed": 10_000_001, "success": False}]}))
    out = subprocess.run(
        [sys.executable, "scripts/tag_target_recall.py", str(tags), str(reference)],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
        env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")},
    ).stdout
    assert out.splitlines()[0].startswith("1 tasks only")
    assert "10000000 (" in out and "10000001" not in out  # only the task the reference alone solved
    assert "target in view in" in out  # one object: the target, in view at the start
