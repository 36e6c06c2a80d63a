"""Expert iteration: the hybrid planner labels the learner's frames (``imitation_teacher="hybrid"``)."""

import json

import pytest
import torch

from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner
from occrl.training import Trainer, get_train_config
from occrl.training.dagger import label_with_planner, target_in_view
from occrl.pretrained import weights_file
from tests.helpers import first_iteration_labels


def test_planner_labels_are_its_decisions_without_privileged_state():
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    data = make_env(batch_size=2, stage=2, seed=3).append_transform(net.make_primer()).rollout(3, net.policy)
    labels = label_with_planner(data.clone(), net, seed=7, m=2, h=2)["expert_action"]
    # the same planner deciding frame by frame, in the batch's flattened order, from the stored LSTM state
    planner = HybridPlanner(net, m=2, h=2, seed=7)
    flat = data.reshape(-1)
    one_by_one = torch.stack([planner(flat[i : i + 1].select(*planner.in_keys).copy())["action"][0] for i in range(flat.shape[0])])
    # batched over frames, the planner draws each frame's roll-out noise in the same order
    assert torch.allclose(labels.reshape(-1, 4), one_by_one, atol=1e-5)
    blind = label_with_planner(data.exclude("privileged").clone(), net, seed=7, m=2, h=2)["expert_action"]
    assert torch.equal(blind, labels)
    assert not torch.allclose(labels, data["action"])  # labels are the planner's, not the learner's


@pytest.mark.integration
def test_trainer_with_planner_teacher(tmp_path):
    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="hybrid", imitation_beta_min=0.3)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    tr.train(iterations=1)
    tr.close()
    row = json.loads((tmp_path / "metrics.jsonl").read_text().splitlines()[0])
    assert row["phase"] == "imitation" and row["beta"] == 0.0  # the learner always acts
    assert torch.isfinite(torch.tensor(row["loss_imitation"]))
    with pytest.raises(ValueError, match="needs the heat-map head"):
        Trainer(get_train_config("tiny", imitation_teacher="hybrid", heatmap=False), tmp_path / "c", seed=0, progress=False)


@pytest.mark.integration
def test_trainer_with_the_planner_acting(tmp_path):
    """imitation_teacher="hybrid-acting": the hybrid planner on the live network acts in every
    episode; its actions are the labels (so the value regresses on the planner's own returns)."""
    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="hybrid-acting", collector="single")
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert isinstance(tr.expert, HybridPlanner) and tr.expert.net is tr.net
    data = tr._collect()
    # every action of the batch is a decision of the planner (its decisions' first actions, in order)
    decided = torch.stack([torch.as_tensor(d.action, dtype=torch.float32) for d in tr.expert.decisions[-data.numel() :]])
    taken = data["action"].transpose(0, 1).reshape(-1, 4)  # decided world by world at each step
    assert torch.allclose(taken, decided, atol=1e-6)
    tr.train(iterations=1)
    tr.close()
    row = json.loads((tmp_path / "metrics.jsonl").read_text().splitlines()[0])
    assert row["phase"] == "imitation" and row["beta"] == 1.0
    assert torch.isfinite(torch.tensor(row["loss_imitation"])) and torch.isfinite(torch.tensor(row["loss_critic"]))
    with pytest.raises(ValueError, match="needs collector 'single'"):
        Trainer(get_train_config("tiny", imitation_teacher="hybrid-acting", collector="multi"), tmp_path / "b", seed=0, progress=False)


@pytest.mark.integration
def test_hybrid_acting_teacher_on_onnxruntime_plans_on_the_updated_weights(tmp_path):
    """teacher_inference="onnxruntime": the acting planner's ONNX export follows the updates."""
    pytest.importorskip("onnxruntime")
    from occrl.planners.rhp import NetworkStepper

    cfg = get_train_config(
        "tiny", imitation_iters=5, imitation_teacher="hybrid-acting", collector="single", teacher_inference="onnxruntime"
    )
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert tr.expert.inference == "onnxruntime"
    tr.train(iterations=2)
    tr._collect()  # syncs the planner to the weights after the second update
    pixels, h = torch.rand(3, 3, 64, 64, generator=torch.Generator().manual_seed(0)), torch.zeros(3, 1, 128)
    onnx, eager = tr.expert.stepper.step(pixels, h, h)[0], NetworkStepper(tr.net).step(pixels, h, h)[0]
    torch.testing.assert_close(onnx["loc"], eager["loc"], atol=1e-4, rtol=1e-4)
    tr.close()


