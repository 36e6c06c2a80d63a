"""The standard observation pipeline: ShelfEnv -> render -> robot-centric crop (-> heat-map label)."""

from __future__ import annotations

import math
import warnings
from typing import Sequence

from torchrl.envs import Compose, InitTracker, StepCounter, TransformedEnv

from occrl.envs import world_constants as C
from occrl.envs.remembered import RememberedDetections
from occrl.envs.robot_frame import DEFAULT_FORWARD_OFFSET, DEFAULT_SIZE, DEFAULT_WINDOW
from occrl.envs.scene import Scene
from occrl.envs.shelf_env import ShelfEnv
from occrl.envs.transforms import HeatmapTarget, OcclusionRender, RobotCentricCrop

__all__ = ["make_env", "observation_transforms"]


def observation_transforms(
    window: float = DEFAULT_WINDOW,
    size: int = DEFAULT_SIZE,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
    heatmap_target: bool = True,
    remembered_detections: bool = False,
) -> list:
    """The transforms that turn detections into the network input (and its heat-map label).

    Examples:
        >>> from torchrl.envs import Compose, TransformedEnv
        >>> from occrl.envs import ShelfEnv, observation_transforms
        >>> [type(t).__name__ for t in observation_transforms()]
        ['OcclusionRender', 'RobotCentricCrop', 'HeatmapTarget']
        >>> env = TransformedEnv(ShelfEnv(batch_size=1, seed=0), Compose(*observation_transforms(heatmap_target=False)))
        >>> env.reset()["pixels"].shape
        torch.Size([1, 3, 64, 64])
    """
    ts = [RememberedDetections()] if remembered_detections else []
    ts += [OcclusionRender(), RobotCentricCrop(window=window, size=size, forward_offset=forward_offset)]
    if heatmap_target:
        ts.append(HeatmapTarget(window=window, size=size, forward_offset=forward_offset))
    return ts


def make_env(
    batch_size: int = 1,
    stage: int = 1,
    noise: float = 0.0,
    seed: int | Sequence[int] | None = None,
    scenes: Sequence[Scene] | None = None,
    num_objects: int | None = None,
    max_steps: int = C.MAX_EPISODE_STEPS,
    window: float = DEFAULT_WINDOW,
    size: int = DEFAULT_SIZE,
    forward_offset: float = DEFAULT_FORWARD_OFFSET,
    heatmap_target: bool = True,
    world: str = "pymunk",
    remembered_detections: bool = False,
    **env_kwargs,
) -> TransformedEnv:
    """The standard pipeline: a batched env whose ``"pixels"`` entry is the 3x64x64 network input.

    ``InitTracker`` marks episode starts (the LSTM needs them) and ``StepCounter`` counts actions.

    Args:
        batch_size: number of worlds stepped together in this process.
        stage, noise, seed, scenes, num_objects, max_steps: see :class:`~occrl.envs.ShelfEnv`.
        window, size, forward_offset: the robot-centric window (metres, pixels, metres).
        heatmap_target: also render ``("privileged", "heatmap_target")`` for training.
        remembered_detections: fill undetected object slots with the episode's earlier
            detections before rendering (:class:`~occrl.envs.remembered.RememberedDetections`;
            beyond the paper, off by default; a network's ``config.remembered_detections``).
        world: ``"pymunk"`` (the 2D world) or ``"mujoco"`` (:class:`~occrl.envs.MujocoShelfEnv`, the
            3D execution env with its default visibility ``"auto"``; needs ``pip install -e ".[mujoco]"``).
            (Called ``backend`` before 0.2.0, a name now kept for process executors; still accepted
            here with a ``DeprecationWarning``.)
        **env_kwargs: passed to the env class, e.g. ``physics=occrl.envs.LEGACY_PHYSICS`` (the
            pymunk physics of occrl 0.1.0), or ``record_camera=True``, ``visibility="rays"`` or
            ``perception="tags"`` (detections from fiducial tags in the wrist camera's image) for
            MuJoCo.

    Examples:
        >>> from occrl.envs import make_env
        >>> env = make_env(batch_size=4, stage=1, seed=0)
        >>> td = env.reset()
        >>> td["pixels"].shape, float(td["pixels"].max()) <= 1.0
        (torch.Size([4, 3, 64, 64]), True)
    """
    if not window > 0.0 or not math.isfinite(window):
        raise ValueError(f"window must be a positive size in metres, got {window!r}")
    if isinstance(size, bool) or not isinstance(size, int) or size < 8:
        raise ValueError(f"size must be an int >= 8 (pixels), got {size!r}")
    if not math.isfinite(forward_offset):
        raise ValueError(f"forward_offset must be finite (metres), got {forward_offset!r}")
    if "backend" in env_kwargs:
        warnings.warn("make_env(backend=...) is now make_env(world=...)", DeprecationWarning, stacklevel=2)
        world = env_kwargs.pop("backend")
    if world == "pymunk":
        perception = env_kwargs.pop("perception", "geometric")
        if perception != "geometric":
            raise ValueError(f"perception={perception!r} needs world='mujoco' (the 2D world has no camera image)")
        for name in ("tag_layout", "wrist_camera", "shelf_height"):
            if name in env_kwargs:
                raise ValueError(f"{name} is a setting of the MuJoCo world: give it with world='mujoco'")
        env_cls = ShelfEnv
    elif world == "mujoco":
        from occrl.envs.mujoco3d.env import MujocoShelfEnv  # optional extra: imported only when asked for

        env_cls = MujocoShelfEnv
    else:
        raise ValueError(f"world must be 'pymunk' or 'mujoco', got {world!r}")
    base = env_cls(
        batch_size=batch_size,
        stage=stage,
        noise=noise,
        seed=seed,
        scenes=scenes,
        num_objects=num_objects,
        max_steps=max_steps,
        **env_kwargs,
    )
    transforms = [InitTracker(), StepCounter()]
    transforms += observation_transforms(window, size, forward_offset, heatmap_target, remembered_detections)
    return TransformedEnv(base, Compose(*transforms))
