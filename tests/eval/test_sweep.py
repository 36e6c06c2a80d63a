import json

import pytest

from occrl.eval.runner import run_tasks, summarize, wilson_interval
from occrl.eval.sweep import noise_sweep_objects, run_sweep
from occrl.eval.sweep_store import POINTS_ARCHIVE, point_path, sweep_points, unpack_points


def stored_point(out, method: str, sweep: str, value: float) -> dict:
    """The one point of ``method`` at ``sweep`` = ``value`` a sweep folder holds."""
    (point,) = [p for p in sweep_points(out, method, sweep) if p["value"] == value]
    return point


@pytest.mark.integration
def test_tiny_sweep_writes_points_table_and_figure_and_resumes(tmp_path):
    values = {"clutter": [1.0, 2.0], "noise": [0.0, 0.1]}
    out = run_sweep(["scripted"], tmp_path, tasks=3, first_seed=123, values=values, batch=3, progress=False)
    assert sorted(p.name for p in out.iterdir()) == [POINTS_ARCHIVE, "results.csv", "results.json", "sweep.png"]  # the points packed
    assert len(sweep_points(out)) == 4
    rows = json.loads((out / "results.json").read_text())
    assert {(r["sweep"], r["value"]) for r in rows} == {("clutter", 1.0), ("clutter", 2.0), ("noise", 0.0), ("noise", 0.1)}
    assert (out / "results.csv").exists() and (out / "sweep.png").stat().st_size > 1000
    clutter1 = stored_point(out, "scripted", "clutter", 1.0)
    assert all(e["objects"] == 1 for e in clutter1["episodes"])
    archive = (out / POINTS_ARCHIVE).read_bytes()
    run_sweep(["scripted"], tmp_path, tasks=3, first_seed=123, values=values, batch=3, progress=False)
    assert (out / POINTS_ARCHIVE).read_bytes() == archive  # finished points are not recomputed (their times would differ)
    with pytest.raises(ValueError, match="holds task seeds from 123, not from 500"):
        run_sweep(["scripted"], tmp_path, tasks=3, first_seed=500, values=values, batch=3, progress=False)


def test_noise_sweep_object_counts_are_fixed_by_seed_and_cover_1_to_10():
    counts = [noise_sweep_objects(s) for s in range(300)]
    assert counts == [noise_sweep_objects(s) for s in range(300)]
    assert set(counts) == set(range(1, 11))


@pytest.mark.integration
def test_results_do_not_depend_on_the_number_of_workers():
    seeds = list(range(40, 46))
    one = run_tasks("scripted", 1, seeds, batch=3, workers=1, progress=False)
    two = run_tasks("scripted", 1, seeds, batch=3, workers=2, progress=False)
    assert [(r.seed, r.success, r.actions) for r in one] == [(r.seed, r.success, r.actions) for r in two]


def test_wilson_interval():
    lo, hi = wilson_interval(45, 50)
    assert lo < 0.9 < hi and 0 <= lo and hi <= 1
    assert wilson_interval(0, 0) == (0.0, 1.0)
    assert summarize([])["tasks"] == 0


@pytest.mark.integration
def test_a_point_extended_by_more_seeds_equals_the_point_run_at_once(tmp_path):
    values = {"clutter": [2.0]}
    run_sweep(["stochastic-gen"], tmp_path / "grown", tasks=2, first_seed=200, sweeps=("clutter",), values=values, batch=3, progress=False)
    run_sweep(
        ["stochastic-gen"],
        tmp_path / "grown",
        tasks=5,
        first_seed=200,
        sweeps=("clutter",),
        values=values,
        batch=3,
        progress=False,
        chunk=2,
    )  # rounds of 2: seeds 202-203, then 204
    run_sweep(["stochastic-gen"], tmp_path / "once", tasks=5, first_seed=200, sweeps=("clutter",), values=values, batch=3, progress=False)
    # batches differ: grown ran [200, 201], [202, 203], [204]; once ran [200, 201, 202], [203, 204]
    grown, once = (stored_point(tmp_path / d, "stochastic-gen", "clutter", 2.0) for d in ("grown", "once"))
    assert [e["seed"] for e in grown["episodes"]] == list(range(200, 205))
    key = lambda p: [(e["seed"], e["success"], e["actions"]) for e in p["episodes"]]  # noqa: E731
    assert key(grown) == key(once)
    assert grown["tasks"] == 5 and grown["success_rate"] == once["success_rate"]


