import numpy as np
import pytest
import torch

from occrl.envs import make_env
from occrl.modules import make_occnet
from occrl.planners import HybridPlanner, generate_states, heatmap_peaks, recreate, rhp_batched, rhp_sequential, select_root
from occrl.planners.recreate import target_fits
from tests.helpers import scene


@pytest.fixture(scope="module")
def net():
    torch.manual_seed(0)
    return make_occnet("paper").eval()


def _env(net, s, **kw):
    return make_env(batch_size=1, scenes=[s], heatmap_target=False, **kw).append_transform(net.make_primer())


def test_raising_a_roots_weight_never_lowers_the_chance_its_action_wins():
    rng = np.random.default_rng(0)
    for _ in range(2000):
        n = rng.integers(1, 5)
        w = rng.dirichlet(np.ones(n))
        r = -rng.uniform(1, 60, n)
        i = rng.integers(n)
        before = select_root(w, r) == i
        w2 = w.copy()
        w2[i] *= rng.uniform(1.0, 5.0)
        w2 /= w2.sum()
        after = select_root(w2, r) == i
        assert after or not before
    # a likelier root wins when returns tie; with equal weights the better return wins
    assert select_root(np.array([0.2, 0.8]), np.array([-5.0, -5.0])) == 1
    assert select_root(np.array([0.5, 0.5]), np.array([-9.0, -4.0])) == 1


def test_batched_rhp_chooses_like_the_sequential_reference(net):
    s = scene([(0.0, 0.15, 0.0, True), (0.1, 0.2, 0.3, False), (-0.1, 0.25, 0.0, False)])
    td = _env(net, s).reset()
    state = recreate(td[0])
    hidden = (td["recurrent_state_h"], td["recurrent_state_c"])
    for seed in range(3):
        noise = torch.randn(2, 3, 3, 4, generator=torch.Generator().manual_seed(seed))
        a = rhp_batched(net, [state, state], hidden, noise)
        b = rhp_sequential(net, [state, state], hidden, noise)
        assert np.array_equal(a.returns.argmax(1), b.returns.argmax(1))
        np.testing.assert_allclose(a.action, b.action, atol=1e-5)
        np.testing.assert_allclose(a.returns, b.returns, atol=1e-4)
        assert a.steps == b.steps
        # both record the same gripper paths; every roll-out starts at the root's gripper pose
        assert a.paths.shape == (2, 3, 4, 3)
        np.testing.assert_allclose(a.paths, b.paths, atol=1e-6)
        assert np.isfinite(a.paths[:, :, :2]).all()  # one step at least before any roll-out can end
        np.testing.assert_allclose(a.paths[:, :, 0], np.broadcast_to(state.gripper_pose, (2, 3, 3)), atol=1e-9)


def test_planner_never_reads_privileged_entries(net):
    s = scene([(0.0, 0.1, 0.0, False), (0.02, 0.28, 0.0, True), (-0.12, 0.2, 0.5, False)])
    env = _env(net, s)
    td = env.reset()
    stripped = td.exclude("privileged")
    a = HybridPlanner(net, m=2, h=2, seed=4)(td.clone())["action"]
    b = HybridPlanner(net, m=2, h=2, seed=4)(stripped.clone())["action"]
    assert torch.equal(a, b)


def test_one_root_when_the_target_is_detected(net):
    s = scene([(0.0, 0.15, 0.0, True)])
    td = _env(net, s).reset()
    state = recreate(td[0])
    assert state.target_detected
    roots = generate_states(np.random.default_rng(0).random((64, 64)), state)
    assert len(roots) == 1 and roots[0].weight == 1.0


def test_heatmap_peaks_become_weighted_roots_at_free_places(net):
    s = scene([(0.0, 0.1, 0.0, False), (0.0, 0.28, 0.0, True)])  # target hidden behind the box
    td = _env(net, s).reset()
    state = recreate(td[0])
    assert not state.target_detected
    from occrl.envs.robot_frame import robot_centric_pixels

    heat = np.zeros((64, 64))
    spots = [(0.0, 0.28), (0.15, 0.3)]
    masses = [2.0, 1.0]
    for (x, y), mass in zip(spots, masses):
        c, r = robot_centric_pixels(np.array([[[x, y]]]), np.array([state.gripper_pose]))[0, 0]
        rows, cols = np.mgrid[:64, :64]
        heat += mass * np.exp(-((rows - r) ** 2 + (cols - c) ** 2) / 4.0)
    peaks = heatmap_peaks(heat)
    assert len(peaks) == 2
    roots = generate_states(heat, state)
    assert len(roots) == 2
    assert roots[0].weight == pytest.approx(2 / 3, abs=0.05) and sum(r.weight for r in roots) == pytest.approx(1.0)
    for root, (x, y) in zip(roots, spots):
        assert np.hypot(root.target_pose[0] - x, root.target_pose[1] - y) < 0.02
        assert target_fits(state, root.target_pose)
        assert root.state.target_detected  # the hypothesised target is in the root state


