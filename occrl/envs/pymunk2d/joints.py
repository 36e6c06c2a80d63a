"""The shelf world's joints: the gripper's force-limited drive, each object's floor friction and
the grasp that holds an object between the fingers.

* Drive: a pivot and a gear joint from the kinematic control body to the gripper, limited to the
  gripper's speed, force and torque, so walls stop it and it pushes with bounded force.
* Floor friction: a pivot and a gear joint from the static body to each object, limited to
  ``mu * m * g`` and the matching torque (``floor_force``, ``floor_force * floor_arm``).
* Grasp: a pivot (weld) and a gear joint (lock) from the gripper to the held object.

Joint limits and error biases are set through Chipmunk's C API (the attribute setters are slow
in a hot loop): the same values pymunk's setters would set.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pymunk
from pymunk._chipmunk_cffi import lib as _cp

from occrl.envs import world_constants as C
from occrl.envs.pymunk2d.physics_settings import PhysicsSettings

__all__ = ["GRASP_ERROR_BIAS", "limited", "drive_and_floor_joints", "grasp_joints"]

# fraction of a grasp joint's error left after one second (1 - 1e-4 corrected in 0.5 s)
GRASP_ERROR_BIAS = 1e-8


def limited(constraint: pymunk.Constraint, max_bias: float, max_force: float) -> pymunk.Constraint:
    """Set a joint's limits through the C API (the attribute setters are slow in a hot loop).

    Examples:
        >>> import pymunk
        >>> from occrl.envs.pymunk2d.joints import limited
        >>> a, b = pymunk.Body(1.0, 1.0), pymunk.Body(1.0, 1.0)
        >>> joint = limited(pymunk.PivotJoint(a, b, (0, 0), (0, 0)), 0.5, 3.0)
        >>> joint.max_bias, joint.max_force
        (0.5, 3.0)
    """
    _cp.cpConstraintSetMaxBias(constraint._constraint, max_bias)
    _cp.cpConstraintSetMaxForce(constraint._constraint, max_force)
    return constraint


def drive_and_floor_joints(
    static: pymunk.Body,
    control: pymunk.Body,
    gripper: pymunk.Body,
    bodies: Sequence[pymunk.Body],
    floor_force: np.ndarray,
    floor_arm: np.ndarray,
    physics: PhysicsSettings,
) -> list[pymunk.Constraint]:
    """New joints: the gripper's drive (pivot, gear) and each object's floor friction (pivot,
    gear), in this order.

    Examples:
        >>> import numpy as np
        >>> import pymunk
        >>> from occrl.envs.pymunk2d import DEFAULT_PHYSICS
        >>> from occrl.envs.pymunk2d.joints import drive_and_floor_joints
        >>> space, bodies = pymunk.Space(), [pymunk.Body(1.0, 1.0) for _ in range(3)]
        >>> joints = drive_and_floor_joints(space.static_body, *bodies[:2], bodies[2:], np.array([0.5]), np.array([0.1]), DEFAULT_PHYSICS)
        >>> [type(j).__name__ for j in joints], joints[2].max_force
        (['PivotJoint', 'GearJoint', 'PivotJoint', 'GearJoint'], 0.5)
    """
    drive = limited(pymunk.PivotJoint(control, gripper, (0, 0), (0, 0)), physics.gripper_max_speed, physics.gripper_max_force)
    turn = limited(pymunk.GearJoint(control, gripper, 0.0, 1.0), 10 * physics.gripper_max_speed, physics.gripper_max_torque)
    cons = [drive, turn]
    for i, body in enumerate(bodies):
        force = float(floor_force[i])
        cons.append(limited(pymunk.PivotJoint(static, body, (0, 0), (0, 0)), 0.0, force))
        cons.append(limited(pymunk.GearJoint(static, body, 0.0, 1.0), 0.0, force * float(floor_arm[i])))
    return cons


def grasp_joints(gripper: pymunk.Body, body: pymunk.Body, anchor, physics: PhysicsSettings) -> list[pymunk.Constraint]:
    """The grasp of ``body``: a weld at ``anchor`` (gripper frame) and a lock of their relative
    angle. With ``physics.finger_contact`` both correct their error within an action
    (:data:`GRASP_ERROR_BIAS`; pymunk's default corrects 96 % in 0.5 s); their force is limited to
    ``physics.grasp_max_force`` (and its torque over a finger's length) unless that is infinite.

    Examples:
        >>> import pymunk
        >>> from occrl.envs.pymunk2d import DEFAULT_PHYSICS
        >>> from occrl.envs.pymunk2d.joints import grasp_joints
        >>> weld, lock = grasp_joints(pymunk.Body(1.0, 1.0), pymunk.Body(1.0, 1.0), (0.0, 0.1), DEFAULT_PHYSICS)
        >>> type(weld).__name__, type(lock).__name__
        ('PivotJoint', 'GearJoint')
    """
    weld = pymunk.PivotJoint(gripper, body, anchor, (0, 0))
    lock = pymunk.GearJoint(gripper, body, body.angle - gripper.angle, 1.0)
    if physics.finger_contact:  # centre within the action
        _cp.cpConstraintSetErrorBias(weld._constraint, GRASP_ERROR_BIAS)
        _cp.cpConstraintSetErrorBias(lock._constraint, GRASP_ERROR_BIAS)
    if physics.grasp_max_force != math.inf:
        _cp.cpConstraintSetMaxForce(weld._constraint, physics.grasp_max_force)
        _cp.cpConstraintSetMaxForce(lock._constraint, physics.grasp_max_force * C.FINGER_LENGTH)
    return [weld, lock]