@pytest.mark.integration
def test_retrieval_takeover_lets_the_scripted_retriever_act_from_the_first_sight_of_the_target(tmp_path):
    """retrieval_takeover=1: in every episode the planner acts until the observation first shows
    the target and the scripted retriever from there to the episode's end; the executed actions
    are the labels."""
    from occrl.baselines import ScriptedRetriever
    from occrl.training.dagger import RetrievalTakeover, label_with_expert, since_first_sight

    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="hybrid-acting", collector="single", retrieval_takeover=1.0)
    tr = Trainer(cfg, tmp_path, seed=1, progress=False, tensorboard=False)
    assert isinstance(tr.expert, RetrievalTakeover)
    data = tr._collect()
    taken = since_first_sight(data)
    assert taken.any() and not taken.all()
    assert tr.expert.frames_taken_over == int(taken.sum()) and tr.expert.frames == data.numel()
    scripted = label_with_expert(data.clone(), ScriptedRetriever())["expert_action"]
    assert torch.equal(data["action"][taken], scripted[taken])
    assert not torch.equal(data["action"][~taken], scripted[~taken])
    tr.train(iterations=1)
    tr.close()
    with pytest.raises(ValueError, match="retrieval_takeover applies to"):
        Trainer(get_train_config("tiny", retrieval_takeover=0.5), tmp_path / "b", seed=0, progress=False)
    with pytest.raises(ValueError, match="retrieval_takeover must be a share"):
        Trainer(
            get_train_config("tiny", imitation_teacher="hybrid-acting", collector="single", retrieval_takeover=1.5),
            tmp_path / "c",
            seed=0,
            progress=False,
        )


def test_since_first_sight_holds_from_the_first_view_of_the_target_to_the_episode_end():
    from tensordict import TensorDict

    from occrl.training.dagger import since_first_sight

    shown = torch.tensor([[False, True, False, False, True, False]])  # seen at 1 and 4
    is_init = torch.tensor([[True, False, False, True, False, False]])  # episodes start at 0 and 3
    data = TensorDict(
        {
            "objects": TensorDict(
                {"detected": shown.unsqueeze(-1), "type_id": torch.ones(1, 6, 1, dtype=torch.long)}, batch_size=[1, 6, 1]
            ),
            "target_type": torch.ones(1, 6, 1, dtype=torch.long),
            "is_init": is_init.unsqueeze(-1),
        },
        batch_size=[1, 6],
    )
    assert since_first_sight(data).tolist() == [[False, True, True, False, True, True]]


def test_the_clearing_teacher_labels_only_from_the_first_sight_of_the_target(tmp_path):
    from occrl.baselines.clearing import ClearingRetriever

    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="clearing", imitation_beta_iters=0, imitation_beta_min=0.5)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert isinstance(tr.expert, ClearingRetriever)
    tr.train(iterations=1)
    tr.close()
    row = json.loads((tmp_path / "metrics.jsonl").read_text().splitlines()[0])
    assert row["phase"] == "imitation" and torch.isfinite(torch.tensor(row["loss_imitation"]))
    (batch,) = tr.learner.dagger.batches  # the labelled batch the update imitated
    weight = batch["expert_weight"].reshape(batch.shape)
    starts = batch["is_init"].reshape(batch.shape)
    assert set(weight.unique().tolist()) == {0.0, 1.0}  # some frames before the first sight, some after
    assert bool(((weight[:, 1:] >= weight[:, :-1]) | starts[:, 1:]).all())  # once labelled, to the episode end