def test_hybrid_planner_runs_in_rollout_and_is_reproducible(net):
    s = scene([(0.0, 0.15, 0.0, True), (0.1, 0.25, 0.3, False)])
    a = _env(net, s).rollout(3, HybridPlanner(net, m=2, h=2, seed=1))
    b = _env(net, s).rollout(3, HybridPlanner(net, m=2, h=2, seed=1))
    assert torch.equal(a["action"], b["action"])
    assert ("next", "recurrent_state_h") in a.keys(True)


def test_planner_rejects_a_net_without_heatmap():
    with pytest.raises(ValueError, match="heat-map head"):
        HybridPlanner(make_occnet("paper", heatmap=False))


def test_closed_fingers_on_an_unseen_object_hold_the_target_in_the_recreated_world():
    """Held against the camera the target is often not detected; the gripper's opening says the
    fingers stopped on something, so the recreated world holds the target between them."""
    from occrl.envs import observation_from_detections
    from occrl.planners import make_world

    rect = np.array([[-0.015, -0.03], [0.015, -0.03], [0.015, 0.03], [-0.015, 0.03]])  # 3 cm x 6 cm
    obs = observation_from_detections((0.05, 0.1, 0.4), 0.06, [], target_type=1, target_vertices=rect, gripper_closed=True)
    state = recreate(obs[0])
    assert state.target_detected and len(state.objects) == 1
    world = make_world(state)
    assert world.held == 0  # grasped in the recreated world
    # turned so that its 6 cm side spans the 6 cm opening
    local = world.object_world_polygons()[0] - np.array(state.gripper_pose[:2])
    c, s = np.cos(-0.4), np.sin(-0.4)
    across = local @ np.array([[c, s], [-s, c]])
    assert abs(np.ptp(across[:, 0]) - 0.06) < 2e-3
    # nothing inferred when the fingers closed on nothing, are open, or the target is seen elsewhere
    for opening, closed, dets in (
        (0.0, True, []),
        (0.085, False, []),
        (0.06, True, [{"type_id": 1, "pose": (-0.1, 0.2, 0.0), "vertices": rect}]),
    ):
        obs = observation_from_detections((0.05, 0.1, 0.4), opening, dets, target_type=1, target_vertices=rect, gripper_closed=closed)
        assert len(recreate(obs[0]).objects) == len(dets)


def test_the_rollouts_first_actions_are_the_policys_samples_in_both_implementations(net):
    from occrl.planners.rhp import NetworkStepper, render_pixels
    from occrl.planners.recreate import make_world

    s = scene([(0.0, 0.15, 0.0, True), (0.1, 0.2, 0.3, False)])
    td = _env(net, s).reset()
    state = recreate(td[0])
    hidden = (td["recurrent_state_h"], td["recurrent_state_c"])
    noise = torch.randn(1, 3, 2, 4, generator=torch.Generator().manual_seed(1))
    out, _, _ = NetworkStepper(net).step(render_pixels([make_world(state)]), *hidden)
    loc, scale = out["loc"][0], out["scale"][0]
    for rhp in (rhp_batched, rhp_sequential):
        own = rhp(net, [state], hidden, noise)
        np.testing.assert_allclose(own.first_actions[0], (loc + scale * noise[0, :, 0]).clamp(-1, 1).numpy(), atol=1e-5)


def test_planning_several_worlds_together_decides_as_one_world_at_a_time():
    """batch_worlds / decide_many (a batch of worlds: one RHP over all their roots) draws each world's noise as
    deciding them one by one does, and chooses the same actions up to the larger batches' float
    rounding; each world's result and step count is its own."""
    from torchrl.envs.utils import step_mdp

    from occrl.pretrained import load_pretrained

    net = load_pretrained("occnet")
    env = make_env(batch_size=4, stage=2, seed=11, heatmap_target=False).append_transform(net.make_primer())
    td = env.reset()
    together, alone = HybridPlanner(net, seed=5, batch_worlds=True), HybridPlanner(net, seed=5)
    for _ in range(3):
        a = together(td.clone())["action"]
        b = torch.stack([alone(td[i : i + 1].clone())["action"][0] for i in range(4)])
        torch.testing.assert_close(a, b, atol=1e-5, rtol=0)
        for x, y in zip(together.decisions[-4:], alone.decisions[-4:]):
            assert len(x.roots) == len(y.roots) and x.chosen_root == y.chosen_root and x.result.steps == y.result.steps
            np.testing.assert_allclose(x.result.returns, y.result.returns, atol=1e-3)
        td = step_mdp(env.step(td.set("action", a)))
    assert sum(len(d.roots) for d in together.decisions[-4:]) > 4  # a hidden target: several roots somewhere
    with pytest.raises(ValueError, match="one LSTM state or one per root"):
        rhp_batched(
            net, [together.decisions[-1].roots[0].state] * 2, (torch.zeros(3, 1, 128), torch.zeros(3, 1, 128)), torch.randn(2, 1, 1, 4)
        )


