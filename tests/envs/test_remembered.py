"""RememberedDetections: earlier detections drawn into the observation (occrl.envs.remembered)."""

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from occrl.baselines import ScriptedRetriever
from occrl.envs import make_env
from occrl.envs.observation import MAX_POLY_VERTICES, MAX_SLOTS
from occrl.envs.remembered import RememberedDetections
from occrl.eval.methods import make_method
from occrl.modules import make_occnet, with_remembered_detections
from occrl.modules.weights import load_weights, save_weights

BOX = np.array([[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]], np.float32)


def observation(detected: dict[int, tuple[float, float]], is_init: bool, gripper=(0.0, -0.2, 0.0)) -> TensorDict:
    """One world's observation (batch (1,)): a 4 cm box in each detected slot at its (x, y)."""
    N, V = MAX_SLOTS, MAX_POLY_VERTICES
    det = torch.zeros(1, N, dtype=torch.bool)
    pose = torch.zeros(1, N, 3)
    verts = torch.zeros(1, N, V, 2)
    nv = torch.zeros(1, N, dtype=torch.int64)
    type_id = torch.zeros(1, N, dtype=torch.int64)
    for k, (x, y) in detected.items():
        det[0, k] = True
        pose[0, k] = torch.tensor([x, y, 0.0])
        verts[0, k, :4] = torch.from_numpy(BOX)
        verts[0, k, 4:] = torch.from_numpy(BOX[0])
        nv[0, k] = 4
        type_id[0, k] = 100 + k
    objects = TensorDict({"detected": det, "type_id": type_id, "pose": pose, "vertices": verts, "num_vertices": nv}, batch_size=[1, N])
    return TensorDict(
        {
            "objects": objects,
            "gripper_pose": torch.tensor([gripper], dtype=torch.float32),
            "gripper_opening": torch.tensor([[0.085]]),
            "is_init": torch.tensor([[is_init]]),
        },
        batch_size=[1],
    )


def test_a_slot_seen_before_is_filled_with_its_last_pose_and_flagged():
    memory = RememberedDetections()
    memory(observation({0: (0.1, 0.2), 1: (-0.1, 0.2)}, is_init=True))
    out = memory(observation({1: (-0.1, 0.25)}, is_init=False))
    objects = out["objects"]
    assert objects["detected"][0, :2].tolist() == [True, True]
    assert objects["remembered"][0, :2].tolist() == [True, False]
    assert torch.allclose(objects["pose"][0, 0], torch.tensor([0.1, 0.2, 0.0]))
    assert objects["type_id"][0, 0] == 100 and objects["num_vertices"][0, 0] == 4
    assert torch.allclose(objects["pose"][0, 1], torch.tensor([-0.1, 0.25, 0.0]))  # the current detection wins


def test_an_episode_start_forgets():
    memory = RememberedDetections()
    memory(observation({0: (0.1, 0.2)}, is_init=True))
    out = memory(observation({}, is_init=True))
    assert not out["objects", "detected"].any() and not out["objects", "remembered"].any()


def test_a_remembered_outline_under_a_fresher_object_or_the_gripper_is_stale():
    memory = RememberedDetections()
    memory(observation({0: (0.1, 0.2), 1: (-0.1, 0.2)}, is_init=True))
    # slot 2 now stands where slot 0 was; the gripper stands where slot 1 was
    out = memory(observation({2: (0.1, 0.21)}, is_init=False, gripper=(-0.1, 0.19, 0.0)))
    assert out["objects", "remembered"][0].tolist()[:3] == [False, False, False]
    assert out["objects", "detected"][0].tolist()[:3] == [False, False, True]
    # the gripper gone, slot 1 is remembered again (the memory keeps it); slot 0 stays under
    # slot 2, remembered where it was seen later
    out = memory(observation({}, is_init=False, gripper=(0.0, -0.3, 0.0)))
    assert out["objects", "remembered"][0].tolist()[:3] == [False, True, True]


def test_bad_input_says_what_is_needed():
    td = observation({0: (0.1, 0.2)}, is_init=True)
    with pytest.raises(KeyError, match="InitTracker"):
        RememberedDetections()(td.exclude("is_init"))
    with pytest.raises(ValueError, match=r"batch \(B,\)"):
        RememberedDetections()(td.unsqueeze(0))


def test_in_the_env_only_the_first_observation_equals_the_papers_and_remembered_slots_are_drawn():
    def rollout(remembered: bool):
        env = make_env(batch_size=2, stage=2, seed=[3, 7], heatmap_target=False, remembered_detections=remembered)
        torch.manual_seed(0)
        return env.rollout(25, ScriptedRetriever(), break_when_any_done=False)

    paper, memory = rollout(False), rollout(True)
    # the privileged retriever acts alike on both (it reads the true state), so the worlds are the same
    assert torch.equal(paper["gripper_pose"], memory["gripper_pose"])
    assert torch.equal(paper["pixels"][:, 0], memory["pixels"][:, 0])  # nothing seen before the first image
    remembered = memory["next", "objects", "remembered"]
    assert remembered.any()
    assert not (remembered & paper["next", "objects", "detected"]).any()  # only slots the camera misses now
    assert (paper["next", "objects", "detected"] <= memory["next", "objects", "detected"]).all()
    steps = remembered.any(-1)
    assert not torch.equal(paper["next", "pixels"][steps], memory["next", "pixels"][steps])
    assert torch.equal(paper["next", "pixels"][~steps], memory["next", "pixels"][~steps])


def test_a_network_trained_with_remembered_detections_takes_its_env_along(tmp_path):
    net = with_remembered_detections(make_occnet("paper"))
    path = tmp_path / "net.pt"
    save_weights(path, net)
    assert load_weights(path).config.remembered_detections
    method = make_method("stochastic-gen", path)
    assert method.remembered_detections
    assert not make_method("stochastic-gen", None).remembered_detections
