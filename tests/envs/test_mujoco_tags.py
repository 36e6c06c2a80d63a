"""MuJoCo with fiducial tags: where the tags sit, that they change neither physics nor the geometric
visibility, that the wrist camera's image decodes where the catalogue says, and
``make_env(world="mujoco", perception="tags")``. Real MuJoCo (an OpenGL backend) and real OpenCV.
"""

import math

import numpy as np
import pytest
import torch

pytest.importorskip("mujoco")
pytest.importorskip("dm_control")
pytest.importorskip("cv2")

from occrl.envs import MujocoShelfEnv, Scene, make_env  # noqa: E402
from occrl.envs.detection_slots import DetectionSlots  # noqa: E402
from occrl.envs.episodes import seeded_task_env, task_scenes  # noqa: E402
from occrl.envs.mujoco3d.camera import gl_available  # noqa: E402
from occrl.envs.mujoco3d.tag_perception import TagObserver, tag_catalogue  # noqa: E402
from occrl.envs.mujoco3d.tags import (  # noqa: E402
    DEFAULT_TAG_LAYOUT,
    MAX_PAIRED_TYPE,
    MAX_TAG_SIZE,
    MIN_TAG_SIZE,
    SECOND_TAG_BASE,
    TAG_LAYOUTS,
    TagLayout,
    tag_id,
    tag_placements,
)
from occrl.envs.mujoco3d.world import MujocoWorld  # noqa: E402
from occrl.envs.mujoco3d.wrist_camera import WristCamera, WristCameraSettings  # noqa: E402
from tests.helpers import scene  # noqa: E402

pytestmark = pytest.mark.skipif(not gl_available()[0], reason=f"no OpenGL backend for MuJoCo: {gl_available()[1]}")

HIDDEN = scene([(0.0, 0.1, 0.0, False), (0.0, 0.3, 0.0, True)])  # the target wholly behind a box
TWO_IN_VIEW = scene([(-0.06, 0.15, 0.2, False), (0.07, 0.2, -0.3, True)], half=0.025)


def test_tags_sit_on_every_face_wide_enough_with_ids_by_type():
    triangle = [[-0.02, -0.02], [0.03, -0.02], [-0.02, -0.01]]  # face 2 is 1 cm: no tag fits
    s = Scene.from_objects(
        [
            {
                "vertices": [[-0.03, -0.02], [0.03, -0.02], [0.03, 0.02], [-0.03, 0.02]],
                "pose": (0.0, 0.2, 0.0),
                "is_target": True,
                "type_id": 5,
            },
            {"vertices": triangle, "pose": (0.15, 0.2, 0.0), "is_target": False, "type_id": 2},
        ]
    )
    tags = tag_placements(s, np.array([0.12, 0.1]))
    assert [(t.object_index, t.face, t.tag_id) for t in tags] == [(0, 0, 32), (0, 1, 33), (0, 2, 34), (0, 3, 35), (1, 0, 8), (1, 1, 9)]
    assert all(MIN_TAG_SIZE <= t.size <= MAX_TAG_SIZE for t in tags)
    assert all(abs(t.up - 0.07) < 1e-12 for t in tags)  # at the wrist camera's height
    with pytest.raises(ValueError, match=r"type id in \[1, 73\]"):
        tag_id(74, 0)
    with pytest.raises(ValueError, match="one height per object"):
        tag_placements(s, np.array([0.12]))


