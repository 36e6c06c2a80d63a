import json
import re

import pytest
import torch

from occrl.training import CheckpointError, Curriculum, TrainConfig, Trainer, get_train_config, load_checkpoint, load_weights
from occrl.training.config import SETTING_CHOICES
from occrl.modules import make_occnet
from occrl.modules.weights import save_weights
from tests.helpers import checkpoint_as_written_before


def _weights(net):
    return {k: v.clone() for k, v in net.state_dict().items()}


@pytest.mark.integration
@pytest.mark.parametrize("imitation", [0, 4])
def test_resume_is_exact(tmp_path, imitation):
    cfg = get_train_config("tiny", imitation_iters=imitation, imitation_beta_iters=2 if imitation else 0)
    straight = Trainer(cfg, tmp_path / "a", seed=5, progress=False, tensorboard=False)
    straight.train(iterations=4)
    straight.close()
    first = Trainer(cfg, tmp_path / "b", seed=5, progress=False, tensorboard=False)
    first.train(iterations=2)
    first.close()
    resumed = Trainer(cfg, tmp_path / "b", seed=5, progress=False, tensorboard=False)
    assert resumed.iteration == 2
    resumed.train(iterations=4)
    resumed.close()
    a, b = _weights(straight.net), _weights(resumed.net)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert resumed.frames == straight.frames
    # the network at the end of the warm start is kept beside the run's latest weights
    warm = tmp_path / "a" / "weights_warmstart.pt"
    assert warm.exists() == bool(imitation)
    if imitation:
        w = _weights(load_weights(warm))
        assert all(torch.equal(w[k], a[k]) for k in a)


@pytest.mark.integration
@pytest.mark.parametrize("where", ["promotion check", "update"])
def test_a_stop_inside_an_iteration_keeps_the_last_checkpoint_and_resumes_exactly(tmp_path, where):
    """SIGTERM / Ctrl-C (KeyboardInterrupt) during the update or the promotion check: the
    half-done iteration is not checkpointed (it would skip the check or resume from half-updated
    weights); the run resumes from the checkpoint before it and ends as a run never stopped."""
    cfg = get_train_config("tiny", promotion="hybrid", promotion_eval_every=2, promote_threshold=0.5)
    rates = iter([0.4, 0.6])  # the check at iteration 4 promotes

    def check(net, stage, tasks, noise):
        return next(rates)

    straight = Trainer(cfg, tmp_path / "a", seed=2, progress=False, tensorboard=False, promotion_check=check)
    straight.train(iterations=5)
    straight.close()

    rates = iter([0.4, 0.6])
    run = tmp_path / "b"
    tr = Trainer(cfg, run, seed=2, progress=False, tensorboard=False, promotion_check=check, checkpoint_every_s=1e-9)
    if where == "promotion check":

        def stopped(net, stage, tasks, noise):  # the check of iteration 4 is interrupted
            if tr.iteration == 4:
                raise KeyboardInterrupt("SIGTERM")
            return check(net, stage, tasks, noise)

        tr.promotion_check = stopped
    else:
        update = tr.learner.update

        def stopped(batch, phase):  # iteration 4's update is interrupted after its first step
            if tr.iteration == 3:
                update(batch, phase)
                raise KeyboardInterrupt("SIGTERM")
            return update(batch, phase)

        tr.learner.update = stopped
    with pytest.raises(KeyboardInterrupt):
        tr.train(iterations=5)
    tr.close()
    assert tr.saved_iteration == 3 and torch.load(run / "checkpoint.pt", weights_only=True)["state"]["iteration"] == 3
    rates = iter([0.6])  # the check of iteration 4 runs again
    resumed = Trainer(cfg, run, seed=2, progress=False, tensorboard=False, promotion_check=check)
    assert resumed.iteration == 3
    resumed.train(iterations=5)
    resumed.close()
    a, b = _weights(straight.net), _weights(resumed.net)
    assert all(torch.equal(a[k], b[k]) for k in a)
    rows = [json.loads(line) for line in (run / "metrics.jsonl").read_text().splitlines()]
    assert [r["iteration"] for r in rows] == [1, 2, 3, 4, 5] and [r["stage"] for r in rows] == [1, 1, 1, 2, 2]
    assert [r.get("hybrid_success_rate") for r in rows] == [None, 0.4, None, 0.6, None]