@pytest.mark.integration
def test_film_strips_replay_the_sweep_episodes_of_the_hybrid_planner(tmp_path):
    from occrl.eval.sweep import sweep_films

    out = run_sweep(["hybrid-2x2"], tmp_path, tasks=2, first_seed=300, sweeps=("clutter",), values={"clutter": [3.0]}, progress=False)
    point = stored_point(out, "hybrid-2x2", "clutter", 3.0)
    solved = sum(e["success"] for e in point["episodes"])
    paths = sweep_films(out, "hybrid-2x2", solved=solved, failed=2 - solved)  # raises if a replay differs
    assert len(paths) == 2 and all(p.stat().st_size > 10_000 for p in paths)


def test_wilson_interval_always_holds_the_rate():
    # at 0 % and 100 % the computed bound can land 1e-16 beside the rate (6/6, 0/11), which broke
    # the sweep plot's error bars ("yerr must not contain negative values")
    for n in range(1, 60):
        for k in range(n + 1):
            lo, hi = wilson_interval(k, n)
            assert 0.0 <= lo <= k / n <= hi <= 1.0, (k, n, lo, hi)


def test_a_clutter_sweep_on_noisy_physics_runs_its_tasks_at_that_noise_and_keeps_to_its_folder(tmp_path):
    from occrl.eval.sweep import summarize_sweep, sweep_films, sweep_tables

    values = {"clutter": [3.0]}
    out = run_sweep(["scripted"], tmp_path, tasks=3, first_seed=700, sweeps=("clutter",), values=values, progress=False, clutter_noise=0.15)
    point = stored_point(out, "scripted", "clutter", 3.0)
    direct = run_tasks("scripted", 2, [700, 701, 702], 0.15, 3, progress=False)  # the sweep's scene stage is 2
    assert point["noise"] == 0.15
    assert [(e["seed"], e["success"], e["actions"]) for e in point["episodes"]] == [(r.seed, r.success, r.actions) for r in direct]
    assert sweep_tables(summarize_sweep(out)).startswith("success (%) against clutter at noise 0.15 (3 tasks per point):")
    solved = sum(e["success"] for e in point["episodes"])
    sweep_films(out, "scripted", solved=solved, failed=3 - solved)  # replays at the point's noise; raises if an episode differs
    with pytest.raises(ValueError, match="holds tasks at noise 0.15, not 0: use another --out folder"):
        run_sweep(["scripted"], tmp_path, tasks=4, first_seed=700, sweeps=("clutter",), values=values, progress=False)


