"""ShelfEnv: a batch of independent pymunk shelf worlds as one TorchRL environment."""

from __future__ import annotations

import logging
from typing import Sequence

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

from occrl.envs import world_constants as C
from occrl.envs.pymunk2d.physics_settings import DEFAULT_PHYSICS, PhysicsSettings
from occrl.envs.scene import STAGES, Scene
from occrl.envs.observation import (
    MAX_POLY_VERTICES,
    MAX_SLOTS,
    MAX_TYPE_ID,
    GRIPPER_AND_TARGET_KEYS,
    OBJECT_SLOT_KEYS,
    detection_arrays,
    pad_polygon,
    world_visible_fractions,
)
from occrl.envs.pymunk2d.world import ShelfWorld

__all__ = ["ShelfEnv", "MAX_SLOTS", "MAX_POLY_VERTICES", "pad_polygon"]

logger = logging.getLogger(__name__)


class ShelfEnv(EnvBase):
    """Retrieve a target object from a cluttered shelf (Bejjani et al.), a batch of pymunk worlds.

    A gripper with a camera starts in front of a shelf holding convex objects, one of which is
    the target. It must find the target, grasp it and pull it out past the front edge without
    pushing any other object off the shelf. All worlds of the batch step in one call.

    Action Space:
        ``Bounded(-1, 1, (4,))``: forward and lateral motion and rotation in the gripper frame,
        scaled to at most 5 cm, 5 cm and 15 degrees, and the gripper command (> 0 close, <= 0
        open). Values outside [-1, 1] are clipped; NaN or inf raise ``ValueError`` and leave
        every world unchanged.

    Observation Space:
        What a perception system reports, never ground truth:
        ``"gripper_pose"`` (x, y, theta), ``"gripper_opening"`` (m), ``"gripper_closed"`` (the
        last gripper command, as the robot knows it), ``"target_type"`` and
        ``"target_vertices"`` (the target's shape, a task prior) and, per object slot,
        ``("objects", "detected" | "type_id" | "pose" | "vertices" | "num_vertices")``. A slot
        is filled only while its object is more than 50 % visible from the camera; undetected
        slots are all zero. ``"success"`` and ``"dropped"`` flag how an episode ended.
        Ground truth for losses and analysis lives under ``"privileged"``; no policy reads it.
        Among it, the physics' own health: ``("privileged", "penetration")``, the deepest
        overlap (m) between two bodies or a body and a wall after the last action, and
        ``("privileged", "physics_invalid")``, set for the rest of the episode once a state was
        physically invalid (an overlap over 5 mm or an object beyond a wall; a warning is logged).

    Rewards:
        -1 per action; -50 more when an object leaves the shelf.

    Starting State:
        A scene sampled for the curriculum ``stage`` (1: 1-4 objects, 2: 5-10, 3: 7-10 with the
        target in the back half) or the next of the given ``scenes``; the gripper starts outside
        the shelf (y = -0.1 m) facing in. With a ``scene_pool``, a share of the episodes start
        from the pool's states instead (the gripper wherever they have it, open and empty).

    Episode Termination:
        Terminated when the target is held and its centroid is 5 cm past the front edge
        (``success``) or when any other object leaves the shelf (``dropped``); truncated after
        ``max_steps`` (50) actions. A ``"_step"`` mask in the input (TorchRL's
        ``rollout(..., break_when_all_done=True)`` writes it) steps only the worlds it marks;
        the others stay as they are, their step counters included.

    Args:
        batch_size: number of independent worlds.
        stage: curriculum stage for sampled scenes.
        noise: execution noise level on density, friction and shapes (0 to 0.25).
        seed: seeds scene sampling and noise; world ``i`` uses the ``i``-th spawned stream. A
            list of ints (one per world) seeds each world's stream directly (fixed task seeds).
        scenes: reset to these scenes in turn instead of sampling.
        num_objects: fixed object count for sampled scenes (overrides the stage's range).
        max_steps: truncation horizon.
        physics: integration settings of the pymunk worlds (``occrl.envs.LEGACY_PHYSICS``
            reproduces occrl 0.1.0).
        scene_pool: start states to draw from (beyond the paper; e.g. the states a search
            hands over to the retrieval): at each reset a
            world starts from a scene of the pool with probability ``scene_pool_share``, drawn by
            its own seeded generator (so a seed fixes the episode), else from a sampled scene.
            Not with ``scenes``.
        scene_pool_share: that probability, in (0, 1].

    Examples:
        >>> from occrl.envs import ShelfEnv
        >>> env = ShelfEnv(batch_size=2, stage=1, seed=0)
        >>> td = env.rollout(3)
        >>> td["next", "reward"].shape
        torch.Size([2, 3, 1])
    """

    batch_locked = True

    def __init__(
        self,
        batch_size: int | Sequence[int] = 1,
        stage: int = 1,
        noise: float = 0.0,
        seed: int | Sequence[int] | None = None,
        scenes: Sequence[Scene] | None = None,
        num_objects: int | None = None,
        max_steps: int = C.MAX_EPISODE_STEPS,
        device: str | torch.device = "cpu",
        physics: PhysicsSettings = DEFAULT_PHYSICS,
        scene_pool: Sequence[Scene] | None = None,
        scene_pool_share: float = 1.0,
    ) -> None:
        if isinstance(batch_size, int):
            batch_size = (batch_size,)
        batch_size = torch.Size(batch_size)
        if len(batch_size) != 1 or batch_size[0] < 1:
            raise ValueError(f"batch_size must be a positive int or a 1-element shape, got {tuple(batch_size)}")
        if stage not in STAGES:
            raise ValueError(f"stage must be one of {sorted(STAGES)}, got {stage!r}")
        if not 0.0 <= noise <= 1.0:
            raise ValueError(f"noise must be in [0, 1] (the paper uses 0 to 0.25), got {noise}")
        if num_objects is not None and (
            isinstance(num_objects, bool) or not isinstance(num_objects, int) or not 1 <= num_objects <= MAX_SLOTS
        ):
            raise ValueError(f"num_objects must be None or an int in [1, {MAX_SLOTS}], got {num_objects!r}")
        if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
            raise ValueError(f"max_steps must be an int >= 1, got {max_steps!r}")
        seeds = seed if isinstance(seed, (list, tuple)) else [seed]
        if not all(
            s is None and len(seeds) == 1 or (isinstance(s, (int, np.integer)) and not isinstance(s, bool) and s >= 0) for s in seeds
        ):
            raise ValueError(f"seed must be None, an int >= 0 or a list of them (one per world), got {seed!r}")
        if not isinstance(physics, PhysicsSettings):
            raise TypeError(f"physics must be an occrl.envs.PhysicsSettings, got {type(physics).__name__}")
        if scenes is not None:
            scenes = list(scenes)
            if not scenes or not all(isinstance(s, Scene) for s in scenes):
                raise ValueError("scenes must be a non-empty sequence of occrl.envs.Scene")
        if scene_pool is not None:
            scene_pool = list(scene_pool)
            if not scene_pool or not all(isinstance(s, Scene) for s in scene_pool):
                raise ValueError("scene_pool must be a non-empty sequence of occrl.envs.Scene")
            if scenes is not None:
                raise ValueError("give scenes (reset to each in turn) or scene_pool (drawn at random), not both")
        if isinstance(scene_pool_share, bool) or not isinstance(scene_pool_share, (int, float)) or not 0.0 < scene_pool_share <= 1.0:
            raise ValueError(f"scene_pool_share must be a probability in (0, 1], got {scene_pool_share!r}")
        super().__init__(device=device, batch_size=batch_size)
        self.num_worlds = int(batch_size[0])
        self.stage = stage
        self.noise = float(noise)
        self.scenes = scenes
        self.scene_pool = scene_pool
        self.scene_pool_share = float(scene_pool_share)
        self.num_objects = num_objects
        self.max_steps = int(max_steps)
        self.physics = physics
        self._scene_cursor = 0
        self.worlds: list[ShelfWorld | None] = [None] * self.num_worlds
        self._steps = np.zeros(self.num_worlds, dtype=np.int64)
        self._invalid = np.zeros(self.num_worlds, dtype=bool)
        self._make_specs()
        if isinstance(seed, (list, tuple)):
            if len(seed) != self.num_worlds:
                raise ValueError(f"a list of seeds needs one per world ({self.num_worlds}), got {len(seed)}")
            self._rngs = [np.random.default_rng(int(s)) for s in seed]
            self._seed = list(seed)
        else:
            self._set_seed(seed)

    # ------------------------------------------------------------------ specs
    def _make_specs(self) -> None:
        B = self.batch_size
        N, V = MAX_SLOTS, MAX_POLY_VERTICES
        f32 = torch.float32

        def flag():
            return Categorical(2, shape=(*B, 1), dtype=torch.bool)

        objects = Composite(
            detected=Categorical(2, shape=(*B, N), dtype=torch.bool),
            type_id=Categorical(MAX_TYPE_ID, shape=(*B, N), dtype=torch.int64),
            pose=Unbounded(shape=(*B, N, 3), dtype=f32),
            vertices=Unbounded(shape=(*B, N, V, 2), dtype=f32),
            num_vertices=Categorical(V + 1, shape=(*B, N), dtype=torch.int64),
            shape=(*B, N),
        )
        privileged = Composite(
            object_present=Categorical(2, shape=(*B, N), dtype=torch.bool),
            object_pose=Unbounded(shape=(*B, N, 3), dtype=f32),
            object_vertices=Unbounded(shape=(*B, N, V, 2), dtype=f32),
            object_num_vertices=Categorical(V + 1, shape=(*B, N), dtype=torch.int64),
            visible_fraction=Bounded(0.0, 1.0, shape=(*B, N), dtype=f32),
            target_slot=Categorical(N, shape=(*B, 1), dtype=torch.int64),
            target_pose=Unbounded(shape=(*B, 3), dtype=f32),
            target_held=Categorical(2, shape=(*B, 1), dtype=torch.bool),
            penetration=Unbounded(shape=(*B, 1), dtype=f32),
            physics_invalid=Categorical(2, shape=(*B, 1), dtype=torch.bool),
            shape=B,
        )
        self.observation_spec = Composite(
            gripper_pose=Unbounded(shape=(*B, 3), dtype=f32),
            gripper_opening=Bounded(0.0, C.GRIPPER_STROKE, shape=(*B, 1), dtype=f32),
            gripper_closed=flag(),
            target_type=Categorical(MAX_TYPE_ID, shape=(*B, 1), dtype=torch.int64),
            target_vertices=Unbounded(shape=(*B, V, 2), dtype=f32),
            target_num_vertices=Categorical(V + 1, shape=(*B, 1), dtype=torch.int64),
            objects=objects,
            success=flag(),
            dropped=flag(),
            privileged=privileged,
            shape=B,
        )
        self.action_spec = Bounded(-1.0, 1.0, shape=(*B, C.ACTION_DIM), dtype=f32)
        self.reward_spec = Unbounded(shape=(*B, 1), dtype=f32)
        self.done_spec = Composite(done=flag(), terminated=flag(), truncated=flag(), shape=B)

    # ------------------------------------------------------------------ seeding
    def _set_seed(self, seed: int | None) -> None:
        ss = np.random.SeedSequence(seed)
        self._rngs = [np.random.default_rng(s) for s in ss.spawn(self.num_worlds)]  # one stream per world: its scenes and its noise
        self._seed = seed

    def _next_scene(self, i: int) -> Scene:
        if self.scenes is not None:
            scene = self.scenes[self._scene_cursor % len(self.scenes)]
            self._scene_cursor += 1
            return scene
        rng = self._rngs[i]
        if self.scene_pool is not None and (self.scene_pool_share >= 1.0 or rng.random() < self.scene_pool_share):
            return self.scene_pool[int(rng.integers(len(self.scene_pool)))]
        return Scene.sample(self.stage, seed=rng, num_objects=self.num_objects)

    # ------------------------------------------------------------------ reset / step
    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        if tensordict is not None and "_reset" in tensordict.keys():
            mask = tensordict.get("_reset").reshape(self.num_worlds).cpu().numpy()
        else:
            mask = np.ones(self.num_worlds, dtype=bool)
        for i in np.flatnonzero(mask):
            if self.worlds[i] is not None:
                self._release_world(self.worlds[i])
            self.worlds[i] = self._new_world(i)
            self._steps[i] = 0
            self._invalid[i] = False
        zeros = np.zeros(self.num_worlds, dtype=bool)
        out = self._observe(success=zeros, dropped=zeros)
        flags = torch.zeros((self.num_worlds, 1), dtype=torch.bool)
        out.update({"done": flags, "terminated": flags.clone(), "truncated": flags.clone()})
        return out

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        actions = tensordict.get("action").detach().cpu().numpy().astype(np.float64).reshape(self.num_worlds, -1)
        if actions.shape[1] != C.ACTION_DIM:
            raise ValueError(f"actions must have {C.ACTION_DIM} entries, got shape {tuple(actions.shape)}")
        bad = ~np.isfinite(actions).all(axis=1)
        if bad.any():
            raise ValueError(
                f"action of world(s) {np.flatnonzero(bad).tolist()} contains NaN or inf: "
                f"{actions[bad].tolist()}; allowed: finite numbers, clipped to [-1, 1]. No world was stepped."
            )
        B = self.num_worlds
        partial = tensordict.get("_step", None)
        stepped = np.ones(B, dtype=bool) if partial is None else partial.reshape(B).cpu().numpy().astype(bool)
        reward = np.zeros(B, dtype=np.float32)
        success = np.zeros(B, dtype=bool)
        dropped = np.zeros(B, dtype=bool)
        for i in np.flatnonzero(stepped):
            world = self.worlds[i]
            outcome = world.step(actions[i])
            reward[i] = outcome.reward
            success[i] = outcome.retrieved
            dropped[i] = bool(outcome.dropped)
            if not self._invalid[i] and not world.physically_valid():
                self._invalid[i] = True
                logger.warning(
                    "world %d reached a physically invalid state at action %d (penetration %.1f mm, object past a wall: %s)",
                    i,
                    self._steps[i] + 1,
                    1000 * world.penetration,
                    world.crossed_wall,
                )
        self._steps += stepped
        terminated = success | dropped
        truncated = (self._steps >= self.max_steps) & ~terminated
        out = self._observe(success=success, dropped=dropped)
        out.update(
            {
                "reward": torch.from_numpy(reward).unsqueeze(-1),
                "terminated": torch.from_numpy(terminated).unsqueeze(-1),
                "truncated": torch.from_numpy(truncated).unsqueeze(-1),
                "done": torch.from_numpy(terminated | truncated).unsqueeze(-1),
            }
        )
        return out

    # ------------------------------------------------------------------ world hooks
    # A subclass executing the task in another simulator (MujocoShelfEnv) overrides these; its
    # worlds offer ShelfWorld's interface (step -> StepOutcome, poses, held, opening, closed, ...).
    def _new_world(self, i: int):
        return ShelfWorld(self._next_scene(i), noise=self.noise, rng=self._rngs[i], physics=self.physics)

    def _release_world(self, world) -> None:
        """Free a world's resources before it is replaced."""

    def _visible_fractions(self, world, poses: np.ndarray) -> np.ndarray:
        return world_visible_fractions(world, poses)

    def _extend_observation(self, out: TensorDictBase) -> TensorDictBase:
        """Add simulator-specific entries (e.g. camera images) to an observation."""
        return out

    # ------------------------------------------------------------------ perception
    def _observe(self, success: np.ndarray, dropped: np.ndarray) -> TensorDictBase:
        B, N, V = self.num_worlds, MAX_SLOTS, MAX_POLY_VERTICES
        present = np.zeros((B, N), bool)
        true_pose = np.zeros((B, N, 3), np.float32)
        true_verts = np.zeros((B, N, V, 2), np.float32)
        true_nv = np.zeros((B, N), np.int64)
        frac = np.zeros((B, N), np.float32)
        target_slot = np.zeros((B, 1), np.int64)
        target_pose = np.zeros((B, 3), np.float32)
        target_held = np.zeros((B, 1), bool)
        penetration = np.zeros((B, 1), np.float32)
        fractions, all_poses = [], []
        for i, w in enumerate(self.worlds):
            n = w.num_objects
            poses = w.object_poses()
            f = self._visible_fractions(w, poses)
            fractions.append(f)
            all_poses.append(poses)
            present[i, :n] = True
            true_pose[i, :n] = poses
            true_verts[i, :n] = w.padded_vertices
            true_nv[i, :n] = w.num_vertices
            frac[i, :n] = f
            t = w.target_index
            target_slot[i, 0] = t
            target_pose[i] = poses[t]
            target_held[i, 0] = w.held == t
            penetration[i, 0] = w.penetration
        a = detection_arrays(self.worlds, fractions, all_poses)  # the one perception pipeline (occrl.envs.observation)
        t = torch.from_numpy
        batch = self.batch_size

        out = TensorDict(
            {
                **{k: t(a[k]) for k in GRIPPER_AND_TARGET_KEYS},
                "objects": TensorDict(
                    {k: t(a[k]) for k in OBJECT_SLOT_KEYS},
                    batch_size=(*batch, N),
                ),
                "success": t(success.copy()).unsqueeze(-1),
                "dropped": t(dropped.copy()).unsqueeze(-1),
                "privileged": TensorDict(
                    {
                        "object_present": t(present),
                        "object_pose": t(true_pose),
                        "object_vertices": t(true_verts),
                        "object_num_vertices": t(true_nv),
                        "visible_fraction": t(frac),
                        "target_slot": t(target_slot),
                        "target_pose": t(target_pose),
                        "target_held": t(target_held),
                        "penetration": t(penetration),
                        "physics_invalid": t(self._invalid.copy()).unsqueeze(-1),
                    },
                    batch_size=batch,
                ),
            },
            batch_size=batch,
        )
        return self._extend_observation(out)
