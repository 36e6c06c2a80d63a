"""The analysis scripts behind "Why stage 2 stops here" (docs/experiments.md) run and report what they say."""

import json
import re
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


def test_stage_ceiling_is_the_union_of_the_runs(tmp_path):
    a = _result(tmp_path / "a.json", "hybrid-4x4", 2, [True, False, False, False])
    b = _result(tmp_path / "b.json", "scripted", 2, [False, True, False, False])
    out = _run("scripts/stage_ceiling.py", str(a), str(b), "--tasks", "4")
    assert "stage 2: 2 runs on the same 4 tasks" in out
    assert "solved by at least one run: 50.0%; never solved: 2 tasks" in out
    assert "never solved: 10000002 10000003" in out


def test_failure_categories_replays_a_failed_scripted_episode(tmp_path):
    # one real stage-1 task, recorded as failed so that the script replays it
    path = _result(tmp_path / "r.json", "scripted", 1, [False])
    out = _run("scripts/failure_categories.py", str(path))
    assert "seed 10000000:" in out and "scripted stage 1: 1 failures replayed" in out


def test_failure_categories_finds_a_target_the_camera_never_faced(tmp_path):
    # held-out stage-2 task 10000029: the target stands in a front corner beside the gripper's
    # start; the planner on occnet-takeover never turns to it (results/diagnosis/strips/)
    path = _result(tmp_path / "r.json", "hybrid-4x4", 2, [True] * 29 + [False])
    out = _run("scripts/failure_categories.py", str(path), "--weights", "occnet-takeover")
    assert "seed 10000029: never detected" in out and "never in the field of view" in out
    assert "never detected and never in the camera's field of view: 1 of 1" in out


def test_failure_categories_splits_a_missed_grasp(tmp_path):
    # held-out stage-2 task 10000007: occnet-takeover's own policy sees the target, closes its
    # fingers in front of it and never holds it
    path = _result(tmp_path / "r.json", "stochastic-gen", 2, [True] * 7 + [False])
    out = _run("scripts/failure_categories.py", str(path), "--weights", "occnet-takeover")
    assert "seed 10000007: detected, never held (closed, missed)" in out
    assert "detected, never held: 1 " in out
    # the gripper brought the target's centre to the point between its fingers, and still missed
    assert "nearest to the grasp point 0.00 m" in out
    assert "closed, missed: 1 of 1 with the target's centre within 8 cm of the grasp point" in out


def test_close_outcomes_finds_grasps_that_only_the_recreated_world_makes():
    # held-out stage-2 task 10000057: the planner on occnet-takeover sees the target all along and
    # closes on it five times; its recreated world grasps, the true state (an object the camera
    # has not seen between the fingers) and the real world do not
    out = _run("scripts/close_outcomes.py", "--seeds", "10000057", "--weights", "occnet-takeover")
    assert "1 tasks, weights occnet-takeover: 5 closes" in out
    assert "target seen / imagined grasp / true-state miss / real miss" in out


def test_image_limited_retriever_reads_the_target_from_the_image(tmp_path):
    out_file = tmp_path / "r.json"
    out = _run(
        "scripts/image_limited_retriever.py",
        "--stage",
        "1",
        "--tasks",
        "2",
        "--size",
        "32",
        "--fovea-size",
        "32",
        "--baseline",
        "results/heldout-physics2/scripted_s1.json",
        "--out",
        str(out_file),
    )
    assert "scripted reading the target from 32 px over 0.8 m and 32 px over 0.4 m (8 mm map), stage 1:" in out
    assert "reading the true pose on the same 2 tasks:" in out
    report = json.loads(out_file.read_text())
    assert [e["seed"] for e in report["episodes"]] == [10_000_000, 10_000_001] and report["windows"][1] == [32, 0.4, 0.1]


def test_handover_pairs_its_episodes_with_the_planners_own(tmp_path):
    baseline = _result(tmp_path / "b.json", "hybrid-4x4", 1, [False, True])
    out = _run("scripts/handover.py", "--stage", "1", "--tasks", "2", "--baseline", str(baseline))
    # both stage-1 tasks are solved after the hand-over: one more than the recorded baseline
    assert "hybrid 4x4 -> scripted at the first detection, stage 1: 100.0 %" in out
    assert "the planner alone on the same 2 tasks: 50.0 %; the hand-over wins 1, loses 0 (McNemar p = 1.000)" in out