def _known_polygons(state):
    from occrl.envs.geometry import transform_points
    from occrl.envs.shelf_geometry import gripper_polygons

    return state.polygons() + [transform_points(p, state.gripper_pose) for p in gripper_polygons(state.opening)]


def _fits_by_the_full_test(state, others, pose) -> bool:
    """The target at ``pose`` lies on the shelf and overlaps none of ``others`` (polygons_overlap
    against every one of them, no pre-test)."""
    from occrl.envs.geometry import polygons_overlap, transform_points
    from occrl.envs.world_constants import SHELF_DEPTH, SHELF_HALF_WIDTH

    poly = transform_points(state.target_vertices, pose)
    lo, hi = poly.min(0), poly.max(0)
    inside = lo[0] >= -SHELF_HALF_WIDTH and hi[0] <= SHELF_HALF_WIDTH and lo[1] >= 0.0 and hi[1] <= SHELF_DEPTH
    return bool(inside and not any(polygons_overlap(poly, o) for o in others))


def test_target_fits_skips_only_polygons_whose_boxes_are_apart():
    # the box pre-test changes no answer of the separating-axis test over every known polygon
    from occrl.envs.world_constants import SHELF_DEPTH, SHELF_HALF_WIDTH

    env = make_env(batch_size=4, stage=2, seed=3, heatmap_target=False)
    rng = np.random.default_rng(0)
    answers = []
    for b in range(4):
        state = recreate(env.reset()[b])
        others = _known_polygons(state)
        for pose in rng.uniform([-SHELF_HALF_WIDTH, 0.0, -np.pi], [SHELF_HALF_WIDTH, SHELF_DEPTH, np.pi], (150, 3)):
            full = _fits_by_the_full_test(state, others, pose)
            answers.append(full)
            assert target_fits(state, pose) == full
    assert any(answers) and not all(answers)


def test_first_fitting_pose_is_the_first_pose_the_full_test_lets_fit():
    # the separating-axis test of every pose and obstacle at once gives the answer of trying the
    # poses one by one with polygons_overlap against every known polygon
    from occrl.planners.recreate import first_fitting_pose

    env = make_env(batch_size=4, stage=3, seed=5, heatmap_target=False)
    rng = np.random.default_rng(1)
    found = []
    for b in range(4):
        state = recreate(env.reset()[b])
        others = _known_polygons(state)
        centres = np.array([o.mean(0) for o in others])
        for _ in range(40):  # poses crowded around the known objects, most of them overlapping one
            near = centres[rng.integers(len(centres), size=12)] + rng.normal(0.0, 0.04, (12, 2))
            poses = np.c_[near, rng.uniform(-np.pi, np.pi, 12)]
            fits = [_fits_by_the_full_test(state, others, pose) for pose in poses]
            expected = fits.index(True) if any(fits) else None
            assert first_fitting_pose(state, poses) == expected
            found.append(expected)
    assert None in found and 0 in found and any(k not in (None, 0) for k in found)


def test_heatmap_peaks_sum_the_same_disks_as_the_whole_map_grid():
    """heatmap_peaks works in a window around each peak: the same peaks and masses, bit for bit,
    as the disk tested on the whole map's pixel grid (float and negative radii included)."""

    def whole_grid(heat, max_peaks, radius, rel_threshold):
        h = heat.copy()
        top = h.max()
        rows, cols = np.mgrid[: h.shape[0], : h.shape[1]]
        peaks = []
        for _ in range(max_peaks):
            r, c = np.unravel_index(int(h.argmax()), h.shape)
            if h[r, c] < rel_threshold * top:
                break
            disk = (rows - r) ** 2 + (cols - c) ** 2 <= radius**2
            peaks.append((int(r), int(c), float(h[disk].sum())))
            h[disk] = 0.0
        return peaks

    rng = np.random.default_rng(0)
    for i in range(300):
        heat = rng.random((int(rng.integers(5, 70)), int(rng.integers(5, 70)))) ** 8
        radius = [6, 2, 0, 3.5, 2.9, 10, 100, -1, -2.5, 1][i % 10]
        threshold = [0.2, 0.0, 0.5][i % 3]
        assert heatmap_peaks(heat, 9, radius, threshold) == whole_grid(heat, 9, radius, threshold)