def test_the_observed_clearing_teacher_acts_and_labels_from_the_first_sight_on(tmp_path):
    from occrl.baselines.observed_clearing import ObservedClearingRetriever
    from occrl.training.dagger import OnlineTeacherPolicy, since_first_sight

    net = make_occnet("paper").eval()
    env = make_env(batch_size=2, stage=2, seed=1).append_transform(net.make_primer())  # hidden in world 0, seen in world 1
    policy = OnlineTeacherPolicy(net.policy, ObservedClearingRetriever(), beta=1.0, from_first_sight=True)
    data = env.rollout(6, policy)
    seen = since_first_sight(data)
    assert bool(seen[1].all()) and not bool(seen[0, 0])
    acts = data["teacher_acts"].reshape(seen.shape)
    assert torch.equal(acts, seen)  # beta = 1: the teacher acts exactly from the first sight on
    taken = data["action"][acts]
    assert torch.equal(taken, data["expert_action"][acts])
    # the trainer: the learner searches, the frames the teacher acted on are the labels
    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="clearing-observed", imitation_beta_iters=0, imitation_beta_min=0.5)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert isinstance(tr.expert, ObservedClearingRetriever)
    tr.train(iterations=1)
    tr.close()
    (batch,) = tr.learner.dagger.batches
    weight = batch["expert_weight"].reshape(batch.shape)
    starts = batch["is_init"].reshape(batch.shape)
    assert set(weight.unique().tolist()) == {0.0, 1.0}  # the teacher acted in some episodes, from the first sight on
    assert bool(((weight[:, 1:] >= weight[:, :-1]) | starts[:, 1:]).all())  # once it acts, to the episode end
    with pytest.raises(ValueError, match="collector 'single'"):
        Trainer(get_train_config("tiny", imitation_iters=5, imitation_teacher="clearing-observed", collector="multi"), tmp_path / "b")


@pytest.mark.integration
def test_hybrid_acting_teacher_with_fixed_weights_teaches_a_network_without_heatmap(tmp_path):
    """teacher_weights: the hybrid planner acts with a fixed network (here a saved random one), so
    a learner without heat-map head learns from its episodes; the teacher's weights never move."""
    from occrl.modules.weights import save_weights

    torch.manual_seed(5)
    teacher = make_occnet("paper").eval()
    path = tmp_path / "teacher.pt"
    save_weights(path, teacher)
    cfg = get_train_config(
        "tiny", imitation_iters=5, imitation_teacher="hybrid-acting", collector="single", heatmap=False, teacher_weights=str(path)
    )
    tr = Trainer(cfg, tmp_path / "run", seed=0, progress=False, tensorboard=False)
    assert tr.expert.net is not tr.net and not tr.net.config.heatmap
    before = {k: v.clone() for k, v in tr.net.state_dict().items()}
    data = tr._collect()
    decided = torch.stack([torch.as_tensor(d.action, dtype=torch.float32) for d in tr.expert.decisions[-data.numel() :]])
    assert torch.allclose(data["action"].transpose(0, 1).reshape(-1, 4), decided, atol=1e-6)  # the planner acts
    tr.train(iterations=1)
    tr.close()
    assert all(torch.equal(v, teacher.state_dict()[k]) for k, v in tr.expert.net.state_dict().items())  # fixed
    assert any(not torch.equal(v, before[k]) for k, v in tr.net.state_dict().items())  # the learner learned
    for settings, match in (
        (dict(imitation_teacher="hybrid-acting", heatmap=False), "or teacher_weights naming a fixed network"),
        (dict(imitation_teacher="scripted", teacher_weights=str(path)), "teacher_weights applies to"),
        (dict(imitation_teacher="hybrid-acting", teacher_weights=str(tmp_path / "none.pt")), "neither a weights file"),
        (dict(imitation_teacher="hybrid-acting", teacher_weights="occnet-noheatmap"), "has no heat-map head"),
    ):
        with pytest.raises(ValueError, match=match):
            Trainer(get_train_config("tiny", collector="single", **settings), tmp_path / "bad", seed=0, progress=False)
    assert not (tmp_path / "bad" / "checkpoint.pt").exists()