def test_handover_from_the_networks_own_policy_keeps_its_episodes_until_the_hand_over(tmp_path):
    baseline = tmp_path / "own.json"
    net = ("--weights", "occnet-takeover")  # a named network: on these 12 tasks its policy never detects the target in 2
    _run(
        "-m",
        "occrl.cli",
        "eval",
        "--method",
        "stochastic-gen",
        "--stage",
        "2",
        "--tasks",
        "12",
        "--workers",
        "1",
        *net,
        "--out",
        str(baseline),
    )
    out = _run("scripts/handover.py", "--from", "stochastic-gen", "--stage", "2", "--tasks", "12", *net, "--baseline", str(baseline))
    assert "stochastic-gen -> scripted at the first detection, stage 2" in out
    # the tasks whose target the policy never detects (2 of these 12) are the evaluation's episodes, step for step
    never = re.search(r"tasks never handed over: (\d+), of them equal to the planner's own episode: (\d+)", out)
    assert never is not None and int(never.group(1)) > 0 and never.group(1) == never.group(2)


def test_handover_from_the_hierarchical_search(tmp_path):
    """--from hierarchical: the OMPL planner's sweep until the first detection, then the clearing
    retriever (no network: none recorded) or the network, which decided from the start; the
    noise option disturbs the executed motion only where asked, and both results split by the
    start (search_split reads them)."""
    plain, noisy = tmp_path / "plain.json", tmp_path / "noisy.json"
    out = _run(
        "scripts/handover.py", "--from", "hierarchical", "--to", "clearing-observed", "--teacher", "--tasks", "3", "--out", str(plain)
    )
    assert "hierarchical -> clearing-observed at the first detection, stage 2" in out
    _run(
        "scripts/handover.py",
        "--from",
        "hierarchical",
        "--to",
        "clearing-observed",
        "--teacher",
        "--action-noise",
        "0.3",
        "--tasks",
        "3",
        "--out",
        str(noisy),
    )
    first, second = json.loads(plain.read_text()), json.loads(noisy.read_text())
    assert first["weights"] is None and first["teacher_settings"] and second["action_noise"] == 0.3
    assert [e["actions"] for e in first["episodes"]] != [e["actions"] for e in second["episodes"]]
    out = _run("scripts/handover.py", "--from", "hierarchical", "--to", "stochastic-gen", "--tasks", "2")
    assert "hierarchical -> stochastic-gen at the first detection, stage 2" in out and "handed over in" in out
    split = _run("scripts/search_split.py", "--start-only", "--results", str(plain))
    assert "hierarchical -> clearing-observed (no network), stage 2, 3 tasks" in split
    for bad_args, message in (
        (["--from", "hierarchical", "--to", "scripted"], "--from hierarchical hands over to one of"),
        (["--to", "stochastic-gen"], "takes over from --from hierarchical only"),
        (["--teacher"], "--teacher applies to --from hierarchical"),
        (["--from", "hierarchical", "--to", "clearing-observed", "--action-noise", "2"], "--action-noise must be in [0, 1]"),
    ):
        bad = subprocess.run([sys.executable, "scripts/handover.py", *bad_args], capture_output=True, text=True, cwd=ROOT)
        assert bad.returncode == 2 and message in bad.stderr


def test_detail_use_is_zero_for_a_network_just_converted(tmp_path):
    weights = tmp_path / "fine.pt"
    _run("scripts/finer_input.py", "--weights", "occnet", "--out", str(weights))
    out = _run("scripts/detail_use.py", "--weights", str(weights), "--tasks", "2", "--steps", "3")
    assert "6 images: mean |action(image) - action(even pixels)| 0.0000" in out and "(0.0 %)" in out
    with pytest.raises(subprocess.CalledProcessError):
        _run("scripts/detail_use.py", "--weights", "occnet", "--tasks", "1", "--steps", "1")


def test_planner_decisions_prints_every_decision():
    out = _run("scripts/planner_decisions.py", "--method", "hybrid-2x2", "--stage", "1", "--seed", "3", "--steps", "2")
    assert out.count("step ") == 2 and out.count("    root 0: returns") == 2


