"""Gymnasium interface: the shelf for Gymnasium-based tools (Stable-Baselines3, CleanRL).

``import occrl`` registers ``"occrl/ShelfRetrieval-v0"`` (with gymnasium installed:
``pip install -e ".[gym]"``); ``gymnasium.make("occrl:occrl/ShelfRetrieval-v0")`` imports occrl
itself. Both classes run the standard TorchRL pipeline (:func:`~occrl.envs.make_env`: detections,
occlusion render, robot-centric crop) underneath, so a Gymnasium agent sees exactly what occrl's
own networks see.

Action Space:
    ``Box(-1, 1, (4,), float32)``: forward, lateral, rotation (gripper frame), gripper (> 0 closes).

Observation Space:
    ``Dict``: ``"pixels"`` ``Box(0, 255, (3, 64, 64), uint8)``, the abstract robot-centric image
    (occrl's network input times 255); ``"gripper_pose"`` ``Box((-0.45, -0.35, -1.67), (0.45,
    0.4, 1.67), (3,))`` (x, y, theta in the shelf frame, the reachable poses with a margin);
    ``"gripper_opening"`` ``Box(0, 0.085, (1,))`` (m); ``"gripper_closed"`` ``Box(0, 1, (1,))``
    (the last gripper command). Ground truth is never in the observation.

Rewards:
    -1 per action; -50 more when an object leaves the shelf.

Starting State:
    A shelf of the curriculum ``stage`` sampled from the env's random generator (``reset(seed=s)``
    fixes it); the gripper outside the shelf facing in.

Episode Termination:
    Terminated when the target is pulled out (``info["success"]``) or an object is dropped
    (``info["dropped"]``); truncated after 50 actions. ``info["penetration"]`` is the physics'
    deepest overlap after the action (m).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from torchrl.envs.utils import step_mdp

from occrl.envs import world_constants as C
from occrl.envs.pipeline import make_env
from occrl.envs.scene import STAGES

try:
    import gymnasium as gym
    from gymnasium import spaces
    from gymnasium.vector import AutoresetMode, VectorEnv
except ImportError as err:  # pragma: no cover - optional extra
    raise ImportError('the Gymnasium interface needs gymnasium: pip install -e ".[gym]"') from err

__all__ = ["ShelfRetrievalEnv", "ShelfRetrievalVectorEnv"]

IMAGE_SHAPE = (3, 64, 64)


# the reachable gripper poses, with room for the physics to push the gripper a little past them
POSE_LOW = np.array([C.GRIPPER_X_LIMITS[0] - 0.05, C.GRIPPER_Y_LIMITS[0] - 0.05, C.GRIPPER_THETA_LIMITS[0] - 0.1], np.float32)
POSE_HIGH = np.array([C.GRIPPER_X_LIMITS[1] + 0.05, C.GRIPPER_Y_LIMITS[1] + 0.05, C.GRIPPER_THETA_LIMITS[1] + 0.1], np.float32)


def _observation_space() -> spaces.Dict:
    return spaces.Dict(
        {
            "pixels": spaces.Box(0, 255, IMAGE_SHAPE, np.uint8),
            "gripper_pose": spaces.Box(POSE_LOW, POSE_HIGH, (3,), np.float32),
            "gripper_opening": spaces.Box(0.0, np.float32(C.GRIPPER_STROKE), (1,), np.float32),
            "gripper_closed": spaces.Box(0.0, 1.0, (1,), np.float32),
        }
    )


def _action_space() -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (C.ACTION_DIM,), np.float32)


def _check(stage: int, noise: float) -> None:
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {sorted(STAGES)}, got {stage!r}")
    if not 0.0 <= noise <= 1.0:
        raise ValueError(f"noise must be in [0, 1] (the paper uses 0 to 0.25), got {noise!r}")


def _observations(td) -> dict[str, np.ndarray]:
    """The Dict observation (batched) of a TorchRL observation tensordict."""
    return {
        "pixels": np.round(td.get("pixels").numpy() * 255.0).astype(np.uint8),
        "gripper_pose": np.clip(td.get("gripper_pose").numpy().astype(np.float32), POSE_LOW, POSE_HIGH),
        "gripper_opening": np.clip(td.get("gripper_opening").numpy().astype(np.float32), 0.0, np.float32(C.GRIPPER_STROKE)),
        "gripper_closed": td.get("gripper_closed").numpy().astype(np.float32),
    }


def _actions(action, batch: int) -> torch.Tensor:
    a = np.asarray(action, dtype=np.float32)
    if a.shape != (batch, C.ACTION_DIM) and not (batch == 1 and a.shape == (C.ACTION_DIM,)):
        raise ValueError(f"action must have shape {(batch, C.ACTION_DIM) if batch > 1 else (C.ACTION_DIM,)}, got {a.shape}")
    return torch.from_numpy(a.reshape(batch, C.ACTION_DIM).copy())


class ShelfRetrievalEnv(gym.Env):
    """One shelf as a Gymnasium env (see the module docstring for the spaces).

    Args:
        stage: curriculum stage of the sampled shelves (1: 1-4 objects, 2: 5-10, 3: 7-10, target
            at the back).
        noise: execution noise level (0 to 0.25 in the paper).
        render_mode: ``"rgb_array"`` renders the abstract observation image, or None.

    Examples:
        >>> import gymnasium, occrl
        >>> env = gymnasium.make("occrl/ShelfRetrieval-v0", stage=1)
        >>> obs, info = env.reset(seed=0)
        >>> obs["pixels"].shape, env.action_space.shape
        ((3, 64, 64), (4,))
        >>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        >>> reward
        -1.0
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, stage: int = 1, noise: float = 0.0, render_mode: str | None = None) -> None:
        _check(stage, noise)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.stage, self.noise, self.render_mode = stage, float(noise), render_mode
        self.observation_space = _observation_space()
        self.action_space = _action_space()
        self._env = make_env(batch_size=1, stage=stage, noise=noise, seed=0, heatmap_target=False)
        self._td = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        # the shelf and its noise come from the env's generator: one draw per episode
        self._env.set_seed(int(self.np_random.integers(2**62)))
        self._td = self._env.reset()
        return {k: v[0] for k, v in _observations(self._td).items()}, {}

    def step(self, action):
        if self._td is None:
            raise RuntimeError("call reset() before step()")
        td = self._env.step(self._td.set("action", _actions(action, 1)))
        nxt = td.get("next")
        self._td = step_mdp(td)
        info = {
            "success": bool(nxt.get("success")[0, 0]),
            "dropped": bool(nxt.get("dropped")[0, 0]),
            "penetration": float(nxt.get(("privileged", "penetration"))[0, 0]),
        }
        obs = {k: v[0] for k, v in _observations(nxt).items()}
        return obs, float(nxt.get("reward")[0, 0]), bool(nxt.get("terminated")[0, 0]), bool(nxt.get("truncated")[0, 0]), info

    def render(self):
        if self.render_mode != "rgb_array" or self._td is None:
            return None
        return np.round(self._td.get("pixels")[0].permute(1, 2, 0).numpy() * 255.0).astype(np.uint8)

    def close(self) -> None:
        self._env.close()