def test_run_folder_has_logs_curves_and_small_files(tmp_path):
    tr = Trainer(get_train_config("tiny"), tmp_path, seed=0, progress=False, tensorboard=True)
    tr.train(iterations=2)
    tr.close()
    rows = [json.loads(line) for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    assert [r["iteration"] for r in rows] == [1, 2] and all("loss_heatmap" in r for r in rows)
    assert (tmp_path / "learning_curves.png").stat().st_size > 1000
    assert any((tmp_path / "tensorboard").rglob("events.*"))
    assert any((tmp_path / "logs").rglob("*.csv"))
    assert (tmp_path / "weights.pt").stat().st_size < 4_000_000


def test_bad_checkpoints_give_clear_errors(tmp_path):
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a checkpoint at all")
    with pytest.raises(CheckpointError, match="not a readable checkpoint"):
        load_weights(garbage)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        load_weights(tmp_path / "missing.pt")
    other = tmp_path / "other.pt"
    save_weights(other, make_occnet("paper", heatmap=False))
    with pytest.raises(CheckpointError, match="another architecture"):
        load_weights(other, make_occnet("paper"))
    torch.save({"format": "something-else"}, tmp_path / "foreign.pt")
    with pytest.raises(CheckpointError, match="not an occrl checkpoint"):
        load_weights(tmp_path / "foreign.pt")
    with pytest.raises(CheckpointError, match="holds only weights"):
        load_checkpoint(other)
    net = load_weights(other)  # a weights file builds its own net
    assert net.heatmap_head is None


def test_resume_refuses_other_settings(tmp_path):
    tr = Trainer(get_train_config("tiny"), tmp_path, seed=0, progress=False, tensorboard=False)
    tr.train(iterations=1)
    tr.close()
    with pytest.raises(ValueError, match="other training settings"):
        Trainer(get_train_config("tiny", lr=1e-3), tmp_path, seed=0, progress=False, tensorboard=False)
    with pytest.raises(ValueError, match="seed"):
        Trainer(get_train_config("tiny"), tmp_path, seed=1, progress=False, tensorboard=False)


def test_curriculum_promotes_only_above_threshold_over_a_full_window():
    c = Curriculum(stage=1, threshold=0.8, window=10)
    assert not c.record([True] * 8)  # window not full yet
    assert not c.record([False, False]) and c.stage == 1  # 8 / 10 is not above 0.8
    assert c.record([True] * 9) and c.stage == 2  # 9 / 10 over the last 10 episodes
    assert len(c.history) == 0  # a new stage starts a new window
    c2 = Curriculum(stage=1, threshold=0.8, window=10)
    assert c2.record([True] * 10) and c2.stage == 2
    c3 = Curriculum(stage=3, threshold=0.8, window=2)
    assert not c3.record([True, True]) and c3.stage == 3


@pytest.mark.integration
def test_resume_from_an_older_checkpoint_supersedes_later_metric_rows(tmp_path):
    cfg = get_train_config("tiny")
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False, checkpoint_every_s=1e9)
    tr.train(iterations=1)  # checkpoint written at the end of train()
    tr._log({"iteration": 2, "frames": 0})  # a row written after the checkpoint, then a crash
    tr.close()
    again = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    again.train(iterations=2)
    again.close()
    iterations = [json.loads(line)["iteration"] for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    assert iterations == [1, 2]


@pytest.mark.integration
def test_hybrid_promotion_rule(tmp_path):
    """promotion='hybrid' (the paper's rule) evaluates hybrid 4x4 on validation tasks and promotes on it."""
    always = get_train_config("tiny", promotion="hybrid", promotion_eval_every=2, promotion_eval_tasks=2, promote_threshold=-1.0)
    tr = Trainer(always, tmp_path / "a", seed=0, progress=False, tensorboard=False)
    tr.train(iterations=3)
    tr.close()
    rows = [json.loads(line) for line in (tmp_path / "a" / "metrics.jsonl").read_text().splitlines()]
    assert [r["stage"] for r in rows] == [1, 2, 2]
    assert "hybrid_success_rate" in rows[1] and "hybrid_success_rate" not in rows[0]
    never = get_train_config(
        "tiny", promotion="hybrid", promotion_eval_every=1, promotion_eval_tasks=2, promote_threshold=1.0, promote_window=1
    )
    tr = Trainer(never, tmp_path / "b", seed=0, progress=False, tensorboard=False)
    tr.train(iterations=2)
    tr.close()
    assert tr.curriculum.stage == 1  # a rate of at most 1 never exceeds the threshold 1
    # under the hybrid rule the learner's window is a statistic only
    c = Curriculum(stage=1, threshold=0.5, window=2)
    assert not c.record([True, True], promote=False) and c.stage == 1 and c.success_rate == 1.0
    assert c.promote() and c.stage == 2 and c.success_rate == 0.0
    # during a DAgger phase too (the cpu-curriculum preset), from the start stage given
    dagger = get_train_config(
        "tiny",
        promotion="hybrid",
        promotion_eval_every=2,
        promotion_eval_tasks=2,
        promote_threshold=-1.0,
        imitation_iters=10,
        imitation_beta_iters=0,
        imitation_beta_min=0.3,
        start_stage=2,
    )
    tr = Trainer(dagger, tmp_path / "e", seed=0, progress=False, tensorboard=False)
    tr.train(iterations=2)
    tr.close()
    rows = [json.loads(line) for line in (tmp_path / "e" / "metrics.jsonl").read_text().splitlines()]
    assert [(r["phase"], r["stage"], r["beta"]) for r in rows] == [("imitation", 2, 0.3), ("imitation", 3, 0.3)]
    assert "hybrid_success_rate" in rows[1]
    with pytest.raises(ValueError, match="needs the heat-map head"):
        Trainer(get_train_config("tiny", promotion="hybrid", heatmap=False), tmp_path / "c", seed=0, progress=False)


def test_checkpoints_from_before_a_new_setting_still_resume(tmp_path):
    def drop_settings(ckpt):
        flat = TrainConfig.from_dict(ckpt["train_config"]).flat_settings()  # as written before the nested form
        for key in ("promotion", "promotion_eval_every", "promotion_eval_tasks"):
            del flat[key]  # and before these settings existed
        ckpt["train_config"] = flat

    cfg = get_train_config("tiny")
    checkpoint_as_written_before(tmp_path, cfg, drop_settings)
    assert Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False).iteration == 1