def test_a_tag_layout_sizes_the_tags_and_bad_layouts_are_refused():
    box = [[-0.03, -0.02], [0.03, -0.02], [0.03, 0.02], [-0.03, 0.02]]  # faces of 6 and 4 cm
    narrow = [[-0.006, -0.03], [0.006, -0.03], [0.006, 0.03], [-0.006, 0.03]]  # faces of 1.2 and 6 cm
    s = Scene.from_objects(
        [
            {"vertices": box, "pose": (0.0, 0.2, 0.0), "is_target": True, "type_id": 5},
            {"vertices": narrow, "pose": (0.15, 0.2, 0.0), "is_target": False, "type_id": 2},
        ]
    )
    heights = np.array([0.12, 0.12])
    fitted = [(t.type_id, t.face, round(t.size, 4)) for t in tag_placements(s, heights)]
    small = [(t.type_id, t.face, round(t.size, 4)) for t in tag_placements(s, heights, TAG_LAYOUTS["at-most-3cm"])]
    assert fitted == [
        (5, 0, 0.0472),
        (5, 1, 0.0312),
        (5, 2, 0.0472),
        (5, 3, 0.0312),
        (2, 0, 0.0088),
        (2, 1, 0.0472),
        (2, 2, 0.0088),
        (2, 3, 0.0472),
    ]
    assert small == [(5, 0, 0.03), (5, 1, 0.0288), (5, 2, 0.03), (5, 3, 0.0288), (2, 1, 0.03), (2, 3, 0.03)]  # none on a 1.2 cm face
    # pairs: two tags on the faces of 3.95 cm and more, one on each half; the second id from SECOND_TAG_BASE
    pairs = [(t.tag_id, t.face, round(t.along, 4), round(t.size, 4)) for t in tag_placements(s, heights, TAG_LAYOUTS["pairs"])]
    assert pairs == [
        (32, 0, -0.015, 0.0232),
        (SECOND_TAG_BASE + 32, 0, 0.015, 0.0232),
        (33, 1, -0.01, 0.0152),
        (SECOND_TAG_BASE + 33, 1, 0.01, 0.0152),
        (34, 2, -0.015, 0.0232),
        (SECOND_TAG_BASE + 34, 2, 0.015, 0.0232),
        (35, 3, -0.01, 0.0152),
        (SECOND_TAG_BASE + 35, 3, 0.01, 0.0152),
        (8, 0, 0.0, 0.0088),
        (9, 1, -0.015, 0.0232),
        (SECOND_TAG_BASE + 9, 1, 0.015, 0.0232),
        (10, 2, 0.0, 0.0088),
        (11, 3, -0.015, 0.0232),
        (SECOND_TAG_BASE + 11, 3, 0.015, 0.0232),
    ]
    assert [t for t in TagLayout(pair_size=0.016).tags_on_face(0.04)] == [(0.0, TagLayout().tag_size(0.04))]  # halves too small
    high = Scene.from_objects([{"vertices": box, "pose": (0.0, 0.2, 0.0), "is_target": True, "type_id": MAX_PAIRED_TYPE + 1}])
    assert len(tag_placements(high, heights[:1])) == 4  # single tags go up to type 73
    with pytest.raises(ValueError, match=r"pairs tags type ids 1 to 36 .* type ids \[37\]; one tag per face \(tag_layout='fitted'\)"):
        tag_placements(high, heights[:1], TAG_LAYOUTS["pairs"])
    with pytest.raises(ValueError, match=r"type id in \[1, 36\]"):
        tag_id(37, 0, second=True)
    for bad, match in (
        (dict(min_size=0.05, max_size=0.03), "min_size <= max_size"),
        (dict(max_size=float("nan")), "finite number"),
        (dict(clearance=-0.001), "clearance must be in"),
        (dict(pair_size=0.005), r"pair_size must be None or in \[min_size, max_size\]"),
        (dict(pair_size=float("inf")), "pair_size must be a finite number"),
    ):
        with pytest.raises(ValueError, match=match):
            TagLayout(**bad)
    with pytest.raises(ValueError, match="tag_layout must be a TagLayout or one of"):
        MujocoShelfEnv(perception="tags", tag_layout="huge")
    with pytest.raises(ValueError, match="give it with perception='tags'"):
        MujocoShelfEnv(tag_layout="at-most-3cm")
    with pytest.raises(ValueError, match="tag_layout is a setting of the MuJoCo world"):
        make_env(tag_layout="at-most-3cm")
    # occrl eval --tag-layout offers exactly the named layouts
    import argparse

    from occrl.cli import make_parser

    sub = next(a for a in make_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert next(a.choices for a in sub.choices["eval"]._actions if a.dest == "tag_layout") == list(TAG_LAYOUTS)


def test_an_env_with_another_tag_layout_wears_those_tags():
    env = make_env(
        batch_size=1, scenes=[TWO_IN_VIEW], seed=[0], world="mujoco", perception="tags", tag_layout="at-most-3cm", heatmap_target=False
    )
    env.reset()
    sizes = [t.size for t in env.base_env.worlds[0].tags]
    assert sizes and max(sizes) <= 0.03 + 1e-12 and min(sizes) >= 0.010
    assert {e.tag_id: e.size for e in env.base_env.tag_observers[0].catalogue} == {t.tag_id: t.size for t in env.base_env.worlds[0].tags}
    env.close()
    # a world takes a layout's name too; True is the default layout
    one_per_face, default = MujocoWorld(TWO_IN_VIEW, tags="fitted"), MujocoWorld(TWO_IN_VIEW, tags=True)
    assert [t.along for t in one_per_face.tags] == [0.0] * len(one_per_face.tags)
    assert len(default.tags) > len(one_per_face.tags)  # pairs on the 5 cm faces
    one_per_face.close()
    default.close()


def test_tag_cards_change_neither_physics_nor_geometric_visibility():
    s = task_scenes(2, [10_000_003], (1, 10))[0]
    plain, tagged = (
        MujocoWorld(s, noise=0.2, rng=np.random.default_rng(4)),
        MujocoWorld(s, noise=0.2, rng=np.random.default_rng(4), tags=True),
    )
    assert len(tagged.tags) > 0 and len(plain.tags) == 0
    for action in ([1.0, 0.2, 0.1, -1.0], [0.6, -0.5, -0.4, -1.0], [0.8, 0.0, 0.0, 1.0]):
        plain.step(action)
        tagged.step(action)
        for a, b in zip(plain.state()[:3], tagged.state()[:3]):
            assert np.array_equal(a, b)  # bit for bit
        assert np.array_equal(plain.visible_fractions("rays"), tagged.visible_fractions("rays"))
    render = MujocoWorld(s, visibility="render", tags=True)
    assert np.array_equal(render.visible_fractions("render"), MujocoWorld(s, visibility="render").visible_fractions("render"))


@pytest.mark.parametrize("layout", ["fitted", "pairs"])
def test_decoded_tags_are_where_the_catalogue_puts_them(layout):
    """Each decoded tag's corners in the rendered image lie within 1.5 pixels of the catalogue's
    corners projected through the camera model: texture, orientation, placement (off the face's
    centre too, for pairs) and calibration agree."""
    import cv2

    world = MujocoWorld(TWO_IN_VIEW, tags=TAG_LAYOUTS[layout], object_height=0.15)
    observer = TagObserver(world)
    catalogue, camera = tag_catalogue(world), observer.calibration
    tags = observer.detector.detect_tags(observer.image())
    assert {catalogue[t["tag_id"]].type_id for t in tags} == {1, 2}  # both objects show a tag
    if layout == "pairs":
        assert {catalogue[t["tag_id"]].offset[0] > 0 for t in tags} == {True, False}  # both tags of a pair
    shelf_camera = world.gripper_transform() @ camera.hand_camera
    for t in tags:
        entry = catalogue[t["tag_id"]]
        o = world.scene.objects[entry.type_id - 1]
        shelf_object = np.eye(4)
        c, s = math.cos(o.pose[2]), math.sin(o.pose[2])
        shelf_object[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        shelf_object[:3, 3] = (o.pose[0], o.pose[1], 0.0)
        corners = (np.linalg.inv(shelf_camera) @ shelf_object @ np.c_[entry.corners_in_object, np.ones(4)].T)[:3].T
        projected, _ = cv2.projectPoints(corners, np.zeros(3), np.zeros(3), camera.intrinsic_matrix, camera.distortion_array)
        assert np.abs(projected.reshape(4, 2) - t["corners"]).max() < 1.5, (t["tag_id"], projected.reshape(4, 2), t["corners"])


def test_tag_perception_reports_what_the_detector_decodes_and_only_that():
    env = make_env(
        batch_size=1, scenes=[TWO_IN_VIEW], seed=[0], world="mujoco", perception="tags", object_height=0.15, heatmap_target=False
    )
    td = env.reset()
    observer = env.base_env.tag_observers[0]
    decoded = observer.detections(observer.image())  # the same frame again (no noise: rendering is deterministic)
    assert [d["type_id"] for d in decoded] == [1, 2]
    expected = DetectionSlots().observation(
        observer.world.gripper_pose(), observer.world.opening, decoded, 2, np.array(TWO_IN_VIEW.objects[1].vertices)
    )
    assert (td["objects"] == expected["objects"]).all()
    for k, d in enumerate(decoded):  # positions within a centimetre (pose errors: benchmarks/mujoco_tags.py)
        true = TWO_IN_VIEW.objects[d["type_id"] - 1].pose
        pose = td["objects", "pose"][0, k].double().tolist()
        assert math.hypot(pose[0] - true[0], pose[1] - true[1]) < 0.01
    # a wholly hidden target's tags are not decoded: not seen, as on a robot
    td = make_env(
        batch_size=1, scenes=[HIDDEN], seed=[0], world="mujoco", perception="tags", object_height=0.15, heatmap_target=False
    ).reset()
    assert td["objects", "type_id"][0][td["objects", "detected"][0]].tolist() == [HIDDEN.objects[0].type_id]


def test_tag_path_keeps_the_geometric_privileged_entries_and_specs():
    seeds = [10_000_003]
    scenes = task_scenes(2, seeds, (1, 10))
    tags = seeded_task_env(lambda td: td, scenes, seeds, world="mujoco", perception="tags")
    plain = seeded_task_env(lambda td: td, scenes, seeds, world="mujoco")
    a, b = tags.reset(), plain.reset()
    assert tags.observation_spec == plain.observation_spec
    assert (a["privileged"] == b["privileged"]).all()
    assert torch.equal(a["gripper_pose"], b["gripper_pose"]) and torch.equal(a["target_vertices"], b["target_vertices"])


def test_lighting_and_image_noise_are_seeded():
    s = task_scenes(2, [10_000_001], (1, 10))[0]

    def image(seed, **settings):
        world = MujocoWorld(s, tags=True)
        return WristCamera(world, WristCameraSettings(**settings), np.random.default_rng(seed)).rgb()

    nominal = image(0)
    assert np.array_equal(nominal, image(1))  # nothing random by default
    noisy = image(0, lighting=0.5, image_noise=4.0)
    assert np.array_equal(noisy, image(0, lighting=0.5, image_noise=4.0))
    assert not np.array_equal(noisy, image(1, lighting=0.5, image_noise=4.0))
    assert 1.0 < np.abs(noisy.astype(float) - nominal).mean() < 60.0
    # through the env: the images' stream is spawned from the task seed, the physics stream untouched
    runs = [
        make_env(
            batch_size=1,
            scenes=[s],
            seed=[seed],
            world="mujoco",
            perception="tags",
            wrist_camera=WristCameraSettings(lighting=0.5, image_noise=4.0),
        )
        for seed in (3, 3)
    ]
    a, b = (env.rollout(2, lambda td: td.set("action", torch.tensor([[1.0, 0.0, 0.0, -1.0]]))) for env in runs)
    assert (a == b).all()


def test_a_frames_noise_follows_the_world_state_alone():
    # two cameras on two copies of one world: one renders its frames more often than the other
    s = task_scenes(2, [10_000_001], (1, 10))[0]
    worlds = [MujocoWorld(s, tags=True) for _ in range(2)]
    cameras = [WristCamera(w, WristCameraSettings(image_noise=4.0), np.random.default_rng(5)) for w in worlds]
    first = cameras[0].rgb()
    assert np.array_equal(first, cameras[0].rgb())  # the same frame again: the same noise
    for _ in range(3):
        cameras[1].rgb()
    for w in worlds:
        w.step(np.array([1.0, 0.0, 0.0, -1.0]))
    a, b = (c.rgb() for c in cameras)
    assert np.array_equal(a, b) and not np.array_equal(a, first)
    for c in cameras:
        c.close()


def test_bad_perception_settings_are_refused():
    with pytest.raises(ValueError, match="perception must be one of"):
        MujocoShelfEnv(perception="lidar")
    with pytest.raises(ValueError, match="needs world='mujoco'"):
        make_env(perception="tags")
    with pytest.raises(ValueError, match="give it with perception='tags'"):
        MujocoShelfEnv(wrist_camera=WristCameraSettings())
    with pytest.raises(ValueError, match="one vertical field of view"):
        MujocoShelfEnv(perception="tags", wrist_camera=WristCameraSettings(width=640, height=360))
    with pytest.raises(ValueError, match="image_noise must be in"):
        WristCameraSettings(image_noise=-1.0)
    with pytest.raises(ValueError, match="width must be an int"):
        WristCameraSettings(width=640.0)
    with pytest.raises(ValueError, match="carries no tags"):
        tag_catalogue(MujocoWorld(HIDDEN))


def test_detection_slots_keep_each_type_in_its_slot_and_recycle_the_oldest():
    box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
    slots = DetectionSlots(num_slots=3)

    def types(*ids):
        dets = [{"type_id": t, "pose": (0.05 * t, 0.2, 0.0), "vertices": box} for t in ids]
        td = slots.observation((0.0, -0.1, 0.0), 0.085, dets, 1, np.array(box))
        assert torch.equal(td["objects", "detected"][0], td["objects", "type_id"][0] > 0)
        assert not td["objects", "type_id"][0, 3:].any()  # only the 3 slots given
        return td["objects", "type_id"][0, :3].tolist()

    assert types(4, 5, 6) == [4, 5, 6]
    assert types(5) == [0, 5, 0]
    assert types(7, 5) == [7, 5, 0]  # 4 and 6 were seen alike long ago: the lower slot goes first
    assert types(6, 8) == [8, 0, 6]  # 6 kept its slot; 8 takes 7's (7 and 5 were last seen together: the lower slot)
    slots.reset()
    assert types(8) == [8, 0, 0]
    with pytest.raises(ValueError, match="num_slots must be"):
        DetectionSlots(num_slots=11)


def test_occrl_eval_passes_perception_through(tmp_path, capsys):
    import json

    from occrl.cli import main

    assert main(["eval", "--method", "scripted", "--perception", "tags", "--tasks", "1"]) == 2
    assert "--perception tags needs --world mujoco" in capsys.readouterr().err
    out = tmp_path / "tags.json"
    args = ["eval", "--method", "scripted", "--world", "mujoco", "--perception", "tags", "--objects", "1", "--tasks", "1", "--no-progress"]
    assert main([*args, "--out", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["perception"] == "tags" and result["success_rate"] == 1.0  # the privileged script reaches its target
    assert result["tag_layout"] == DEFAULT_TAG_LAYOUT == "pairs"  # recorded when left to the default
    assert main([*args, "--tag-layout", "at-most-3cm", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["tag_layout"] == "at-most-3cm"
    assert main([*args[:5], "--tag-layout", "at-most-3cm", "--tasks", "1"]) == 2  # no --perception tags
    assert "--tag-layout sizes the tags" in capsys.readouterr().err
    # run_tasks hands it to run_episodes, which builds the tag env
    from occrl.baselines import ScriptedRetriever
    from occrl.envs.episodes import run_episodes

    built = []
    run_episodes(
        ScriptedRetriever(), task_scenes(2, [5], 1), [5], world="mujoco", perception="tags", on_env=lambda env: built.append(env.base_env)
    )
    assert [env.perception for env in built] == ["tags"] and len(built[0].tag_observers) == 1
    assert built[0].tag_layout == TAG_LAYOUTS["pairs"]
