"""How the shelf world's fingers open, close and grasp (the gripper command of an action).

Closing fingers grasp the object that straddles the gripper axis between them (centred between
the fingers and held by the grasp joints, :mod:`occrl.envs.pymunk2d.joints`); other objects stop
the fingers at contact. Opening releases the held object; with ``PhysicsSettings.finger_contact``
the fingers stop where one first touches an object or a wall, and keep opening at later actions.
The geometry (which object is grasped, where fingers stop) is :mod:`occrl.envs.pymunk2d.fingers`'.
"""

from __future__ import annotations

import math

from occrl.envs import world_constants as C
from occrl.envs.geometry import transform_points
from occrl.envs.pymunk2d.body_properties import finger_vertices
from occrl.envs.pymunk2d.fingers import closing_stop, grasp_candidate, opening_until_contact
from occrl.envs.shelf_geometry import SHELF_WALLS, inverse_pose

__all__ = ["FingerActuation"]


class FingerActuation:
    """The finger part of :class:`~occrl.envs.ShelfWorld` (a base class of it): the gripper
    command's effect on the opening, the grasp and the finger shapes.

    It reads and sets the world's ``opening``, ``closed`` and ``held``, reads ``physics``,
    ``bodies`` and the poses (``gripper_pose()``, ``object_world_polygons()``,
    ``simulated_polygons()``), and moves the finger shapes (``gripper_shapes[1:3]``).

    Examples:
        >>> from occrl.envs import Scene, ShelfWorld
        >>> from occrl.envs import world_constants as C
        >>> world = ShelfWorld(Scene.sample(stage=1, seed=0))
        >>> world.opening == C.GRIPPER_STROKE, world.closed
        (True, False)
        >>> _ = world.step([0.0, 0.0, 0.0, 1.0])  # close on nothing: the fingers shut
        >>> world.closed, world.held, world.opening < C.GRIPPER_STROKE
        (True, None, True)
    """

    def _actuate_fingers(self, close: bool) -> None:
        if close and not self.closed:
            self.closed = True
            self._close_fingers()
        elif not close and self.closed:
            self.closed = False
            self.held = None
            if self.physics.finger_contact:
                self._open_fingers()
            else:
                self._set_opening(C.GRIPPER_STROKE)
        elif not close and self.physics.finger_contact and self.opening < C.GRIPPER_STROKE:
            self._open_fingers()  # fingers stopped by contact earlier keep opening

    def _open_fingers(self) -> None:
        """Open towards the full stroke, symmetrically; the fingers stop where one of them first
        touches an object or a wall (the simulated shapes), as they stop at contact when closing."""
        self._set_opening(opening_until_contact(self.gripper_pose(), self.opening, [*self.simulated_polygons(), *SHELF_WALLS]))

    def _centring_shift(self, i: int) -> float:
        """Sideways offset (gripper frame) that centres object ``i`` between the fingers."""
        local = transform_points(self.object_world_polygons()[i], inverse_pose(self.gripper_pose()))
        return -(local[:, 0].min() + local[:, 0].max()) / 2.0

    def _close_fingers(self) -> None:
        """Close until contact; grasp the object between the fingers if it straddles the axis."""
        gpose = self.gripper_pose()
        i, touching = grasp_candidate(gpose, self.opening, self.object_world_polygons())
        if i is not None:
            local = touching[i]
            xmin, xmax = local[:, 0].min(), local[:, 0].max()
            if not self.physics.finger_contact:  # occrl 0.1.0: the object jumps to the centre
                shift = -(xmin + xmax) / 2.0
                c, s = math.cos(gpose[2]), math.sin(gpose[2])
                body = self.bodies[i]
                body.position = (body.position.x + c * shift, body.position.y + s * shift)
            self._set_opening(xmax - xmin)
            self.held = i
            return
        self._set_opening(closing_stop(self.opening, touching))  # at the first contact, or closed on nothing

    def _set_opening(self, opening: float) -> None:
        self.opening = float(opening)
        # (the sign too: -0.0 gives fingers of other zero signs than 0.0)
        key = (self.opening, math.copysign(1.0, self.opening))
        if key == self._finger_opening:  # the fingers are there already (as set below)
            return
        fingers = finger_vertices(key)
        self.gripper_shapes[1].unsafe_set_vertices(fingers[0])
        self.gripper_shapes[2].unsafe_set_vertices(fingers[1])
        self._finger_opening = key