class ShelfRetrievalVectorEnv(VectorEnv):
    """``num_envs`` shelves stepped together in one process (one batched :class:`ShelfEnv`), with
    same-step autoreset: the observation returned when a world's episode ends is the first of its
    next episode, and the last one is in ``info["final_obs"]`` (``info["_final_obs"]`` marks which).

    Examples:
        >>> import gymnasium, occrl
        >>> envs = gymnasium.make_vec("occrl/ShelfRetrieval-v0", num_envs=3, vectorization_mode="vector_entry_point")
        >>> obs, info = envs.reset(seed=0)
        >>> obs["pixels"].shape
        (3, 3, 64, 64)
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 1, stage: int = 1, noise: float = 0.0, **kwargs) -> None:
        _check(stage, noise)
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be an int >= 1, got {num_envs!r}")
        self.num_envs = num_envs
        self.single_observation_space = _observation_space()
        self.single_action_space = _action_space()
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, num_envs)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self._env = make_env(batch_size=num_envs, stage=stage, noise=noise, seed=0, heatmap_target=False)
        self._td = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        if seed is not None:
            self._np_random, _ = gym.utils.seeding.np_random(seed)
        self._env.set_seed(int(self.np_random.integers(2**62)))
        self._td = self._env.reset()
        return _observations(self._td), {}

    def step(self, actions):
        if self._td is None:
            raise RuntimeError("call reset() before step()")
        td, root = self._env.step_and_maybe_reset(self._td.set("action", _actions(actions, self.num_envs)))
        nxt = td.get("next")
        self._td = root
        done = nxt.get("done")[:, 0].numpy()
        info: dict[str, Any] = {
            "success": nxt.get("success")[:, 0].numpy().copy(),
            "dropped": nxt.get("dropped")[:, 0].numpy().copy(),
            "penetration": nxt.get(("privileged", "penetration"))[:, 0].numpy().copy(),
        }
        if done.any():
            info["final_obs"] = _observations(nxt)
            info["_final_obs"] = done.copy()
        return (
            _observations(root),
            nxt.get("reward")[:, 0].numpy().astype(np.float64),
            nxt.get("terminated")[:, 0].numpy().copy(),
            nxt.get("truncated")[:, 0].numpy().copy(),
            info,
        )

    def close_extras(self, **kwargs) -> None:
        self._env.close()
