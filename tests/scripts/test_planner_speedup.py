"""`benchmarks/planner_speedup.py` compares like with like: "the same work" pairs the decisions of
the episodes both sides played alike, whatever else each side played."""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def _same_work():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from planner_speedup import same_work
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return same_work


def _run(episodes, owners, seconds):
    return {"episodes": episodes, "owners": owners, "decisions": seconds, "roots": [1] * len(seconds), "wall": 1.0}


def test_same_work_keeps_only_the_episodes_played_alike_and_pairs_their_decisions():
    same_work = _same_work()
    # episode 7 is the same on both sides (2 steps); episode 8 differs (3 steps here, 1 there)
    ref = _run([[7, True, 2], [8, False, 1]], [[7, 0], [8, 0], [7, 1]], [0.010, 0.500, 0.030])
    # this side records its decisions in another order and plays episode 8 longer
    this = _run([[7, True, 2], [8, True, 3]], [[8, 0], [7, 1], [8, 1], [7, 0], [8, 2]], [0.001, 0.012, 0.002, 0.004, 0.003])
    alike, times = same_work({"this": [this], "reference": [ref]})
    assert alike == 1
    np.testing.assert_allclose(times["reference"][0], [10.0, 30.0])  # ms, (seed, step) order
    np.testing.assert_allclose(times["this"][0], [4.0, 12.0])


def test_same_work_needs_an_episode_alike_in_every_round():
    same_work = _same_work()
    a = _run([[7, True, 1]], [[7, 0]], [0.01])
    b = _run([[7, False, 1]], [[7, 0]], [0.01])  # round 2 of this side played episode 7 otherwise
    alike, times = same_work({"this": [a, b], "reference": [a, a]})
    assert alike == 0 and all(len(t) == 0 for t in times["this"])


def test_same_work_needs_the_same_action_at_every_step_where_the_runs_record_them():
    # two failed episodes of the full length agree in seed, outcome and length whatever they did:
    # where the runs record each decision's action, an episode is alike only if every step's
    # action agrees (to 1e-3) with the reference's first round
    same_work = _same_work()

    def run(actions_8):
        out = _run([[7, False, 2], [8, False, 2]], [[7, 0], [7, 1], [8, 0], [8, 1]], [0.01, 0.02, 0.03, 0.04])
        return {**out, "actions": [[0.5, 0.0, 0.0, 1.0], [0.1, 0.2, 0.0, -1.0], *actions_8]}

    ref = run([[0.0, 0.0, 0.0, 1.0], [0.3, 0.3, 0.0, 1.0]])
    this = run([[0.0, 0.0, 0.0, 1.0], [-0.7, 0.3, 0.0, 1.0]])  # episode 8 parts at its second step
    nearly = {**this, "actions": [[a + 5e-4 for a in row] for row in this["actions"]]}
    alike, times = same_work({"this": [this, nearly], "reference": [ref, ref]})
    assert alike == 1
    np.testing.assert_allclose(times["reference"][0], [10.0, 20.0])  # episode 7's two decisions
    # without recorded actions (an older checkout), the old test: seed, outcome and length
    plain = [{k: v for k, v in r.items() if k != "actions"} for r in (this, ref)]
    assert same_work({"this": [plain[0]], "reference": [plain[1]]})[0] == 2