@pytest.mark.integration
def test_clearing_observed_teacher_with_successes_only(tmp_path):
    """label_episodes="success" with the observed clearing teacher: its labels are the actions it
    took, so only the frames it acted on in episodes that succeed within the batch stay labels."""
    cfg = get_train_config(
        "tiny",
        imitation_iters=5,
        imitation_teacher="clearing-observed",
        imitation_beta_iters=0,
        imitation_beta_min=1.0,
        label_episodes="success",
        start_stage=1,
        steps_per_env=40,
    )
    acted, succeeded, stored = first_iteration_labels(cfg, tmp_path)
    assert bool(((acted == 1) & (succeeded == 0)).any())  # some of its frames are not labels: episodes not finished
    assert bool((acted * succeeded).sum() > 0)  # and some are
    assert torch.equal(stored, acted * succeeded)


def _clearing_teacher_collection(tmp_path, init_weights: str | None = None, **settings):
    """One collection of a tiny run whose teacher is the observed clearing retriever (drawn per
    episode from the first iteration on, ``imitation_beta_min`` of the settings): the trainer,
    closed, and its data."""
    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="clearing-observed", imitation_beta_iters=0, **settings)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False, init_weights=init_weights)
    data = tr._collect()
    tr.close()
    return tr, data


def test_clearing_observed_teacher_with_action_noise(tmp_path):
    """teacher_action_noise (DART): where the teacher acts its motion is disturbed, the gripper
    command and the labels are its decisions; other teachers refuse the setting."""
    tr, data = _clearing_teacher_collection(
        tmp_path, weights_file("occnet"), imitation_beta_min=1.0, teacher_action_noise=0.2, start_stage=1, steps_per_env=20
    )
    acted = data["teacher_acts"].reshape(data.shape)
    assert bool(acted.any())
    executed, decided = data["action"][acted], data["expert_action"][acted]
    assert torch.equal(executed[:, 3], decided[:, 3])  # the gripper command as decided
    inside = decided[:, :3].abs() < 0.5  # far from the clipping bounds
    difference = (executed[:, :3] - decided[:, :3])[inside]
    assert 0.15 < float(difference.std()) < 0.25 and abs(float(difference.mean())) < 0.05
    with pytest.raises(ValueError, match="teacher_action_noise applies to"):
        get_train_config("tiny", imitation_iters=5, teacher_action_noise=0.2).validate()
    from occrl.training.dagger import OnlineTeacherPolicy

    with pytest.raises(ValueError, match="action_noise must be in"):
        OnlineTeacherPolicy(tr.net.policy, tr.expert, action_noise=-0.1)


@pytest.mark.integration
def test_clearing_observed_teacher_with_the_hierarchical_search(tmp_path):
    """teacher_search="hierarchical": the drawn teacher acts from the episode's start, the
    hierarchical planner's sweep before the first sight, the clearing retriever after, and every
    frame it acted on is a label (the learner searches in none of them)."""
    from occrl.baselines.handover import SearchThenRetrieve

    tr, data = _clearing_teacher_collection(
        tmp_path, teacher_search="hierarchical", imitation_beta_min=0.5, start_stage=2, steps_per_env=20
    )
    assert isinstance(tr.expert, SearchThenRetrieve) and tr.expert.retriever_follows
    acted = data["teacher_acts"].reshape(data.shape)
    starts = data["is_init"].reshape(data.shape)
    assert bool(acted.any()) and not bool(acted.all())
    assert bool(((acted[:, 1:] == acted[:, :-1]) | starts[:, 1:]).all())  # a drawn episode is the teacher's throughout
    assert bool(acted[:, 0].any())  # from the start, before any sight of the target
    sweeping = data["expert_action"][acted & ~target_in_view(data).reshape(data.shape)]
    assert len(sweeping) and bool((sweeping[:, 1].abs() == 1.0).any())  # its sweeps: full lateral speed
    with pytest.raises(ValueError, match="teacher_search applies to"):
        get_train_config("tiny", imitation_iters=5, imitation_teacher="hierarchical", teacher_search="hierarchical").validate()
