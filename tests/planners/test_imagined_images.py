"""One observation pipeline: the image a planner imagines for the state it
recreates from an observation is the env's image of that observation, pixel for pixel."""

import numpy as np
import pytest
import torch
from torchrl.envs.utils import step_mdp

from occrl.baselines.scripted import ScriptedRetriever
from occrl.envs import make_env
from occrl.envs.observation import world_pixels, world_visible_fractions
from occrl.planners import make_world, recreate, render_pixels


def _visited_observations(stage: int, noise: float, seed: int, steps: int, reset_done: bool):
    """Observations of 8 seeded worlds driven by the scripted retriever with random kicks (so
    states include pushes, misses and grasps); without ``reset_done`` finished worlds go on
    stepping, which visits states with the target held outside the shelf."""
    env = make_env(batch_size=8, stage=stage, noise=noise, seed=seed, heatmap_target=False)
    policy = ScriptedRetriever()
    g = torch.Generator().manual_seed(seed)
    td = env.reset()
    for t in range(steps):
        yield td
        td = policy(td)
        if t % 3 == 0:
            td["action"] = (td["action"] + 0.5 * torch.randn(td["action"].shape, generator=g)).clamp(-1, 1)
        td = step_mdp(env.step(td))
        if reset_done and td["done"].any():
            td = env.reset(td)


@pytest.mark.integration
@pytest.mark.parametrize(
    "stage,noise,seed,reset_done",
    [(2, 0.0, 0, False), (2, 0.15, 1, True), (3, 0.0, 2, True)],
)
def test_recreated_state_renders_the_observed_image(stage, noise, seed, reset_done):
    states = unseen_in_hand = 0
    for td in _visited_observations(stage, noise, seed, steps=30, reset_done=reset_done):
        for i in range(td.shape[0]):
            state = recreate(td[i])
            imagined = render_pixels([make_world(state)])[0]
            different = int((imagined != td["pixels"][i]).any(0).sum())
            assert different == 0, f"step state {states}: {different} pixels differ (target unseen in hand: {state.target_unseen_in_hand})"
            states += 1
            unseen_in_hand += state.target_unseen_in_hand
    assert states == 240
    if not reset_done:  # the case that used to differ was visited
        assert unseen_in_hand > 0


def test_world_pixels_is_the_env_pipeline_on_the_env_worlds():
    env = make_env(batch_size=4, stage=2, seed=3, heatmap_target=False)
    td = env.reset()
    assert torch.equal(world_pixels(env.base_env.worlds), td["pixels"])
    td = step_mdp(env.step(td.set("action", torch.rand(4, 4) * 2 - 1)))
    assert torch.equal(world_pixels(env.base_env.worlds), td["pixels"])


def test_a_target_unseen_in_hand_is_transparent_to_the_imagined_camera():
    # a closed gripper stopped 3 cm apart with nothing detected between its fingers holds the
    # target unseen: the recreated world keeps it there without it being seen or hiding anything
    from occrl.envs import observation_from_detections

    box = np.array([[-0.015, -0.015], [0.015, -0.015], [0.015, 0.015], [-0.015, 0.015]])
    behind = {"type_id": 2, "pose": (0.0, 0.25, 0.0), "vertices": box}
    obs = observation_from_detections((0.0, 0.0, 0.0), 0.03, [behind], target_type=1, target_vertices=box, gripper_closed=True)
    state = recreate(obs[0])
    assert state.target_unseen_in_hand and state.target_detected
    world = make_world(state)
    assert world.held == world.target_index == world.unseen_while_held
    fractions = world_visible_fractions(world)
    assert fractions[world.target_index] == 0.0 and fractions[0] > 0.5  # the object behind stays seen
    world.unseen_while_held = None  # as an ordinary object the guessed target hides what is behind it
    assert world_visible_fractions(world)[0] < fractions[0]


