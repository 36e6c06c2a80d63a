"""Zero a Chipmunk joint's accumulated impulse, so that a kept joint acts as a new one.

Chipmunk warm-starts every joint from the impulse it accumulated in its last step (``jAcc``);
the world's cold start (:class:`occrl.envs.pymunk2d.world.ShelfWorld`) wants each action to be a
function of the snapshot alone, which a new joint gives. pymunk offers no setter for ``jAcc``
and its C structs are opaque to its cffi module, so a new joint used to be built for every
joint at every action (the physics of a 4x4 planner decision took 15.4 ms with new joints and
11.4 ms with kept ones: docs/lab/speed.md, *Planning and evaluation*). This module writes the
impulse in place instead, at the byte offsets of Chipmunk's struct layout (chipmunk_structs.h,
64-bit): the pivot joint's ``jAcc`` vector and the gear joint's ``jAcc`` scalar.

The layout is checked once, on a probe space, against what the C API reads back (the
constraint's limits, the pivot's anchors, the gear's phase and ratio, and the joint's impulse
before and after zeroing). :data:`AVAILABLE` is False when any check fails (another pymunk or
Chipmunk build, a 32-bit platform); the world then builds new joints as before.

Examples:
    >>> import pymunk
    >>> from occrl.envs.pymunk2d import joint_reset
    >>> space = pymunk.Space()
    >>> body = pymunk.Body(1.0, 1.0)
    >>> body.velocity = (1.0, 0.0)
    >>> joint = pymunk.PivotJoint(space.static_body, body, (0, 0), (0, 0))
    >>> joint.max_bias = 0.0
    >>> space.add(body, joint)
    >>> space.step(0.01)
    >>> joint_reset.AVAILABLE, joint.impulse > 0
    (True, True)
    >>> joint_reset.zero_pivot(joint); joint.impulse
    0.0
"""

from __future__ import annotations

import math

import pymunk
from pymunk._chipmunk_cffi import ffi, lib

from occrl.envs.pymunk2d.chipmunk_layout import layout_confirmed

__all__ = ["AVAILABLE", "zero_pivot", "zero_gear", "ImpulseSlots"]

# struct cpConstraint: klass, space, a, b, next_a, next_b (6 pointers), then maxForce, errorBias,
# maxBias, collideBodies (padded), preSolve, postSolve, userData: 104 bytes on 64-bit
_MAX_FORCE = 48
_MAX_BIAS = 64
_CONSTRAINT_SIZE = 104
# struct cpPivotJoint: constraint, anchorA, anchorB, r1, r2 (cpVect), k (cpMat2x2), jAcc, bias
_PIVOT_ANCHOR_A = _CONSTRAINT_SIZE
_PIVOT_JACC = _CONSTRAINT_SIZE + 4 * 16 + 32
# struct cpGearJoint: constraint, phase, ratio, ratio_inv, iSum, bias, jAcc (cpFloat)
_GEAR_PHASE = _CONSTRAINT_SIZE
_GEAR_JACC = _CONSTRAINT_SIZE + 5 * 8


def _doubles(constraint: pymunk.Constraint, offset: int, count: int):
    return list(ffi.cast("double *", ffi.cast("char *", constraint._constraint) + offset)[0:count])


def _write(constraint: pymunk.Constraint, offset: int, count: int) -> None:
    pointer = ffi.cast("double *", ffi.cast("char *", constraint._constraint) + offset)
    for k in range(count):
        pointer[k] = 0.0


def zero_pivot(joint: pymunk.PivotJoint) -> None:
    """Set a pivot joint's accumulated impulse to zero (as a new joint's)."""
    _write(joint, _PIVOT_JACC, 2)


def zero_gear(joint: pymunk.GearJoint) -> None:
    """Set a gear joint's accumulated impulse to zero (as a new joint's)."""
    _write(joint, _GEAR_JACC, 1)


class ImpulseSlots:
    """The accumulated impulses of joints kept over many actions, located once: :meth:`zero`
    clears them all as :func:`zero_pivot` / :func:`zero_gear` would, without casting each
    joint's pointer again at every action. The joints must outlive this object (it points into
    their C structs).

    Examples:
        >>> import pymunk
        >>> from occrl.envs.pymunk2d.joint_reset import ImpulseSlots
        >>> space = pymunk.Space()
        >>> body = pymunk.Body(1.0, 1.0)
        >>> body.velocity, body.angular_velocity = (1.0, 0.0), 1.0
        >>> pivot = pymunk.PivotJoint(space.static_body, body, (0, 0), (0, 0))
        >>> gear = pymunk.GearJoint(space.static_body, body, 0.0, 1.0)
        >>> pivot.max_bias = gear.max_bias = 0.0
        >>> space.add(body, pivot, gear)
        >>> space.step(0.01)
        >>> slots = ImpulseSlots(pivots=[pivot], gears=[gear])
        >>> slots.zero(); pivot.impulse, gear.impulse
        (0.0, 0.0)
    """

    def __init__(self, pivots: list[pymunk.PivotJoint], gears: list[pymunk.GearJoint]) -> None:
        self._pivot_slots = [_pointer(joint, _PIVOT_JACC) for joint in pivots]  # two doubles each (a vector)
        self._gear_slots = [_pointer(joint, _GEAR_JACC) for joint in gears]  # one double each

    def zero(self) -> None:
        """Set every slot's accumulated impulse to zero (as a new joint's)."""
        for pointer in self._pivot_slots:
            pointer[0] = pointer[1] = 0.0
        for pointer in self._gear_slots:
            pointer[0] = 0.0


def _pointer(constraint: pymunk.Constraint, offset: int):
    return ffi.cast("double *", ffi.cast("char *", constraint._constraint) + offset)


def _layout_holds() -> bool:
    """Whether the struct offsets above are those of the loaded Chipmunk (see the module doc)."""
    space = pymunk.Space()
    body = pymunk.Body(1.0, 2.0)
    body.velocity, body.angular_velocity = (1.0, -0.5), 0.75
    pivot = pymunk.PivotJoint(space.static_body, body, (0.25, -0.125), (0.0, 0.0))
    gear = pymunk.GearJoint(space.static_body, body, 0.375, 1.5)
    for joint, force in ((pivot, 0.5), (gear, 0.25)):
        lib.cpConstraintSetMaxBias(joint._constraint, 0.0)
        lib.cpConstraintSetMaxForce(joint._constraint, force)
    space.add(body, pivot, gear)
    if _doubles(pivot, _MAX_FORCE, 1) != [0.5] or _doubles(gear, _MAX_BIAS, 1) != [0.0]:
        return False
    if _doubles(pivot, _PIVOT_ANCHOR_A, 2) != [0.25, -0.125] or _doubles(gear, _GEAR_PHASE, 2) != [0.375, 1.5]:
        return False
    space.step(0.01)
    jx, jy = _doubles(pivot, _PIVOT_JACC, 2)
    (jg,) = _doubles(gear, _GEAR_JACC, 1)
    if not (pivot.impulse > 0 and gear.impulse > 0):
        return False
    if math.hypot(jx, jy) != pivot.impulse or abs(jg) != gear.impulse:
        return False
    zero_pivot(pivot)
    zero_gear(gear)
    return pivot.impulse == 0.0 and gear.impulse == 0.0


#: Whether the struct layout was confirmed on this pymunk build (:func:`zero_pivot` and
#: :func:`zero_gear` may be used); False: the worlds build new joints at every action.
AVAILABLE: bool = layout_confirmed(_layout_holds, "worlds build new joints at every action")
