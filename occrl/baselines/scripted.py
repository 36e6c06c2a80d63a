"""A privileged scripted retriever: it reads the true state and goes straight for the target.

It is not a method of the paper. It proves that the physics allows retrieval, drives demos and
tests, and can provide demonstrations (imitation warm start). It reads ``"privileged"`` entries,
so it must never be used where only perception is allowed.

Strategy, re-planned every step from the true state (closed loop):

1. Plan a grasp: an approach angle within +-45 degrees and a lateral offset such that the target
   fits between the open fingers across the gripper axis, no part of the gripper hits a wall on the
   straight way in, and preferably no clutter lies in the corridor the fingers sweep (clutter
   there would be pushed into the target and end up between the fingers with it). Straight and
   centred grasps are preferred.
2. Line up on the approach line behind the grasp pose, then advance along it (pushing clutter
   outside the corridor aside) until the target sits between the fingers.
3. Close, then pull straight out of the shelf (-y) until the target is past the front edge.
   A grasp that missed is opened and tried again.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from occrl.envs import world_constants as C
from occrl.envs.geometry import convex_hull, polygons_overlap, transform_points, transform_polygons
from occrl.envs.shelf_geometry import SHELF_WALLS, gripper_polygons
from occrl.envs.pymunk2d.fingers import grasp_candidate

__all__ = ["ScriptedRetriever", "plan_grasp", "grasp_candidates", "way_out", "path_clear", "move_action", "fingertips_inside", "FIT_WIDTH"]

_APPROACH_ANGLES = np.radians(np.arange(-45.0, 45.1, 5.0))
FIT_WIDTH = C.GRIPPER_STROKE - 0.012  # the widest object the open fingers take with room to spare
_OFFSETS = np.arange(0.001, 0.0361, 0.001)
_LATERAL_OFFSETS = np.concatenate([[0.0], np.stack([_OFFSETS, -_OFFSETS], 1).ravel()])
_OPEN_GRIPPER = gripper_polygons(C.GRIPPER_STROKE)
_OUTSIDE_Y = -0.01  # fingertips behind this line are out of the shelf
_PLAN_RESOLUTION = np.array([0.004, 0.004, 0.05])  # target motion (m, m, rad) that triggers a re-plan


def _rot(v: np.ndarray, th: float) -> np.ndarray:
    c, s = math.cos(th), math.sin(th)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def move_action(heading: float, d_world: np.ndarray, dth: float, grip: float) -> np.ndarray:
    """The action (clipped to [-1, 1]) that moves a gripper at ``heading`` by ``d_world`` (shelf
    frame, m), turns it by ``dth`` (rad) and sets the gripper command ``grip``."""
    lat, fwd = _rot(d_world, -heading)
    return np.clip(np.array([fwd / C.MAX_FORWARD, lat / C.MAX_LATERAL, dth / C.MAX_ROTATION, grip]), -1.0, 1.0)


class ScriptedRetriever(TensorDictModuleBase):
    """Privileged scripted policy: reach, grasp and pull out the target, writing ``"action"``.

    Args:
        lateral_tolerance: how well (m) the gripper must be lined up before it advances onto the target.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.baselines import ScriptedRetriever
        >>> env = make_env(batch_size=1, stage=1, seed=3, heatmap_target=False)
        >>> td = env.rollout(50, policy=ScriptedRetriever())
        >>> bool(td["next", "success"].any())
        True
    """

    in_keys = ["gripper_pose", "gripper_opening", "gripper_closed", "privileged"]
    out_keys = ["action"]

    def __init__(self, lateral_tolerance: float = 0.006) -> None:
        super().__init__()
        if not 0.0 <= lateral_tolerance <= 0.05:
            raise ValueError(f"lateral_tolerance must be in [0, 0.05] m, got {lateral_tolerance!r}")
        self.lateral_tolerance = lateral_tolerance
        self._plans: dict[bytes, tuple[float, np.ndarray]] = {}  # grasp plans by target pose
        self._tried: dict[bytes, list[float]] = {}  # approach angles that ended with clutter in the way

    def reset(self) -> None:
        """Forget cached grasp plans (call between batches of episodes for exact repeatability)."""
        self._plans.clear()
        self._tried.clear()

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        flat = tensordict.reshape(-1)
        gp = flat.get("gripper_pose").cpu().numpy().astype(float)
        closed = flat.get("gripper_closed").cpu().numpy().reshape(-1)
        priv = flat.get("privileged")
        present = priv.get("object_present").cpu().numpy()
        poses = priv.get("object_pose").cpu().numpy().astype(float)
        world = transform_polygons(priv.get("object_vertices").cpu().numpy().astype(float), poses)
        nv = priv.get("object_num_vertices").cpu().numpy()
        slot = priv.get("target_slot").cpu().numpy().reshape(-1)
        held = priv.get("target_held").cpu().numpy().reshape(-1)
        actions = []
        for b in range(flat.shape[0]):
            idx = np.flatnonzero(present[b])
            target = world[b, slot[b], : nv[b, slot[b]]]
            clutter = [world[b, k, : nv[b, k]] for k in idx if k != slot[b]]
            key = (poses[b, slot[b]] / _PLAN_RESOLUTION).round().tobytes()  # re-plan when the target moved
            actions.append(self.act(gp[b], bool(closed[b]), bool(held[b]), target, clutter, key))
        action = torch.as_tensor(np.stack(actions), dtype=torch.float32).reshape(*tensordict.shape, C.ACTION_DIM)
        tensordict.set("action", action)
        return tensordict

    # ------------------------------------------------------------------ one world
    def grasp_plan(self, target: np.ndarray, clutter: list, heading: float, key: bytes | None = None) -> tuple[float, np.ndarray]:
        """:meth:`plan` for ``target``, cached under ``key`` (the target's quantised pose)."""
        plan = self._plans.get(key) if key is not None else None
        if plan is None:
            plan = self.plan(target, clutter, heading)
            if key is not None:
                if len(self._plans) > 4096:
                    self.reset()
                self._plans[key] = plan
        return plan

    def plan(self, target: np.ndarray, clutter: list, heading: float) -> tuple[float, np.ndarray]:
        """Approach angle and grasp position for the target: :func:`plan_grasp`."""
        return plan_grasp(target, clutter, prefer_angle=heading)

    def act(self, gripper_pose, closed: bool, held: bool, target: np.ndarray, clutter: list, key: bytes | None = None) -> np.ndarray:
        """The action for one world from the true target and clutter polygons (shelf frame)."""
        x, y, th = gripper_pose
        if held:  # back out the way it came in: that corridor is clear
            return np.array([-1.0, 0.0, 0.0, 1.0])
        if closed:  # a missed grasp: open first
            return np.array([0.0, 0.0, 0.0, -1.0])
        approach, grasp = self.grasp_plan(target, clutter, th, key)
        if grasp_candidate(gripper_pose, C.GRIPPER_STROKE, [target, *clutter])[0] == 0:
            return np.array([0.0, 0.0, 0.0, 1.0])  # the target alone is between the fingers: close
        e = _rot(np.array([x, y]) - grasp, -approach)  # gripper in the grasp frame: e[0] lateral, e[1] along
        dth = _wrap(approach - th)
        if abs(e[0]) < self.lateral_tolerance and abs(e[1]) < 0.005 and abs(dth) < math.radians(4) and key is not None:
            # in place, yet clutter shares the space between the fingers: try another approach
            tried = self._tried.setdefault(key, [])
            tried.append(approach)
            self._plans[key] = plan_grasp(target, clutter, prefer_angle=th, exclude=tried)
            approach, grasp = self._plans[key]
            e = _rot(np.array([x, y]) - grasp, -approach)
            dth = _wrap(approach - th)
        inside = fingertips_inside(gripper_pose)
        if abs(e[0]) < self.lateral_tolerance and abs(dth) < math.radians(3):
            # lined up: advance onto the target, slowly over the last centimetres
            step_g = np.array([-e[0], -e[1] if -e[1] > 0.06 else min(-e[1], 0.025)])
        elif inside and (abs(e[0]) > 0.01 or abs(dth) > math.radians(3)):
            # moving sideways or turning inside the shelf sweeps clutter: back out first
            return np.array([-1.0, 0.0, 0.0, -1.0])
        elif inside:
            step_g = np.array([-e[0], 0.0])  # a small sideways correction
        else:
            # line up outside the shelf, at the entry of the approach corridor
            entry = -way_out(grasp, approach)
            step_g = np.array([-e[0], entry - e[1]])
        return move_action(th, _rot(step_g, approach), dth, grip=-1.0)


def grasp_candidates(target: np.ndarray, clutter: list[np.ndarray] = (), prefer_angle: float = 0.0, exclude: list[float] = ()):
    """The grasps that fit a target polygon (shelf frame), one approach angle at a time.

    Angles are tried from ``prefer_angle`` outwards, skipping those within 10 degrees of the
    ``exclude``d ones; each yields ``(angle, grasps, band, lanes)``: the gripper positions (n, 2)
    whose open fingers take the target (centred first), and per clutter object and grasp
    (len(clutter), n) whether it reaches between the fingers (``band``) or in front of the
    fingers or between them (``lanes``) on the straight way in, from outside the shelf to the
    fingertips at the grasp. Clutter tests use each object's bounding box in the approach frame
    (conservative).
    """
    centre = target.mean(axis=0)
    h = C.GRIPPER_STROKE / 2
    slack = h - 0.002
    for a in _APPROACH_ANGLES[np.argsort(np.abs(_APPROACH_ANGLES - prefer_angle), kind="stable")]:
        a = float(a)
        if any(abs(a - b) < math.radians(10) for b in exclude):
            continue
        local = transform_points(target - centre, (0.0, 0.0, -a))
        xmin, xmax = local[:, 0].min(), local[:, 0].max()
        if xmax - xmin > FIT_WIDTH:
            continue
        grasp_y = min(max(-local[:, 1].min() + 0.004, 0.012), C.FINGER_LENGTH - 0.006)
        cs = 0.5 * (xmin + xmax) + _LATERAL_OFFSETS
        ok = (xmin - cs > -slack) & (xmax - cs < slack) & (xmin - cs < -0.003) & (xmax - cs > 0.003)
        if not ok.any():
            continue
        cs = cs[ok]
        grasps = centre + np.stack([cs, np.full_like(cs, -grasp_y)], 1) @ np.array(
            [[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]
        )
        # finger corridor in the approach frame (centred on the target): x in [c - h, c + h],
        # y from where the fingertips leave the shelf to the fingertips at the grasp pose
        out = np.array([way_out(g, a) for g in grasps])
        y_lo, y_hi = -grasp_y - out, -grasp_y + C.FINGER_LENGTH
        band = np.zeros((len(clutter), len(cs)), bool)
        lanes = np.zeros((len(clutter), len(cs)), bool)
        hw = h + C.FINGER_WIDTH
        for i, poly in enumerate(clutter):
            p = transform_points(poly - centre, (0.0, 0.0, -a))
            px0, px1, py0, py1 = p[:, 0].min(), p[:, 0].max(), p[:, 1].min(), p[:, 1].max()
            along = (py1 > y_lo) & (py0 < y_hi)
            band[i] = (px1 > cs - h) & (px0 < cs + h) & along
            lanes[i] = (px1 > cs - hw) & (px0 < cs + hw) & along
        yield a, grasps, band, lanes


def plan_grasp(
    target: np.ndarray, clutter: list[np.ndarray] = (), prefer_angle: float = 0.0, exclude: list[float] = ()
) -> tuple[float, np.ndarray]:
    """Approach angle and grasp position (gripper origin) for a target polygon (shelf frame).

    Candidates come from :func:`grasp_candidates` (from ``prefer_angle``, the gripper's current
    heading, so a re-plan does not swing the arm, and centred outwards; ``exclude``: approaches
    that already failed). Preference: a wall-free way in with no clutter in the way of the
    fingers; then one with no clutter between the fingers (clutter ahead of a finger gets pushed
    aside); then any wall-free way in; then anything that fits.
    """
    fits = wall_free = band_only = None
    for a, grasps, band, lanes in grasp_candidates(target, clutter, prefer_angle, exclude):
        band_free, lanes_free = ~band.any(axis=0), ~lanes.any(axis=0)
        for k in range(len(grasps)):
            if fits is None:
                fits = (a, grasps[k])
            if (band_free[k] or wall_free is None) and path_clear(grasps[k], a):
                if lanes_free[k]:
                    return a, grasps[k]
                if band_free[k] and band_only is None:
                    band_only = (a, grasps[k])
                if wall_free is None:
                    wall_free = (a, grasps[k])
    if band_only is not None:
        return band_only
    if wall_free is not None:
        return wall_free
    if fits is not None:
        return fits
    return 0.0, target.mean(axis=0) + np.array([0.0, -0.02])  # nothing fits: aim at it straight on


def fingertips_inside(gripper_pose) -> bool:
    """Whether the fingertips of a gripper at this pose (shelf frame) are in the shelf."""
    return gripper_pose[1] + math.cos(gripper_pose[2]) * C.FINGER_LENGTH > _OUTSIDE_Y


def way_out(grasp: np.ndarray, angle: float) -> float:
    """Distance back along the approach axis until the fingertips are out of the shelf."""
    back_y = -math.cos(angle)
    return max((grasp[1] + C.FINGER_LENGTH - _OUTSIDE_Y) / max(-back_y, 1e-3), 0.0)


def path_clear(grasp: np.ndarray, angle: float) -> bool:
    """No part of the open gripper touches a wall at the grasp pose or on the straight line back
    out of the shelf along the approach axis. A part translated along a line sweeps the convex
    hull of its start and end outlines, so one separating-axis test per part and wall suffices."""
    back = _rot(np.array([0.0, -1.0]), angle)
    far = grasp + way_out(grasp, angle) * back
    for part in _OPEN_GRIPPER:
        swept = convex_hull(np.concatenate([transform_points(part, (*grasp, angle)), transform_points(part, (*far, angle))]))
        if any(polygons_overlap(swept, w, clearance=0.001) for w in SHELF_WALLS):
            return False
    return True