def test_network_stepper_equals_the_tensordict_modules_bit_for_bit():
    from tensordict import TensorDict

    from occrl.modules import make_occnet
    from occrl.planners.rhp import NetworkStepper

    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    for p in net.parameters():  # away from the initialisation, as a trained net is
        p.data.add_(0.05 * torch.randn_like(p))
    stepper = NetworkStepper(net)
    for n in (1, 4, 12):
        pixels = torch.rand(n, 3, 64, 64)
        h, c = torch.randn(n, 1, 128), torch.randn(n, 1, 128)
        out, h_next, c_next = stepper.step(pixels, h, c)
        td = TensorDict(
            {"pixels": pixels, "recurrent_state_h": h, "recurrent_state_c": c, "is_init": torch.zeros(n, 1, dtype=torch.bool)}, [n]
        )
        with torch.no_grad():
            td = net.actor.module[0](net.trunk(td))
            value = net.critic(td.select("belief").copy()).get("state_value").squeeze(-1)
        for key in ("belief", "loc", "scale"):
            assert torch.equal(out[key], td.get(key)), key
        assert torch.equal(h_next, td.get(("next", "recurrent_state_h")))
        assert torch.equal(c_next, td.get(("next", "recurrent_state_c")))
        assert torch.equal(stepper.value(out), value)


def test_world_pool_worlds_step_as_newly_built_ones_bit_for_bit():
    import copy

    from occrl.planners import WorldPool

    rng = np.random.default_rng(0)
    pool = WorldPool()
    states = [recreate(td[i]) for td in _visited_observations(2, 0.0, 4, steps=12, reset_done=False) for i in range(0, 8, 2)]
    reused = 0
    for state in states:
        (kept,) = pool.take([state])
        for _ in range(2):  # dirty the kept world, as a roll-out does
            kept.step(rng.uniform(-1, 1, 4))
        (world,) = pool.take([state])
        reused += world is kept
        fresh = make_world(state)
        assert world.unseen_while_held == fresh.unseen_while_held and world.held == fresh.held
        for _ in range(3):
            action = rng.uniform(-1, 1, 4)
            assert world.step(action) == fresh.step(action)
            assert np.array_equal(world.object_poses(), fresh.object_poses())
            assert np.array_equal(world.gripper_pose(), fresh.gripper_pose()) and world.opening == fresh.opening
    assert reused == len(states)  # the same objects: the kept world was handed out again
    assert copy.deepcopy(pool).take([states[0]])[0] is not world  # copies start empty


@pytest.mark.integration
def test_world_pool_worlds_that_take_other_objects_step_as_newly_built_ones_bit_for_bit():
    from collections import defaultdict

    from occrl.planners import WorldPool
    from occrl.planners.recreate import _object_set

    rng = np.random.default_rng(1)
    by_count = defaultdict(list)  # recreated states of stages 1-3, held targets and grasps included
    for stage, seed in ((1, 3), (2, 4), (3, 5)):
        for td in _visited_observations(stage, 0.0, seed, 15, reset_done=True):
            for i in range(8):
                state = recreate(td[i])
                by_count[len(state.objects)].append(state)
    pairs = 0
    for states in by_count.values():
        for before, after in zip(states, states[1:]):
            if _object_set(before) == _object_set(after):
                continue  # the same objects: set_poses, tested above
            pool = WorldPool()
            (kept,) = pool.take([before])
            for _ in range(2):  # dirty the kept world, as a roll-out does (contacts, a grasp, the fingers)
                kept.step(rng.uniform(-1, 1, 4))
            (world,) = pool.take([after])
            assert world is kept and pool.rebuilt == 1 and pool.built == 1
            fresh = make_world(after)
            assert world.unseen_while_held == fresh.unseen_while_held and world.held == fresh.held
            assert world.target_index == fresh.target_index and np.array_equal(world.padded_vertices, fresh.padded_vertices)
            for _ in range(3):
                action = rng.uniform(-1, 1, 4)
                assert world.step(action) == fresh.step(action)
                assert np.array_equal(world.object_poses(), fresh.object_poses())
                assert np.array_equal(world.gripper_pose(), fresh.gripper_pose()) and world.opening == fresh.opening
            assert np.array_equal(world_pixels([world]), world_pixels([fresh]))
            pairs += 1
    assert pairs >= 100