def test_perception_identity_passes_on_itself_and_fails_on_a_changed_render(tmp_path):
    out = _run("scripts/perception_identity.py", "--reference", str(ROOT), "--batches", "2")
    assert out.startswith("identical:")
    changed = tmp_path / "checkout"
    shutil.copytree(ROOT / "occrl", changed / "occrl", ignore=shutil.ignore_patterns("__pycache__"))
    render = changed / "occrl" / "envs" / "render.py"
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


def test_oracle_roots_plan_in_a_world_that_steps_as_the_real_one():
    # the true-state root holds every object, hidden ones included, and its imagined world
    # steps as the execution world does at noise 0; the true-target root adds only the target
    import numpy as np
    import torch
    from torchrl.envs.utils import step_mdp

    from occrl.envs import world_constants as C

    from occrl.baselines.oracle_planner import OracleRootsPlanner
    from occrl.envs.episodes import seeded_task_env, task_scenes
    from occrl.modules import make_occnet
    from occrl.planners import HybridPlanner, make_world, recreate

    net = make_occnet("paper").eval()
    planner = OracleRootsPlanner(net, "state", m=2, h=2)
    seed = 10_000_002  # stage 2: 9 objects, 3 detected at the start, the target not among them
    env = seeded_task_env(planner, task_scenes(2, [seed]), [seed], 0.0, [net.make_primer()], False, "pymunk")
    td = env.reset()
    obs = td[0]
    present = obs["privileged", "object_present"].numpy().astype(bool)
    (root,) = planner.roots(obs, np.zeros((64, 64)))
    assert len(root.state.objects) == present.sum() > len(recreate(obs).objects)
    assert sum(o.is_target for o in root.state.objects) == 1
    (target_root,) = OracleRootsPlanner(net, "target", m=2, h=2).roots(obs, np.zeros((64, 64)))
    assert len(target_root.state.objects) == len(recreate(obs).objects) + 1
    for _ in range(3):
        (root,) = planner.roots(td[0], np.zeros((64, 64)))
        world = make_world(root.state)
        td = env.step(planner(td))
        world.step(td["action"][0].numpy().astype(float))
        nxt = td["next"][0]
        alive = nxt["privileged", "object_present"].numpy().astype(bool)
        assert np.abs(world.object_poses() - nxt["privileged", "object_pose"].numpy()[alive]).max() < 1e-6
        assert np.abs(world.gripper_pose() - nxt["gripper_pose"].numpy()).max() < 1e-6
        td = step_mdp(td)
    # to the end: as deep as the actions left in the episode, scored by the rewards alone
    end = OracleRootsPlanner(net, "state", to_the_end=True, m=2, h=2)
    obs = td[0].clone()
    obs["step_count"] = torch.tensor([47])
    hidden = (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
    decision = end.decide(obs, np.zeros((64, 64)), hidden)
    assert end.h == 3 and decision.result.paths.shape[2] == 4
    ends = np.isfinite(decision.result.paths[..., 1:, 0]).sum(-1)  # steps each roll-out took
    assert np.allclose(decision.result.returns[ends == 3], -(1 + C.GAMMA + C.GAMMA**2))  # three -1 rewards, no value
    # its own roots: the plain planner's, no privileged key read
    own = OracleRootsPlanner(net, "own", m=2, h=2)
    heatmap = np.random.default_rng(0).random((64, 64))
    assert "privileged" not in own.in_keys and "privileged" in planner.in_keys
    plain = HybridPlanner(net, m=2, h=2).roots(td[0], heatmap)

    def described(roots):
        return [(r.weight, r.peak_pixel, len(r.state.objects), r.state.gripper_pose, r.state.target_detected) for r in roots]

    assert described(own.roots(td[0], heatmap)) == described(plain) and len(plain) >= 1
    with pytest.raises(ValueError, match="which must be"):
        OracleRootsPlanner(net, "heatmap")


def test_label_census_counts_the_teachers_labels_after_the_first_sight():
    out = _run("scripts/label_census.py", "--worlds", "2", "--weights", "occnet-takeover")
    frames = int(out.split("frames after the first sight")[0].split(": ")[1].split(" of ")[0])
    assert "2 worlds x 50 steps, stage 2" in out and 0 < frames <= 100
    assert "labels that back out: " in out and "the learner's mean action" in out


def test_results_table_compares_two_runs_task_by_task(tmp_path):
    a = _result(tmp_path / "a.json", "hybrid-4x4", 2, [True, True, True, False])
    b = _result(tmp_path / "b.json", "hybrid-4x4", 2, [True, False, False, True])
    out = _run("scripts/results_table.py", "--compare", str(a), str(b))
    assert "1 of 4 episodes the same" in out
    assert "4 tasks in both: solved 3 / 2; only by the first 2, only by the second 1; exact McNemar p = 1.000" in out


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


def test_sweep_compare_counts_the_tasks_each_folder_alone_solved(tmp_path):
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
    # the committed hierarchical sweeps: noise 0.15 costs 23 tasks at 1-5 objects and 47 at 6-10 (docs/experiments.md)
    out = _run("scripts/sweep_compare.py", "results/sweep-physics2", "results/sweep-physics2-clutter-n015", "--method", "hierarchical")
    assert "| 1-5 | 500 | 498 / 475 | 23 / 0 |" in out and "| 6-10 | 500 | 444 / 398 | 47 / 1 |" in out


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


def test_proposal_uptake_counts_one_proposal_per_action_and_the_exclusive_wins(tmp_path):
    """One proposal record per executed action; the exclusive wins against another result of the
    same tasks add up to the difference of their successes (the episodes are those of ``occrl eval``
    up to the proposer's wall-time-bounded OMPL queries)."""
    scored = tmp_path / "eval.json"
    _run("-m", "occrl.cli", "eval", "--method", "hybrid-ompl-2x2", "--stage", "1", "--tasks", "2", "--out", str(scored), "--no-progress")
    out = tmp_path / "uptake.json"
    text = _run(
        "scripts/proposal_uptake.py",
        "--method",
        "hybrid-ompl-2x2",
        "--stage",
        "1",
        "--tasks",
        "2",
        "--compare",
        str(scored),
        "--out",
        str(out),
    )
    report, evaluated = json.loads(out.read_text()), json.loads(scored.read_text())
    assert set(report["solved"]) == {str(e["seed"]) for e in evaluated["episodes"]}  # the same tasks
    there = {str(e["seed"]): e["success"] for e in evaluated["episodes"]}
    assert report["compare"]["only_it"] == sum(v and not report["solved"][k] for k, v in there.items())
    assert report["compare"]["its_success_rate"] == evaluated["success_rate"]
    assert report["uptake"]["all"]["decisions"] == sum(report["actions"].values())
    assert sum(row["decisions"] for kind, row in report["uptake"].items() if kind != "all") == report["uptake"]["all"]["decisions"]
    assert 0.0 <= report["uptake"]["all"]["taken"] <= 1.0 and "proposal kind" in text
    assert report["replan_inside"] is True and report["proposal_bonus"] == 0.0


def test_proposal_uptake_refuses_a_bonus_that_is_not_a_finite_number():
    done = subprocess.run(
        [sys.executable, "scripts/proposal_uptake.py", "--tasks", "1", "--proposal-bonus", "nan"], capture_output=True, text=True, cwd=ROOT
    )
    assert done.returncode == 2 and "--proposal-bonus must be a finite number" in done.stderr


def test_the_policy_probes_reproduce_the_evaluation_at_their_reference_setting(tmp_path):
    """noise_persistence at rho 0 and oracle_close's "policy" mode are ``occrl eval --method
    stochastic-gen`` task for task; the oracle close changes commands; target_memory finds the
    heat-map's mass on the target while it is in view."""
    baseline = tmp_path / "own.json"
    _run("-m", "occrl.cli", "eval", "--method", "stochastic-gen", "--stage", "2", "--tasks", "8", "--workers", "1", "--out", str(baseline))
    own = [e["success"] for e in json.loads(baseline.read_text())["episodes"]]
    _run("scripts/noise_persistence.py", "--stage", "2", "--tasks", "8", "--rhos", "0,0.9", "--out", str(tmp_path / "noise.json"))
    noise = json.loads((tmp_path / "noise.json").read_text())["solved"]
    assert noise["0.0"] == own and len(noise["0.9"]) == 8
    out = _run("scripts/oracle_close.py", "--stage", "2", "--tasks", "8", "--modes", "policy,oracle", "--out", str(tmp_path / "close.json"))
    close = json.loads((tmp_path / "close.json").read_text())["solved"]
    assert close["policy"] == own
    changed = re.search(r"\| oracle \| [^\n]* \| (\d+) \|\n", out)
    assert changed is not None and int(changed.group(1)) > 0
    out = _run("scripts/target_memory.py", "--stage", "2", "--tasks", "8")
    visible = re.search(r"\| visible \| (\d+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+)x \|", out)
    assert visible is not None and int(visible.group(1)) > 0 and float(visible.group(4)) > 1.0  # more mass on the target than elsewhere


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


def test_network_ablation_puts_back_only_the_named_head(tmp_path):
    import torch

    from occrl.modules import make_occnet
    from occrl.modules.weights import load_weights, save_weights

    trained = make_occnet("paper")
    with torch.no_grad():  # a "trained" network: every weight moved away from its initialisation
        for p in trained.parameters():
            p.add_(0.5)
    save_weights(tmp_path / "trained.pt", trained)
    heads = {"policy": "actor", "value": "critic", "heatmap": "heatmap_head"}
    for part in heads:
        out = tmp_path / f"{part}.pt"
        assert "wrote" in _run("scripts/network_ablation.py", "--weights", str(tmp_path / "trained.pt"), "--part", part, "--out", str(out))
        net = load_weights(out)
        torch.manual_seed(0)
        fresh = make_occnet("paper")
        for name, other in heads.items():
            mine, theirs = getattr(net, other).state_dict(), getattr(trained if name != part else fresh, other).state_dict()
            assert all(torch.equal(mine[k], theirs[k]) for k in mine), (part, name)
        assert all(torch.equal(a, b) for a, b in zip(net.lstm.parameters(), trained.lstm.parameters()))
    save_weights(tmp_path / "noheatmap.pt", make_occnet("paper", heatmap=False))
    bad = subprocess.run(
        [sys.executable, "scripts/network_ablation.py", "--weights", str(tmp_path / "noheatmap.pt"), "--part", "heatmap", "--out", str(tmp_path / "x.pt")],
        capture_output=True, text=True, cwd=ROOT,
    )  # fmt: skip
    assert bad.returncode != 0 and "no heat-map head" in bad.stderr and not (tmp_path / "x.pt").exists()


def test_search_split_groups_the_evaluations_episodes_by_the_first_sight(tmp_path):
    results = tmp_path / "own.json"
    _run("-m", "occrl.cli", "eval", "--method", "stochastic-gen", "--stage", "2", "--tasks", "12", "--workers", "1", "--out", str(results))
    out = _run("scripts/search_split.py", "--weights", "occnet", "--results", str(results), "--out", str(tmp_path / "split.json"))
    split = json.loads((tmp_path / "split.json").read_text())
    groups = split["groups"]
    assert sum(g["tasks"] for g in groups.values()) == 12
    assert sum(g["solved"] for g in groups.values()) == json.loads(results.read_text())["successes"]
    assert groups["never seen"]["solved"] == 0 and "warning" not in out
    searched = groups["never seen"]["tasks"] + groups["first seen after a search"]["tasks"]
    assert groups["first seen at the start"]["tasks"] > 0 and searched > 0
    # split by the task alone: the tasks whose target is seen at the start are the same for any method
    _run("scripts/search_split.py", "--start-only", "--results", str(results), str(results), "--out", str(tmp_path / "start.json"))
    start = json.loads((tmp_path / "start.json").read_text())[str(results)]
    assert start["seen at the start"] == groups["first seen at the start"]
    assert start["hidden at the start"]["tasks"] == searched
    other = json.loads(results.read_text())
    other["replicate"] = 1
    (tmp_path / "r1.json").write_text(json.dumps(other))
    bad = subprocess.run(
        [sys.executable, "scripts/search_split.py", "--results", str(tmp_path / "r1.json")], capture_output=True, text=True, cwd=ROOT
    )
    assert bad.returncode == 2 and "needs a replicate-0 result" in bad.stderr


def test_start_scene_pool_writes_target_hidden_tasks_the_trainer_can_read(tmp_path):
    from occrl.envs.scene_files import load_scenes
    from occrl.training.start_scenes import hidden_target_scenes

    out = tmp_path / "pool.json"
    _run("scripts/start_scene_pool.py", "--kind", "target-hidden", "--stage", "2", "--count", "3", "--seed", "7", "--out", str(out))
    scenes, meta = load_scenes(out)
    assert meta["stage"] == 2 and meta["kind"] == "target-hidden" and meta["scenes"] == len(scenes) == 3
    expected = [s.seed for s in hidden_target_scenes(2, range(7, meta["last_seed"] + 1))][:3]
    assert [s.seed for s in scenes] == expected
    bad = subprocess.run(
        [sys.executable, "scripts/start_scene_pool.py", "--kind", "target-hidden", "--count", "3", "--later-only", "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert bad.returncode == 2 and "apply to --kind handover" in bad.stderr


def test_policy_samples_groups_tasks_by_the_policys_replicates(tmp_path):
    p0 = _result(tmp_path / "p0.json", "stochastic-gen", 2, [True, False, False, False])
    p1 = _result(tmp_path / "p1.json", "stochastic-gen", 2, [True, True, False, False])
    h = _result(tmp_path / "h.json", "hybrid-4x4", 2, [True, True, True, False])
    out = _run("scripts/policy_samples.py", "--policy", str(p0), str(p1), "--planner", str(h), "--out", str(tmp_path / "s.json"))
    assert "| 0 of 2 | 2 | 0.0 % | 50.0 % |" in out  # the planner solves one of the two tasks the policy never solved
    assert "| 1 of 2 | 1 | 50.0 % | 100.0 % |" in out and "| 2 of 2 | 1 | 100.0 % | 100.0 % |" in out
    result = json.loads((tmp_path / "s.json").read_text())
    # one replicate solves 3 of 8 task-replicates on average; either of the two, 2 of the 4 tasks
    assert result["union_curve"] == [0.375, 0.5] and result["worth_in_samples"]["planner"] is None
    other = _result(tmp_path / "o.json", "hybrid-4x4", 3, [True, True, True, False])
    bad = subprocess.run(
        [sys.executable, "scripts/policy_samples.py", "--policy", str(p0), "--planner", str(other)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert bad.returncode == 2 and "settings" in bad.stderr


def test_averaged_rollouts_score_each_first_action_by_the_mean_of_its_continuations():
    import numpy as np
    import torch

    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        from averaged_rollouts import AveragedRolloutsPlanner
    finally:
        sys.path.remove(str(ROOT / "scripts"))
    from occrl.modules import make_occnet
    from occrl.planners import RecreatedState, Root, rhp_batched, with_target
    from occrl.planners.rhp import noise_dim

    net = make_occnet("paper").eval()
    box = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]])
    state = RecreatedState((), (0.0, -0.1, 0.0), 0.085, False, target_type=1, target_vertices=box)
    roots = [Root(with_target(state, (-0.1, 0.2, 0.0)), 0.5), Root(with_target(state, (0.1, 0.2, 0.0)), 0.5)]
    hidden = (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
    planner = AveragedRolloutsPlanner(net, k=3, m=2, h=3, seed=5)
    result = planner.rollouts(roots, hidden)
    # the same draws, rolled out by the paper's RHP: 2 x 3 roll-outs per root
    generator = torch.Generator().manual_seed(5)
    first = torch.randn(2, 2, 1, 1, noise_dim(net), generator=generator)
    noise = torch.randn(2, 2, 3, 3, noise_dim(net), generator=generator)
    noise[:, :, :, :1] = first.expand(2, 2, 3, 1, noise_dim(net))
    raw = rhp_batched(net, [r.state for r in roots], hidden, noise.reshape(2, 6, 3, noise_dim(net)))
    firsts = raw.first_actions.reshape(2, 2, 3, 4)
    assert np.array_equal(firsts, np.repeat(firsts[:, :, :1], 3, axis=2))  # one first action per group
    means = raw.returns.reshape(2, 2, 3).mean(axis=2)
    assert np.allclose(result.returns, means) and np.allclose(result.value, means.max(axis=1))
    assert np.array_equal(result.action, firsts[np.arange(2), means.argmax(axis=1), 0])
    assert len(np.unique(raw.returns.round(9))) > 2  # the continuations differ
    with pytest.raises(ValueError, match="k must be"):
        AveragedRolloutsPlanner(net, k=0)
