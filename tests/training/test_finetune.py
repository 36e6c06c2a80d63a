"""PPO fine-tuning of a warm-started net: --init-weights, critic warm-up, loss_bc, KL early stop,
batch-norm statistics that stay put, and the collection/update consistency PPO's ratio needs."""

import json

import pytest
import torch

from occrl.modules import make_occnet
from occrl.training import CheckpointError, Trainer, get_train_config
from occrl.modules.weights import save_weights


def _state(module):
    return {k: v.clone() for k, v in module.state_dict().items()}


def _equal(a, b):
    return all(torch.equal(a[k], b[k]) for k in a)


def _rows(run_dir):
    return [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]


@pytest.fixture
def start_weights(tmp_path):
    torch.manual_seed(123)
    net = make_occnet("paper")
    path = tmp_path / "start.pt"
    save_weights(path, net)
    return path, _state(net)


def test_init_weights_start_a_new_run_and_are_recorded(tmp_path, start_weights):
    path, weights = start_weights
    tr = Trainer(get_train_config("tiny"), tmp_path / "run", seed=0, progress=False, tensorboard=False, init_weights=path)
    assert _equal(weights, _state(tr.net))
    tr.train(iterations=1)
    tr.close()
    resumed = Trainer(get_train_config("tiny"), tmp_path / "run", seed=0, progress=False, tensorboard=False)
    assert resumed.iteration == 1 and resumed.init_weights["path"] == str(path)
    assert len(resumed.init_weights["sha256"]) == 64
    with pytest.raises(CheckpointError, match="another architecture"):
        Trainer(get_train_config("tiny", heatmap=False), tmp_path / "other", seed=0, progress=False, init_weights=path)


def test_init_weights_written_before_a_setting_existed_start_a_run(tmp_path):
    """Files written before a network setting was added (e.g. occnet-warmstart and occnet-takeover
    predate ``remembered_detections``) hold the architecture of its default and start a run."""
    for heatmap in (False, True):
        torch.manual_seed(7)
        net, path = make_occnet("paper", heatmap=heatmap), tmp_path / f"old_{heatmap}.pt"
        save_weights(path, net)
        obj = torch.load(path, weights_only=True)
        del obj["net_config"]["remembered_detections"]  # as written before the setting existed
        torch.save(obj, path)
        tr = Trainer(
            get_train_config("tiny", heatmap=heatmap),
            tmp_path / f"run_{heatmap}",
            seed=0,
            progress=False,
            tensorboard=False,
            init_weights=path,
        )
        assert _equal(_state(net), _state(tr.net))
        tr.close()


@pytest.mark.integration
def test_critic_warmup_trains_the_value_head_only(tmp_path, start_weights):
    path, _ = start_weights
    cfg = get_train_config("tiny", critic_warmup_iters=1, batch_norm_frames=0)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False, init_weights=path)
    before = {name: _state(getattr(tr.net, name)) for name in ("encoder", "actor", "critic")}
    tr.train(iterations=1)
    assert _rows(tmp_path)[-1]["phase"] == "critic_warmup"
    assert _equal(before["encoder"], _state(tr.net.encoder))  # trunk untouched
    assert _equal(before["actor"], _state(tr.net.actor))  # policy untouched
    assert not _equal(before["critic"], _state(tr.net.critic))  # value head trained
    tr.train(iterations=2)
    tr.close()
    assert _rows(tmp_path)[-1]["phase"] == "ppo"


def test_ppo_ratio_starts_at_one_every_iteration(tmp_path):
    # one minibatch per iteration: the logged ratio statistics are those of the net that collected
    # the batch (before the batch-norm refresh moved behind the update, 47 % of them were clipped)
    cfg = get_train_config("tiny", minibatch_envs=4, epochs=1, entropy_coeff=0.0)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    tr.train(iterations=3)
    tr.close()
    for row in _rows(tmp_path):
        assert row["clip_fraction"] == 0.0 and abs(row["kl_approx"]) < 1e-5


def test_frozen_batch_norm_statistics(tmp_path):
    tr = Trainer(get_train_config("tiny", batch_norm_frames=0), tmp_path, seed=0, progress=False, tensorboard=False)
    stats = {k: v.clone() for k, v in tr.net.encoder.state_dict().items() if "running" in k}
    assert stats
    tr.train(iterations=1)
    tr.close()
    assert all(torch.equal(v, tr.net.encoder.state_dict()[k]) for k, v in stats.items())


def test_kl_early_stop(tmp_path):
    cfg = get_train_config("tiny", epochs=3, target_kl=1e-9, optimizer="adam", lr=1e-2)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    tr.train(iterations=2)
    tr.close()
    rows = _rows(tmp_path)
    # 3 epochs x 2 minibatches would be 6 updates; the first large step exceeds the KL target
    assert all(1 <= r["updates"] < 6 for r in rows)


def test_removed_settings_resume_when_off_and_are_refused_when_on(tmp_path):
    from occrl.training import TrainConfig
    from occrl.training.config import same_run_settings

    base = get_train_config("cpu-finetune")
    old = {**base.flat_settings(), "ppo_bc_coeff": 0.0, "ppo_bc_min_scale": 0.01, "freeze_policy_scale": False}
    assert TrainConfig.from_dict(old) == base and same_run_settings(old, base.to_dict())
    for name, value in (("ppo_bc_coeff", 1.0), ("freeze_policy_scale", True)):
        with pytest.raises(ValueError, match=f"{name}={value!r} was removed from occrl.*git checkout eed1cea"):
            TrainConfig.from_dict({**old, name: value})
    # the experiments' settings removed later: accepted at their old defaults, refused otherwise
    older = {**old, "detail_lr": 0.0, "start_scenes": "", "start_scenes_share": 0.3, "task_copies": 1, "teacher_roll_in": 0}
    older |= {"critic_to_trunk": True, "teacher_roots": "own", "takeover_at": "first-sight", "teacher_label_kinds": "all"}
    assert TrainConfig.from_dict(older) == base and same_run_settings(older, base.to_dict())
    for name, value in (("task_copies", 2), ("start_scenes", "pool.json"), ("critic_to_trunk", False), ("teacher_roots", "state")):
        with pytest.raises(ValueError, match=f"{name}={value!r} was removed from occrl.*git checkout 53b1240"):
            TrainConfig.from_dict({**older, name: value})
    with pytest.raises(ValueError, match=r"unknown training settings \['ppo_bc_coeff'\]"):
        get_train_config("tiny", ppo_bc_coeff=0.5)  # no longer a setting


def test_replay_workers_keep_the_previous_stage(tmp_path):
    cfg = get_train_config("tiny", collector="multi", workers=2, num_envs=4, replay_stage_workers=1, start_stage=2)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert (
        tr.collection.worker_stages(2) == [2, 1] and tr.collection.worker_stages(3) == [3, 2] and tr.collection.worker_stages(1) == [1, 1]
    )
    with pytest.raises(ValueError, match="replay_stage_workers=1 needs collector 'multi' or 'ray'"):
        Trainer(get_train_config("tiny", replay_stage_workers=1), tmp_path / "single", seed=0, progress=False)
    with pytest.raises(ValueError, match="fewer than workers=2"):
        Trainer(get_train_config("tiny", collector="multi", replay_stage_workers=2), tmp_path / "all", seed=0, progress=False)
