"""The task, apart from any simulator (dm_control's Physics / Task split): what an action achieved
(retrieval, drops, reward), computed once from world queries for the pymunk and the MuJoCo world,
and the :class:`World` protocol: what a world offers the env and the task.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from occrl.envs import world_constants as C

__all__ = ["StepOutcome", "task_outcome", "World"]


@dataclass(frozen=True)
class StepOutcome:
    """What one action did. ``dropped`` lists object indices that left the shelf.

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs.task import StepOutcome
        >>> StepOutcome(reward=-1.0, retrieved=False, dropped=(2,)).terminal
        True
        >>> out = ShelfWorld(Scene.sample(stage=1, seed=0)).step([1.0, 0.0, 0.0, -1.0])
        >>> out.retrieved, out.dropped, out.terminal
        (False, (), False)
    """

    reward: float
    retrieved: bool
    dropped: tuple[int, ...]

    @property
    def terminal(self) -> bool:
        return self.retrieved or bool(self.dropped)


def task_outcome(poses: np.ndarray, held: int | None, target_index: int, fallen: np.ndarray | None = None) -> StepOutcome:
    """The task's verdict on a world state after an action: the target is retrieved when it is held
    and its centroid is past the retrieval line (``RETRIEVED_Y``); any other object is dropped once
    its centroid leaves the shelf (in front of the front edge, or 5 cm beyond the back or a side)
    or ``fallen`` says it fell; reward -1 per action, -50 more when anything was dropped.

    Args:
        poses: (n, 3) object poses (x, y, theta) in the shelf frame (an array, or a list of rows).
        held: index of the object held between the fingers, or None.
        target_index: the target's index (-1: no target, e.g. a planner's imagined world).
        fallen: optional (n,) flags of objects that fell off (the 3D world's heights).

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.task import task_outcome
        >>> poses = np.array([[0.0, -0.06, 0.0], [0.1, 0.2, 0.0]])
        >>> task_outcome(poses, held=0, target_index=0)  # target held past the line
        StepOutcome(reward=-1.0, retrieved=True, dropped=())
        >>> task_outcome(poses, held=None, target_index=1).dropped  # object 0 is off the shelf
        (0,)
    """
    # Python floats: the same comparisons, without numpy's per-element cost
    rows = poses if isinstance(poses, list) else np.asarray(poses).tolist()
    retrieved = target_index >= 0 and held == target_index and rows[target_index][1] < C.RETRIEVED_Y
    dropped = []
    for i, (x, y, *_) in enumerate(rows):
        if i == target_index and held == i:
            continue  # the target on its way out in the gripper
        if y < C.FRONT_EDGE_Y or y > C.SHELF_DEPTH + 0.05 or abs(x) > C.SHELF_HALF_WIDTH + 0.05 or (fallen is not None and fallen[i]):
            dropped.append(i)
    reward = C.STEP_REWARD + (C.DROP_PENALTY if dropped else 0.0)
    return StepOutcome(reward=reward, retrieved=bool(retrieved), dropped=tuple(dropped))


@runtime_checkable
class World(Protocol):
    """What a world offers :class:`~occrl.envs.ShelfEnv` and the task: :class:`~occrl.envs.ShelfWorld`
    (pymunk) and :class:`~occrl.envs.mujoco3d.world.MujocoWorld` (MuJoCo) both do.

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs.task import World
        >>> isinstance(ShelfWorld(Scene.sample(stage=1, seed=0)), World)
        True
    """

    num_objects: int
    target_index: int
    penetration: float  # deepest overlap after the last action (m)
    crossed_wall: bool  # an object went through a wall in the last action

    @property
    def opening(self) -> float: ...  # the fingers' gap (m)

    @property
    def held(self) -> int | None: ...  # index of the object between the closed fingers

    def gripper_pose(self) -> np.ndarray: ...  # (x, y, theta) in the shelf frame

    def object_poses(self) -> np.ndarray: ...  # (n, 3)

    def step(self, action) -> StepOutcome: ...  # one action: the task's verdict on it

    def physically_valid(self, max_penetration: float = ...) -> bool: ...
