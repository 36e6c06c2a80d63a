import numpy as np

from occrl.baselines.object_memory import KnownObject, ObjectMemory, current_objects
from occrl.envs import Scene, make_env
from tests.helpers import square

# the target in view, a box beside it; the gripper outside the shelf
TWO = Scene.from_objects(
    [
        {"vertices": square(0.02), "pose": (0.0, 0.3, 0.0), "is_target": True},
        {"vertices": square(0.03), "pose": (0.15, 0.2, 0.0), "is_target": False},
    ],
    gripper_pose=(0.0, -0.1, 0.0),
)


def first_observation():
    env = make_env(batch_size=1, scenes=[TWO], heatmap_target=False)
    obs = env.reset()[0]
    return obs, obs["gripper_pose"].numpy().astype(float)


def hide_everything(obs):
    hidden = obs.clone()
    hidden["objects", "detected"][:] = False
    return hidden


def test_remembers_every_detection_and_plans_in_what_it_knows():
    obs, pose = first_observation()
    assert int(obs["objects", "detected"].sum()) == 2
    memory = ObjectMemory()
    memory.observe(obs, pose, step=1, plan_running=False)
    assert memory.target_in_view and memory.target_id() == int(obs["target_type"][0]) and memory.knows_non_target()
    state, ids = memory.known_state(obs, pose, step=1)
    assert ids == sorted(memory.objects) and len(state.objects) == 2
    assert [o.is_target for o in state.objects] == [memory.objects[i].is_target for i in ids]
    # out of view at the next step: still known where it was seen
    memory.observe(hide_everything(obs), pose, step=2, plan_running=False)
    assert not memory.target_in_view and memory.target_id() is not None
    again, _ = memory.known_state(obs, pose, step=2)
    for a, b in zip(state.objects, again.objects):
        np.testing.assert_array_equal(a.pose, b.pose)
    assert len(memory.views) == 2 and len(memory.distinct_views()) == 1  # the gripper did not move


def test_objects_out_of_view_move_where_the_plan_put_them_once_it_has_run():
    obs, pose = first_observation()
    memory = ObjectMemory()
    memory.observe(obs, pose, step=1, plan_running=False)
    box = next(t for t, k in memory.objects.items() if not k.is_target)
    moved = np.array([-0.1, 0.35, 0.5])
    memory.expect({box: moved})
    memory.observe(hide_everything(obs), pose, step=2, plan_running=True)  # the plan still runs
    assert not np.allclose(memory.objects[box].pose, moved)
    memory.observe(hide_everything(obs), pose, step=3, plan_running=False)  # it has run to its end
    np.testing.assert_array_equal(memory.objects[box].pose, moved)
    assert memory.predicted is None
    # a detection beats the prediction
    memory.expect({box: np.array([0.1, 0.1, 0.0])})
    memory.observe(obs, pose, step=4, plan_running=False)
    np.testing.assert_allclose(memory.objects[box].pose, obs["objects", "pose"][obs["objects", "type_id"] == box][0].numpy())


def test_a_stale_memory_overlapping_a_fresher_object_or_the_gripper_is_dropped():
    box = square(0.03)
    old = KnownObject(1, box, np.array([0.0, 0.2, 0.0]), False, seen_step=1)
    fresh = KnownObject(2, box, np.array([0.01, 0.2, 0.0]), False, seen_step=5)  # 2 cm deep into the old one
    apart = KnownObject(3, box, np.array([0.15, 0.2, 0.0]), True, seen_step=2)
    kept = current_objects([old, fresh, apart], step=5, gripper=[])
    assert [k.type_id for k, _ in kept] == [2, 3]
    gripper = [np.asarray(square(0.03)) + np.array([0.15, 0.2])]  # the gripper where object 3 was remembered
    assert [k.type_id for k, _ in current_objects([apart], step=5, gripper=gripper)] == []
    assert [k.type_id for k, _ in current_objects([apart], step=2, gripper=gripper)] == [3]  # seen now: kept
    np.testing.assert_allclose(kept[0][1], np.asarray(box) + np.array([0.01, 0.2]))  # the shelf-frame outline
