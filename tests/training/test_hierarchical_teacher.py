"""The hierarchical planner as a DAgger teacher (``imitation_teacher="hierarchical"``): it sees every
observation of the learner's episodes, only observation keys, and re-plans when the learner leaves
its plan (``follow_tolerance``)."""

import json
import math

import pytest
import torch

from occrl.baselines import ScriptedRetriever
from occrl.baselines.hierarchical import HierarchicalPlanner
from occrl.envs import make_env
from occrl.envs import world_constants as C
from occrl.modules import make_occnet
from occrl.training import Trainer, get_train_config
from occrl.training.dagger import OnlineTeacherPolicy
from tests.helpers import first_iteration_labels, scene

TOLERANCE = (0.01, math.radians(10.0))


class RecordingPlanner(HierarchicalPlanner):
    """The real planner, recording the keys of every observation it is given."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.seen_keys: set = set()

    def forward(self, tensordict):
        self.seen_keys |= set(tensordict.keys(include_nested=True, leaves_only=True))
        return super().forward(tensordict)


def test_the_teacher_labels_every_step_from_observations_only():
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    env = make_env(batch_size=2, stage=1, seed=3).append_transform(net.make_primer())
    teacher = RecordingPlanner(plan_seconds=0.3, follow_tolerance=TOLERANCE, seed=1)
    data = env.rollout(6, OnlineTeacherPolicy(net.policy, teacher, beta=0.0))
    assert "privileged" in data.keys()  # the env has ground truth; the teacher never got it
    assert teacher.seen_keys and not any("privileged" in str(k) for k in teacher.seen_keys)
    assert not data["teacher_acts"].any()  # beta 0: the learner acts in every episode
    assert data["expert_action"].shape == data["action"].shape
    assert not torch.allclose(data["expert_action"], data["action"])  # labels are the teacher's
    assert len(teacher.episodes) == 2 and all(ep.step == 6 for ep in teacher.episodes)  # every observation, in order

    torch.manual_seed(0)
    teacher = HierarchicalPlanner(plan_seconds=0.3, follow_tolerance=TOLERANCE, seed=1)
    data = (
        make_env(batch_size=2, stage=1, seed=3)
        .append_transform(net.make_primer())
        .rollout(6, OnlineTeacherPolicy(net.policy, teacher, beta=1.0))
    )
    assert data["teacher_acts"].all()
    assert torch.equal(data["action"], data["expert_action"])  # beta 1: the teacher acts

    with pytest.raises(ValueError, match="observations only"):
        OnlineTeacherPolicy(net.policy, ScriptedRetriever())


def test_who_acts_is_drawn_per_episode():
    torch.manual_seed(2)
    net = make_occnet("paper").eval()
    env = make_env(batch_size=8, stage=1, seed=0).append_transform(net.make_primer())
    teacher = HierarchicalPlanner(plan_seconds=0.2, follow_tolerance=TOLERANCE)
    data = env.rollout(3, OnlineTeacherPolicy(net.policy, teacher, beta=0.5))
    acts = data["teacher_acts"].squeeze(-1)
    assert torch.equal(acts, acts[:, :1].expand_as(acts))  # constant within each episode
    assert 0 < int(acts[:, 0].sum()) < 8  # both kinds of episode at beta 0.5


@pytest.mark.integration
def test_a_plan_is_dropped_once_the_world_leaves_it():
    """Open-loop (the paper) the planner executes a plan to its end whatever happens; with a
    tolerance it plans again when the observed gripper leaves the simulated path."""

    def run(follow_tolerance, push):
        env = make_env(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)])], heatmap_target=False)
        planner = HierarchicalPlanner(seed=0, follow_tolerance=follow_tolerance)
        td = env.reset()
        for t in range(C.MAX_EPISODE_STEPS):
            td = planner(td.exclude("privileged")).update(td.select("privileged"))
            if push(t, planner.episodes[0]):
                td["action"] = torch.tensor([[0.0, 1.0, 0.0, -1.0]])  # sideways instead of the plan
            td = env.step(td)
            if td["next", "done"].any():
                break
            td = td["next"]
        return planner, bool(td["next", "success"].any())

    # the teacher's own plan: followed to the end (the world keeps to the simulated path)
    planner, success = run(TOLERANCE, lambda t, ep: False)
    assert success and planner.episodes[0].replans == 0
    # one push off the reach plan: dropped and planned again, and the target is still retrieved
    pushed = set()

    def push_once(t, ep):
        if ep.queue_kind == "reach" and len(ep.queue) > 2 and not pushed:
            pushed.add(t)
            return True
        return False

    planner, success = run(TOLERANCE, push_once)
    assert pushed and planner.episodes[0].replans >= 1 and success
    assert [p.name for p in planner.last_plans if p.success][:2] == ["reach", "reach"]
    # open-loop, the same push leaves the plan in place (no re-plan)
    pushed.clear()
    planner, _ = run(None, push_once)
    assert pushed and planner.episodes[0].replans == 0

    with pytest.raises(ValueError, match="follow_tolerance"):
        HierarchicalPlanner(follow_tolerance=(0.01, -1.0))


@pytest.mark.integration
def test_trainer_with_the_hierarchical_teacher(tmp_path):
    cfg = get_train_config("tiny", imitation_iters=5, imitation_teacher="hierarchical", collector="single", imitation_beta_min=0.5)
    tr = Trainer(cfg, tmp_path, seed=0, progress=False, tensorboard=False)
    assert isinstance(tr.expert, HierarchicalPlanner) and tr.expert.follow_tolerance is not None
    tr.train(iterations=1)
    tr.close()
    row = json.loads((tmp_path / "metrics.jsonl").read_text().splitlines()[0])
    assert row["phase"] == "imitation"
    assert torch.isfinite(torch.tensor(row["loss_imitation"])) and torch.isfinite(torch.tensor(row["loss_critic"]))
    with pytest.raises(ValueError, match="needs collector 'single'"):
        Trainer(get_train_config("tiny", imitation_teacher="hierarchical", collector="multi"), tmp_path / "b", seed=0, progress=False)


def test_labels_only_of_the_chosen_kinds():
    """label_kinds=("reach", "extract"): the teacher labels the retrieval of a located target only."""
    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    env = make_env(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True)])]).append_transform(net.make_primer())
    teacher = HierarchicalPlanner(seed=0, follow_tolerance=TOLERANCE)
    data = env.rollout(C.MAX_EPISODE_STEPS, OnlineTeacherPolicy(net.policy, teacher, beta=1.0, label_kinds=("reach", "extract")))
    assert data["next", "success"].any()  # the teacher acted and retrieved the visible target
    weight = data["expert_weight"].squeeze(-1)
    assert 0 < int(weight.sum()) < data.shape[-1]  # the sweep's first steps are not labels, the plans' are
    assert weight[0, -1] == 1.0 and weight[0, 0] == 0.0
    from occrl.planners import HybridPlanner

    with pytest.raises(ValueError, match="last_action_kinds"):
        OnlineTeacherPolicy(net.policy, HybridPlanner(net), label_kinds=("reach",))


def test_weighted_imitation_averages_over_labelled_frames():
    from tensordict import TensorDict

    from occrl.objectives import imitation_nll

    net = make_occnet("paper")
    belief = torch.randn(4, 128)
    labels = torch.rand(4, 4) * 2 - 1
    full = imitation_nll(net, TensorDict({"belief": belief, "expert_action": labels}, batch_size=[4]))
    first_two = imitation_nll(net, TensorDict({"belief": belief[:2], "expert_action": labels[:2]}, batch_size=[2]))
    weighted = imitation_nll(
        net, TensorDict({"belief": belief, "expert_action": labels, "expert_weight": torch.tensor([[1.0], [1.0], [0.0], [0.0]])}, [4])
    )
    assert torch.allclose(weighted, first_two) and not torch.allclose(weighted, full)


@pytest.mark.integration
def test_the_hierarchical_teachers_own_successes_only(tmp_path):
    """label_episodes="success" with the hierarchical teacher: only the frames of the episodes it
    acted in and that succeed within the batch stay labels (its own successful demonstrations)."""
    cfg = get_train_config(
        "tiny",
        imitation_iters=5,
        imitation_teacher="hierarchical",
        collector="single",
        imitation_beta_iters=0,
        imitation_beta_min=0.5,
        label_episodes="success",
        start_stage=1,
        steps_per_env=30,
    )
    acted, succeeded, stored = first_iteration_labels(cfg, tmp_path)
    assert bool((acted * succeeded).sum() > 0)  # the teacher solved some of its episodes
    assert bool(((acted == 0) & (succeeded == 1)).any())  # and the learner some of its own: not labels
    assert torch.equal(stored, acted * succeeded)


def test_a_retriever_with_an_episode_memory_cannot_take_over():
    """RetrievalTakeover calls its retriever on the taken-over worlds together, so the retriever
    must decide from each step alone; one that remembers the episode is refused."""
    from occrl.planners import HybridPlanner
    from occrl.training.dagger import RetrievalTakeover

    net = make_occnet("paper").eval()
    with pytest.raises(ValueError, match="HierarchicalPlanner keeps an episode memory"):
        RetrievalTakeover(HybridPlanner(net, m=2, h=2), HierarchicalPlanner(plan_seconds=0.2, follow_tolerance=TOLERANCE), share=0.5)
