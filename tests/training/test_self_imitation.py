"""Cloning only successes: ``label_episodes="success"`` and the ``"self"`` teacher."""

import pytest
import torch
from tensordict import TensorDict

from occrl.pretrained import weights_file
from occrl.training import Trainer, get_train_config
from occrl.training.stats import successful_episode_frames


def test_successful_episode_frames_mark_the_frames_of_episodes_that_end_in_success():
    T = 8
    done = torch.zeros(3, T, 1, dtype=torch.bool)
    success = torch.zeros(3, T, 1, dtype=torch.bool)
    starts = torch.zeros(3, T, 1, dtype=torch.bool)
    starts[:, 0] = True
    done[0, 2] = success[0, 2] = True  # row 0: a success in 3 steps, then a failure in 2, then one cut off
    starts[0, 3] = True
    done[0, 4] = True
    starts[0, 5] = True
    done[1, 7] = True  # row 1: a failure that fills the batch
    done[2, 5] = success[2, 5] = True  # row 2: a success in 6 steps, then a success in 2
    starts[2, 6] = True
    done[2, 7] = success[2, 7] = True
    data = TensorDict({"is_init": starts, "next": {"done": done, "success": success}}, batch_size=[3, T])
    assert successful_episode_frames(data).int().tolist() == [
        [1, 1, 1, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0],
        [1, 1, 1, 1, 1, 1, 1, 1],
    ]


@pytest.mark.integration
def test_self_imitation_clones_the_learners_own_successful_episodes(tmp_path):
    """The learner acts (no teacher); its own actions are the labels on the frames of the episodes
    that succeed within the batch, and only there."""
    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="self", label_episodes="success", steps_per_env=40, start_stage=1)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False, init_weights=weights_file("occnet"))
    assert tr.expert is None and tr._beta() == 0.0
    data = tr._collect()  # the batch the first iteration collects (each iteration is seeded)
    expected = successful_episode_frames(data).to(torch.float32)
    assert set(expected.unique().tolist()) == {0.0, 1.0}  # successes and failures or cut-off episodes
    before = {k: v.clone() for k, v in tr.net.state_dict().items()}
    tr.train(iterations=1)
    tr.close()
    (batch,) = tr.learner.dagger.batches
    assert torch.equal(batch["expert_weight"].reshape(batch.shape), expected)
    assert torch.equal(batch["expert_action"], data["action"])
    assert any(not torch.equal(before[k], v) for k, v in tr.net.state_dict().items())


def test_label_episodes_is_checked_against_the_teacher(tmp_path):
    assert get_train_config("tiny", imitation_iters=2, imitation_teacher="self").imitation.teacher.label_episodes == "success"
    with pytest.raises(ValueError, match="label_episodes='success'"):
        Trainer(get_train_config("tiny", imitation_iters=2, imitation_teacher="self", label_episodes="all"), tmp_path / "a", progress=False)
    with pytest.raises(ValueError, match="not 'scripted'"):
        Trainer(get_train_config("tiny", imitation_iters=2, label_episodes="success"), tmp_path / "b", progress=False)


def test_graded_weights_count_across_minibatches():
    """The imitation loss divides by the number of weighted frames, not the weights' sum: halving
    every weight halves the loss (a minibatch of low-weight successes takes a smaller step), and
    with weights of 0 or 1 it is the mean over the weighted frames."""
    from occrl.modules import make_occnet
    from occrl.objectives import imitation_nll

    net = make_occnet("paper")
    td = TensorDict({"belief": torch.randn(6, 128), "expert_action": torch.rand(6, 4) * 2 - 1}, batch_size=[6])
    ones = torch.tensor([1.0, 1.0, 1.0, 0.0, 0.0, 1.0])
    full = imitation_nll(net, td.clone().set("expert_weight", ones))
    half = imitation_nll(net, td.clone().set("expert_weight", ones / 2))
    assert torch.allclose(half, full / 2)
    assert torch.allclose(full, imitation_nll(net, td[ones > 0]))