def test_world_pool_keeps_no_trace_of_object_sets_without_idle_worlds():
    from occrl.planners import WorldPool

    pool = WorldPool(max_kept=4)
    states = [recreate(td[i]) for td in _visited_observations(2, 0.0, 6, steps=6, reset_done=False) for i in range(8)]
    for state in states:
        pool.take([state, state])
    idle = pool._idle  # the pool's own bookkeeping: every kept object set holds an idle world
    assert all(idle.values()) and sum(len(v) for v in idle.values()) <= 4
    assert pool.built + pool.rebuilt <= 2 * len(states) and pool.rebuilt > 0


def test_rebuild_refuses_another_object_count_or_noise_and_leaves_the_world():
    from occrl.envs import Scene, ShelfWorld

    world = ShelfWorld(Scene.sample(2, seed=0))
    poses = world.object_poses()
    with pytest.raises(ValueError, match=f"rebuild needs a scene of {world.num_objects} objects"):
        world.rebuild(Scene.sample(1, seed=0, num_objects=1))
    noisy = ShelfWorld(Scene.sample(2, seed=0), noise=0.1)
    with pytest.raises(ValueError, match="noise-free worlds"):
        noisy.rebuild(Scene.sample(2, seed=0))
    assert np.array_equal(world.object_poses(), poses)


def test_hybrid_planner_chooses_alike_with_and_without_kept_worlds():
    from occrl.planners import HybridPlanner
    from occrl.planners.rhp import rhp_batched
    from occrl.pretrained import load_pretrained

    net = load_pretrained("occnet")
    planner = HybridPlanner(net, m=2, h=2, seed=0)
    env = make_env(batch_size=1, stage=2, seed=5, heatmap_target=False).append_transform(net.make_primer())
    td = env.rollout(6, planner)  # the pool is used across these decisions
    assert planner.pool.built < 6 * 2
    for d in planner.decisions:
        roots = [r.state for r in d.roots]
        noise = torch.zeros(len(roots), 2, 2, 4)
        hidden = (torch.zeros(1, 1, 128), torch.zeros(1, 1, 128))
        with_pool = rhp_batched(net, roots, hidden, noise, pool=planner.pool)
        without = rhp_batched(net, roots, hidden, noise)
        assert np.array_equal(with_pool.returns, without.returns) and np.array_equal(with_pool.action, without.action)
    assert td.shape == (1, 6)


def test_onnxruntime_stepper_agrees_with_torch_to_float_rounding():
    pytest.importorskip("onnxruntime")
    import copy

    from occrl.planners import HybridPlanner
    from occrl.planners.rhp import NetworkStepper
    from occrl.pretrained import load_pretrained

    net = load_pretrained("occnet")
    eager, onnx = NetworkStepper(net), NetworkStepper(net, backend="onnxruntime")
    for n in (1, 4, 12):
        g = torch.Generator().manual_seed(n)
        pixels, h, c = torch.rand(n, 3, 64, 64, generator=g), torch.randn(n, 1, 128, generator=g), torch.randn(n, 1, 128, generator=g)
        (a, ha, ca), (b, hb, cb) = eager.step(pixels, h, c), onnx.step(pixels, h, c)
        for key in ("belief", "loc", "scale"):
            torch.testing.assert_close(a[key], b[key], atol=1e-4, rtol=1e-4)
        torch.testing.assert_close(ha, hb, atol=1e-4, rtol=1e-4)
        torch.testing.assert_close(ca, cb, atol=1e-4, rtol=1e-4)
        torch.testing.assert_close(eager.value(a), onnx.value(b), atol=1e-3, rtol=1e-4)
    planner = HybridPlanner(net, m=2, h=2, inference="onnxruntime")
    env = make_env(batch_size=1, stage=1, seed=0, heatmap_target=False).append_transform(net.make_primer())
    assert env.rollout(3, planner)["action"].shape == (1, 3, 4)
    assert copy.deepcopy(planner).stepper.session is not None  # rebuilt on copy / in a worker
    with pytest.raises(ValueError, match="inference must be one of"):
        HybridPlanner(net, inference="tensorrt")


