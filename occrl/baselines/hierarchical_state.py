"""One world's episode in the hierarchical planner (:mod:`occrl.baselines.hierarchical`): what it
remembers, which stage of Alg. 3 it is in, the low-level plan it is executing, and what becomes of
that plan when the world stops following it.

Stages: ``"search"``, ``"decide"`` (retrieve a located target, else rearrange), the two queries of
Retrieve (``"retrieve_reach"``, ``"retrieve_extract"``, then ``"retrieved"``) and of Rearrange
(``"rearrange_reach"``, ``"rearrange_place"``), and ``"move_out"``. A queued plan's kind
(``queue_kind``) is one of the planner's ``ACTION_KINDS`` other than ``"search"``.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from occrl.baselines.object_memory import ObjectMemory

__all__ = ["EpisodeState", "strayed"]

logger = logging.getLogger(__name__)


def strayed(pose: np.ndarray, expected: np.ndarray, tolerance: tuple[float, float]) -> bool:
    """Whether the observed gripper ``pose`` lies farther than ``tolerance`` (metres, radians)
    from the pose the simulator predicted (``expected``): the world left the plan.

    Examples:
        >>> import math
        >>> import numpy as np
        >>> from occrl.baselines.hierarchical_state import strayed
        >>> tolerance = (0.01, math.radians(10.0))
        >>> bool(strayed(np.array([0.0, 0.005, 0.0]), np.zeros(3), tolerance)), bool(strayed(np.array([0.0, 0.0, 0.5]), np.zeros(3), tolerance))
        (False, True)
    """
    dist, angle = tolerance
    turn = abs((pose[2] - expected[2] + math.pi) % (2 * math.pi) - math.pi)
    return math.hypot(pose[0] - expected[0], pose[1] - expected[1]) > dist or turn > angle


@dataclass
class EpisodeState:
    """Per-world memory and high-level state.

    Examples:
        >>> import numpy as np
        >>> from occrl.baselines.hierarchical_state import EpisodeState
        >>> ep = EpisodeState(queue_kind="reach")
        >>> ep.queue.extend([np.ones(4), np.zeros(4)]); ep.expected.extend([np.zeros(3), np.ones(3)])
        >>> ep.pop().tolist(), ep.last_kind, ep.awaiting.tolist()
        ([1.0, 1.0, 1.0, 1.0], 'reach', [0.0, 0.0, 0.0])
        >>> ep.drop_plan(closed=False, replan_inside=False)
        >>> ep.stage, len(ep.queue), ep.replans
        ('retrieve_reach', 0, 1)
    """

    step: int = 0
    known: ObjectMemory = field(default_factory=ObjectMemory)  # the objects detected so far
    queue: deque = field(default_factory=deque)
    expected: deque = field(default_factory=deque)  # gripper pose after each queued action (simulated)
    awaiting: np.ndarray | None = None  # the pose the last executed queued action should have led to
    queue_kind: str | None = None  # what the queue does: "reach", "extract", "rearrange_reach", "place", "move_out"
    replans: int = 0  # plans dropped because the world stopped following them (``follow_tolerance``)
    last_kind: str = "search"  # what the last action did: "search" or a queue kind (ACTION_KINDS)
    stage: str = "search"
    sweep: list | None = None  # waypoints left in the current sweep
    sweep_full: bool = True  # the current sweep does not stop when the target comes into view
    force_sweep: bool = False  # a plan failed: the next Search sweeps in full
    rearranged: set = field(default_factory=set)  # type ids already moved to the back
    rearrange_id: int | None = None
    planning_seconds: float = 0.0
    plans: list = field(default_factory=list)
    failures: int = 0
    out_of_time: bool = False
    hiding: tuple | None = None  # (step, HidingRegion) of the last rearrange decision

    def pop(self) -> np.ndarray:
        """The next queued action; remembers the pose the simulator predicted after it."""
        self.awaiting = self.expected.popleft() if self.expected else None
        self.last_kind = self.queue_kind or "search"
        return self.queue.popleft()

    def plans_inside(self, replan_inside: bool) -> bool:
        """With ``replan_inside``: whether "decide" has something to plan for (a target seen, or
        an object to rearrange), so it need not back out to search first."""
        return replan_inside and (self.known.target_id() is not None or self.known.knows_non_target())

    def drop_plan(self, closed: bool, replan_inside: bool) -> None:
        """The world no longer follows the queued plan: drop it and go back to the stage that
        plans it again (with the gripper closed, to the stage that plans with the object held)."""
        kind = self.queue_kind
        self.queue.clear()
        self.expected.clear()
        self.known.expect(None)
        self.replans += 1
        if kind in ("reach", "extract"):
            self.stage = "retrieve_extract" if closed else "retrieve_reach"
        elif kind == "rearrange_reach":
            self.stage = "rearrange_place" if closed else "rearrange_reach"
        elif kind == "place":
            self.stage = "rearrange_place" if closed else "move_out"
        elif kind == "move_out":
            self.stage = "decide" if self.plans_inside(replan_inside) else "move_out"
        logger.debug("the world left the %s plan at step %d: planning %s again", kind, self.step, self.stage)