def test_episode_stats_count_each_rows_first_episode_only():
    """A second episode in a row fits the batch only when short (mostly a success): counting it
    biases the training success upward, so only the first episode of each row counts."""
    from tensordict import TensorDict

    from occrl.training import episode_stats

    T = 10
    done = torch.zeros(3, T, 1, dtype=torch.bool)
    success = torch.zeros(3, T, 1, dtype=torch.bool)
    done[0, 9] = True  # row 0: a failure that ran to the end of the batch
    done[1, 3] = success[1, 3] = True  # row 1: a quick success, then another one
    done[1, 6] = success[1, 6] = True
    # row 2: still running at the end of the batch
    data = TensorDict({"next": {"done": done, "success": success, "reward": -torch.ones(3, T, 1)}}, batch_size=[3, T])
    stats = episode_stats(data)
    assert stats == {"success": [False, True], "returns": [-10.0, -4.0], "lengths": [10, 4]}


@pytest.mark.parametrize("name", sorted(SETTING_CHOICES))
def test_a_setting_outside_its_choices_is_refused_before_the_run_folder_is_made(tmp_path, name):
    with pytest.raises(ValueError, match=re.escape(f"{name} must be one of {SETTING_CHOICES[name]}")):
        Trainer(get_train_config("tiny", **{name: "no-such-choice"}), tmp_path / "run", seed=0, progress=False)
    assert not (tmp_path / "run").exists()