def test_onnxruntime_stepper_takes_up_changed_weights_on_sync():
    """Training changes the weights in place: the ONNX session runs the old ones until synced."""
    pytest.importorskip("onnxruntime")
    from occrl.modules import make_occnet
    from occrl.planners.rhp import NetworkStepper

    torch.manual_seed(0)
    net = make_occnet("paper").eval()
    stepper = NetworkStepper(net, backend="onnxruntime")
    g = torch.Generator().manual_seed(1)
    pixels, h = torch.rand(2, 3, 64, 64, generator=g), torch.zeros(2, 1, 128)
    before = stepper.step(pixels, h, h)[0]["loc"]
    with torch.no_grad():
        for param in net.actor.parameters():  # an "update"
            param.add_(0.05 * torch.randn(param.shape, generator=g))
    assert torch.equal(stepper.step(pixels, h, h)[0]["loc"], before)  # stale until synced
    stepper.sync_weights()
    after = NetworkStepper(net).step(pixels, h, h)[0]["loc"]
    assert (after - before).abs().max() > 1e-2
    torch.testing.assert_close(stepper.step(pixels, h, h)[0]["loc"], after, atol=1e-4, rtol=1e-4)


def test_hybrid_planner_advances_the_lstm_as_the_tensordict_modules_do():
    from occrl.planners import HybridPlanner
    from occrl.pretrained import load_pretrained

    net = load_pretrained("occnet")
    env = make_env(batch_size=2, stage=2, seed=7, heatmap_target=False).append_transform(net.make_primer())
    td = env.reset()
    td["recurrent_state_h"] = torch.randn(td["recurrent_state_h"].shape)  # a history, and one world starting afresh
    td["recurrent_state_c"] = torch.randn(td["recurrent_state_c"].shape)
    td["is_init"][1] = True
    with torch.no_grad():
        expected = net.heatmap(td.clone())
    out = HybridPlanner(net, m=1, h=1)(td.clone())
    assert torch.equal(out["heatmap"], expected["heatmap"])
    for key in (("next", "recurrent_state_h"), ("next", "recurrent_state_c")):
        assert torch.equal(out[key], expected[key])


def test_detected_polygons_without_slot_arrays_are_the_observations():
    """world_pixels reads the detections straight from the worlds (worlds_detected_polygons): the
    polygons and target flags the observation's slot arrays give, bit for bit, on env worlds and
    on recreated worlds (hypothesised and unseen held targets, no target at all). (Its padded
    copy for the renderer: the tests above, world_pixels against the env's pixels.)"""
    from occrl.envs.observation import detected_world_polygons, detection_arrays, worlds_detected_polygons, worlds_visible_fractions
    from occrl.planners import with_target

    checked = 0
    for td in _visited_observations(stage=3, noise=0.1, seed=11, steps=12, reset_done=False):
        states = [recreate(td[b]) for b in range(td.shape[0])]
        worlds = [make_world(s) for s in states] + [make_world(with_target(s, (0.0, 0.3, 0.4))) for s in states if not s.target_detected]
        fractions = worlds_visible_fractions(worlds)
        a = detection_arrays(worlds, fractions)
        slots = detected_world_polygons(a["detected"], a["type_id"], a["pose"], a["vertices"], a["num_vertices"], a["target_type"])
        for (ps, flags), (qs, direct_flags) in zip(slots, worlds_detected_polygons(worlds, fractions)):
            assert flags == direct_flags and len(ps) == len(qs)
            assert all(p.dtype == q.dtype and np.array_equal(p, q) for p, q in zip(ps, qs))
            checked += len(ps)
    assert checked > 100
