"""Training with TorchRL's RayCollector on a local 2-worker Ray runtime."""

import logging

import pytest
import torch

from occrl.distributed import ray_available
from occrl.training import Trainer, get_train_config

pytestmark = pytest.mark.skipif(not ray_available(), reason="ray is not installed (pip install 'occrl[ray]')")


def _weights(trainer: Trainer) -> dict:
    return {k: v.clone() for k, v in trainer.net.state_dict().items()}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


@pytest.fixture(scope="module")
def multi_reference(tmp_path_factory):
    """Two PPO iterations with the multi-process collector: batches and weights after each."""
    trainer = Trainer(
        get_train_config("tiny", collector="multi", workers=2), tmp_path_factory.mktemp("multi"), seed=3, progress=False, tensorboard=False
    )
    out = []
    try:
        for it in (1, 2):
            trainer.train(iterations=it)
            out.append(_weights(trainer))
    finally:
        trainer.close()
    return out


@pytest.mark.integration
def test_ray_collection_and_ppo_update_match_multi_and_survive_a_dead_worker(multi_reference, tmp_path, caplog):
    import ray

    trainer = Trainer(get_train_config("tiny", collector="ray", workers=2), tmp_path, seed=3, progress=False, tensorboard=False)
    try:
        summary = trainer.train(iterations=1)  # 2 Ray workers collect, then one PPO update
        assert summary["frames"] == trainer.config.frames_per_batch
        assert "loss_objective" in summary and torch.isfinite(torch.tensor(summary["loss_objective"]))
        # same seeds -> the same batch as the multi-process collector -> the same weights
        assert _same(_weights(trainer), multi_reference[0])

        ray.kill(trainer.collection.collector.remote_collectors[0], no_restart=True)
        with caplog.at_level(logging.ERROR, logger="occrl.training.trainer"):
            trainer.train(iterations=2)
        assert any("Ray collector worker died" in r.getMessage() for r in caplog.records)
        # the repeated iteration is the one the dead worker would have collected
        assert _same(_weights(trainer), multi_reference[1])
    finally:
        trainer.close()
    assert not ray.is_initialized()  # the runtime the trainer started is stopped


def test_ray_run_resumes_a_multi_run_but_not_another_preset(tmp_path):
    trainer = Trainer(get_train_config("tiny", collector="multi", workers=2), tmp_path, seed=0, progress=False, tensorboard=False)
    trainer.save()
    trainer.close()
    resumed = Trainer(get_train_config("tiny", collector="ray", workers=2), tmp_path, seed=0, progress=False, tensorboard=False)
    assert resumed.iteration == 0
    resumed.close()
    with pytest.raises(ValueError, match="other training settings"):
        Trainer(get_train_config("tiny", collector="single"), tmp_path, seed=0, progress=False, tensorboard=False)
