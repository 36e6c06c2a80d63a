import numpy as np
import torch

from occrl.baselines.clearing import ClearingRetriever
from occrl.baselines.observed_clearing import NO_TARGET_ACTION, ObservedClearingRetriever
from occrl.envs import ShelfEnv
from occrl.envs import Scene, make_env
from tests.helpers import scene, square

# the target behind a box wider than it, straight ahead of the gripper
HIDDEN = Scene.from_objects(
    [
        {"vertices": square(0.02), "pose": (0.0, 0.3, 0.0), "is_target": True},
        {"vertices": [[-0.04, -0.02], [0.04, -0.02], [0.04, 0.02], [-0.04, 0.02]], "pose": (0.0, 0.12, 0.0), "is_target": False},
    ],
    gripper_pose=(0.0, -0.1, 0.0),
)


def test_reads_observations_only_and_retrieves_a_visible_target_as_the_privileged_retriever():
    retriever = ObservedClearingRetriever()
    assert "privileged" not in retriever.in_keys
    env = ShelfEnv(batch_size=1, scenes=[scene([(0.05, 0.2, 0.4, True), (-0.15, 0.1, 0.0, False)])])
    # the retriever is handed each observation without the privileged entries
    observed = env.rollout(50, lambda td: td.update(retriever(td.exclude("privileged")).select("action")))
    privileged = env.rollout(50, ClearingRetriever())
    assert observed["next", "success"].any()
    np.testing.assert_allclose(observed["action"].numpy(), privileged["action"].numpy(), atol=1e-5)


def test_holds_still_until_the_target_is_seen_then_remembers_where_it_was():
    env = make_env(batch_size=1, scenes=[HIDDEN], heatmap_target=False)  # InitTracker: "is_init"
    td = env.reset()
    retriever = ObservedClearingRetriever()
    assert not bool(td["objects", "detected"][0, 0])  # the target stands behind the wide box
    assert np.array_equal(retriever(td.clone())["action"][0].numpy(), NO_TARGET_ACTION)
    seen = td.clone()
    seen["objects", "detected"][0, 0] = True  # as if the camera had reported it
    seen["objects", "type_id"][0, 0] = seen["target_type"][0, 0]
    seen["objects", "pose"][0, 0] = torch.tensor([0.0, 0.3, 0.0])
    seen["objects", "vertices"][0, 0] = torch.from_numpy(env.base_env.worlds[0].padded_vertices[0]).float()
    seen["objects", "num_vertices"][0, 0] = 4
    retriever = ObservedClearingRetriever()
    first = retriever(seen.clone())["action"][0].numpy()
    assert not np.array_equal(first, NO_TARGET_ACTION)
    later = td.clone()
    later["is_init"][:] = False  # the same episode, the target out of view again
    assert np.array_equal(retriever(later)["action"][0].numpy(), first)
    assert np.array_equal(retriever(td.clone())["action"][0].numpy(), NO_TARGET_ACTION)  # a new episode forgets it
