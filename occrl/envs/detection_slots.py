"""Observation slots that stay with their objects: a perception system's detections, each in the
slot its object type was first given in the episode.

:func:`~occrl.envs.perception.observation_from_detections` packs the detections into the first
slots in the order given, so an object's slot would move whenever another one comes into or goes
out of view. The simulated envs keep object ``k`` in slot ``k``, and what reads slots across steps
(:class:`~occrl.envs.remembered.RememberedDetections`) relies on it. :class:`DetectionSlots` gives
each type a slot when it is first detected and keeps it for the episode; when all slots are taken,
a new type takes over the slot of the type detected longest ago among those not detected now.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from tensordict import TensorDict

from occrl.envs.observation import MAX_SLOTS, OBJECT_SLOT_KEYS
from occrl.envs.perception import observation_from_detections

__all__ = ["DetectionSlots"]


class DetectionSlots:
    """One episode's slot of each detected object type; call :meth:`reset` at each episode start.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.detection_slots import DetectionSlots
        >>> box = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]]
        >>> def seen(*types):
        ...     return [{"type_id": t, "pose": (0.1 * t, 0.2, 0.0), "vertices": box} for t in types]
        >>> slots = DetectionSlots()
        >>> def observe(*types):
        ...     td = slots.observation((0.0, -0.1, 0.0), 0.085, seen(*types), 1, np.array(box))
        ...     return td["objects", "type_id"][0].tolist()
        >>> observe(4, 7)
        [4, 7, 0, 0, 0, 0, 0, 0, 0, 0]
        >>> observe(2, 7)  # 7 keeps its slot; 2 takes the first free one
        [0, 7, 2, 0, 0, 0, 0, 0, 0, 0]
    """

    def __init__(self, num_slots: int = MAX_SLOTS) -> None:
        if isinstance(num_slots, bool) or not isinstance(num_slots, int) or not 1 <= num_slots <= MAX_SLOTS:
            raise ValueError(f"num_slots must be an int in [1, {MAX_SLOTS}] (the observation's slots), got {num_slots!r}")
        self.num_slots = num_slots
        self.slot_of: dict[int, int] = {}
        self._last_seen: dict[int, int] = {}
        self._frame = 0

    def reset(self) -> None:
        """Forget every type's slot (a new episode)."""
        self.slot_of.clear()
        self._last_seen.clear()
        self._frame = 0

    def slots(self, type_ids: Sequence[int]) -> list[int]:
        """The slot of each of the types detected now (distinct ids), given them on first sight."""
        if len(set(type_ids)) != len(type_ids) or len(type_ids) > self.num_slots:
            raise ValueError(f"at most {self.num_slots} distinct type ids fit the slots, got {list(type_ids)}")
        self._frame += 1
        now = set(type_ids)
        for t in type_ids:
            if t not in self.slot_of:
                taken = {s for u, s in self.slot_of.items()}
                free = [s for s in range(self.num_slots) if s not in taken]
                if free:
                    self.slot_of[t] = free[0]
                else:  # every slot taken: the type detected longest ago among those not seen now gives its up
                    old = min((u for u in self.slot_of if u not in now), key=lambda u: (self._last_seen[u], self.slot_of[u]))
                    self.slot_of[t] = self.slot_of.pop(old)
                    del self._last_seen[old]
            self._last_seen[t] = self._frame
        return [self.slot_of[t] for t in type_ids]

    def observation(
        self,
        gripper_pose: Sequence[float],
        gripper_opening: float,
        detections: Sequence[dict],
        target_type: int,
        target_vertices: np.ndarray,
        gripper_closed: bool = False,
    ) -> TensorDict:
        """:func:`~occrl.envs.perception.observation_from_detections` (the same checks and
        values) with each detection moved to its type's slot."""
        packed = observation_from_detections(gripper_pose, gripper_opening, detections, target_type, target_vertices, gripper_closed)
        slots = self.slots([int(d["type_id"]) for d in detections])
        objects = packed.get("objects")
        placed = objects.clone().zero_()
        n = len(slots)
        for key in OBJECT_SLOT_KEYS:
            placed.get(key)[0, slots] = objects.get(key)[0, :n]
        packed.set("objects", placed)
        return packed