def test_the_command_line_runs_the_clutter_sweep_alone_at_the_noise_it_is_given(tmp_path, monkeypatch):
    import occrl.eval.sweep as sweep_module
    from occrl.cli import main

    calls = []

    def record(*args, **kwargs):  # the arguments only: the sweep itself is tested above
        calls.append(kwargs)
        out = tmp_path / "out"
        (out / "points").mkdir(parents=True, exist_ok=True)
        (out / "results.json").write_text("[]")
        return out

    monkeypatch.setattr(sweep_module, "run_sweep", record)
    assert main(["eval", "--sweep", "--methods", "scripted", "--noise", "0.15", "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    assert main(["eval", "--sweep", "--methods", "scripted", "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    assert [(c["sweeps"], c["clutter_noise"]) for c in calls] == [(("clutter",), 0.15), (("clutter", "noise"), 0.0)]


@pytest.mark.integration
def test_a_point_records_its_network_and_is_never_extended_with_another(tmp_path):
    """A sweep point records the network its method decided with (its own name and the SHA-256 of
    the weights); extending it with other weights, or after the default network changed, is refused."""
    from occrl.eval.methods import method_network
    from occrl.pretrained import pretrained_path

    values = {"clutter": [1.0]}
    out = run_sweep(["greedy"], tmp_path, tasks=1, first_seed=900, sweeps=("clutter",), values=values, films=False, progress=False)
    point = stored_point(out, "greedy", "clutter", 1.0)
    assert (point["network"], point["network_sha256"]) == method_network("greedy") and point["network"] == "occnet-noheatmap-selfimit"
    warm = str(pretrained_path("occnet-noheatmap-warmstart"))
    with pytest.raises(ValueError, match="holds episodes of the network 'occnet-noheatmap-selfimit'.*use another --out folder"):
        run_sweep(["greedy"], tmp_path, tasks=2, first_seed=900, sweeps=("clutter",), values=values, weights=warm, progress=False)
    assert len(stored_point(out, "greedy", "clutter", 1.0)["episodes"]) == 1  # left as it was
    # the same network (its weights file, as occrl eval passes it) extends the point
    run_sweep(
        ["greedy"],
        tmp_path,
        tasks=2,
        first_seed=900,
        sweeps=("clutter",),
        values=values,
        weights=str(pretrained_path("occnet-noheatmap-selfimit")),
        progress=False,
    )
    assert len(stored_point(out, "greedy", "clutter", 1.0)["episodes"]) == 2


def test_points_say_how_their_times_were_taken(tmp_path):
    """New points time each task's own episode; a point from before 0.3.0 (no mark: 50 actions per
    task) keeps its legacy mark when extended, and the figure's time axis says which it shows."""
    values = {"clutter": [1.0]}
    out = run_sweep(["scripted"], tmp_path, tasks=1, first_seed=700, sweeps=("clutter",), values=values, progress=False)
    assert stored_point(out, "scripted", "clutter", 1.0)["timing"] == "episode"
    assert json.loads((out / "results.json").read_text())[0]["timing"] == "episode"
    unpack_points(out)  # back to one file per point, to make this one a legacy point
    path = point_path(out, "scripted", "clutter", 1.0)
    legacy = json.loads(path.read_text())
    del legacy["timing"]
    path.write_text(json.dumps(legacy))
    run_sweep(["scripted"], tmp_path, tasks=2, first_seed=700, sweeps=("clutter",), values=values, progress=False)
    point = stored_point(out, "scripted", "clutter", 1.0)
    assert len(point["episodes"]) == 2 and "timing" not in point
    assert json.loads((out / "results.json").read_text())[0]["timing"] == "50 actions"


def test_a_sweep_killed_while_packing_or_unpacking_loses_no_point(tmp_path):
    """Both halves at once (an archive and a folder) read as one sweep, the folder's copy first;
    unpacking writes back only what the folder lacks, then drops the archive."""
    from occrl.eval.sweep_store import pack_points

    values = {"clutter": [1.0, 2.0]}
    out = run_sweep(["scripted"], tmp_path, tasks=2, first_seed=800, sweeps=("clutter",), values=values, progress=False)
    packed = sweep_points(out)
    unpack_points(out)
    assert not (out / POINTS_ARCHIVE).exists() and sweep_points(out) == packed
    pack_points(out)
    newer = point_path(out, "scripted", "clutter", 2.0)  # a point rewritten after an unpack killed half way
    newer.parent.mkdir()
    newer.write_text(json.dumps(packed[1] | {"tasks": 99}))
    assert [p["tasks"] for p in sweep_points(out)] == [2, 99]
    unpack_points(out)
    assert [p["tasks"] for p in sweep_points(out)] == [2, 99] and not (out / POINTS_ARCHIVE).exists()
    pack_points(out)
    assert not (out / "points").exists() and [p["tasks"] for p in sweep_points(out)] == [2, 99]
