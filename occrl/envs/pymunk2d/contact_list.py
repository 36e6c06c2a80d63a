"""Whether a Chipmunk body touches anything, read from the head of the body's arbiter list.

The world asks at every physics substep whether the gripper touches anything (it then steps in
finer substeps: :class:`occrl.envs.pymunk2d.world.ShelfWorld`). pymunk's
``Body.each_arbiter`` answers through a cffi callback that wraps every arbiter in a Python
object. Chipmunk keeps a body's arbiters in a linked list whose head (``arbiterList``) is NULL
exactly when ``cpBodyEachArbiter`` visits nothing; this module reads that head at its byte offset
in Chipmunk's struct layout (chipmunk_structs.h, 64-bit), as
:mod:`occrl.envs.pymunk2d.joint_reset` does for joint impulses.

The layout is checked once, on a probe space, against the C API (the body's position, angle,
user data and space read back at their offsets, and the head against ``each_arbiter`` with a
body touching a wall and away from it). :data:`AVAILABLE` is False when any check fails; the
world then asks ``each_arbiter`` as before.

Examples:
    >>> import pymunk
    >>> from occrl.envs.pymunk2d import contact_list
    >>> space = pymunk.Space()
    >>> wall = pymunk.Segment(space.static_body, (-1, 0), (1, 0), 0.05)
    >>> body = pymunk.Body(1.0, 1.0)
    >>> body.position = (0.0, 0.05)
    >>> space.add(wall, body, pymunk.Circle(body, 0.1))
    >>> space.step(0.01)
    >>> head = contact_list.arbiter_head(body)
    >>> contact_list.AVAILABLE, contact_list.has_arbiters(head)
    (True, True)
"""

from __future__ import annotations

import pymunk
from pymunk._chipmunk_cffi import ffi, lib

from occrl.envs.pymunk2d.chipmunk_layout import layout_confirmed

__all__ = ["AVAILABLE", "NULL", "arbiter_head", "has_arbiters"]

# struct cpBody: velocity_func, position_func (pointers), m, m_inv, i, i_inv, cog (cpVect),
# p, v, f (cpVect), a, w, t, transform (6 cpFloat), userData, v_bias (cpVect), w_bias, space,
# shapeList, arbiterList, constraintList, sleeping
_BODY_P = 64
_BODY_A = 112
_BODY_USER_DATA = 184
_BODY_SPACE = 216
_BODY_ARBITER_LIST = 232


#: What an :func:`arbiter_head` holds when its body has no arbiter: ``head[0] != NULL`` is
#: :func:`has_arbiters` inlined, for loops that cannot afford the call.
NULL: object = ffi.NULL


def arbiter_head(body: pymunk.Body):
    """A cffi pointer to ``body``'s arbiter-list head (valid while the body lives), for
    :func:`has_arbiters`."""
    return ffi.cast("void **", ffi.cast("char *", body._body) + _BODY_ARBITER_LIST)


def has_arbiters(head) -> bool:
    """Whether the body of this :func:`arbiter_head` has any arbiter (touches a shape): what
    ``bool(list of body.each_arbiter)`` says."""
    return head[0] != ffi.NULL


def _each_arbiter_count(body: pymunk.Body) -> int:
    seen: list = []
    body.each_arbiter(seen.append)
    return len(seen)


def _layout_holds() -> bool:
    """Whether the struct offsets above are those of the loaded Chipmunk (see the module doc)."""
    space = pymunk.Space()
    wall = pymunk.Segment(space.static_body, (-1.0, 0.0), (1.0, 0.0), 0.05)
    body = pymunk.Body(1.0, 1.0)
    body.position, body.angle = (0.25, 0.125), 0.375
    space.add(wall, body, pymunk.Circle(body, 0.1))
    base = ffi.cast("char *", body._body)
    p = ffi.cast("double *", base + _BODY_P)
    if (p[0], p[1], ffi.cast("double *", base + _BODY_A)[0]) != (0.25, 0.125, 0.375):
        return False
    lib.cpBodySetUserData(body._body, ffi.cast("void *", 0x5A5A))
    if ffi.cast("void **", base + _BODY_USER_DATA)[0] != ffi.cast("void *", 0x5A5A):
        return False
    if ffi.cast("void **", base + _BODY_SPACE)[0] != lib.cpBodyGetSpace(body._body):
        return False
    head = arbiter_head(body)
    if has_arbiters(head) or _each_arbiter_count(body):  # no step yet: no arbiter
        return False
    space.step(0.01)  # the circle overlaps the wall
    if not (has_arbiters(head) and _each_arbiter_count(body) > 0):
        return False
    body.position = (0.25, 5.0)
    space.step(0.01)  # away from the wall
    return not has_arbiters(head) and _each_arbiter_count(body) == 0


#: Whether the body layout was confirmed on this pymunk build (:func:`arbiter_head` and
#: :func:`has_arbiters` may be used); False: the worlds ask ``Body.each_arbiter``.
AVAILABLE: bool = layout_confirmed(_layout_holds, "worlds ask each_arbiter for contacts")
