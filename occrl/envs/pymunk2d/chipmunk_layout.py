"""Guarded access to Chipmunk's C structs: a layout check run once, with a fallback when it fails.

pymunk's cffi module treats Chipmunk's structs as opaque, so :mod:`occrl.envs.pymunk2d.joint_reset`
and :mod:`occrl.envs.pymunk2d.contact_list` read and write fields at the byte offsets of
chipmunk_structs.h (64-bit). Each confirms its offsets on a probe space against the C API before
the worlds use them; :func:`layout_confirmed` runs such a probe: on a 64-bit build with 8-byte
doubles only, any exception counts as a mismatch, and a mismatch is logged with what the world
does instead (the same results, more slowly).

Examples:
    >>> from occrl.envs.pymunk2d.chipmunk_layout import layout_confirmed
    >>> layout_confirmed(lambda: True, "unused")
    True
    >>> layout_confirmed(lambda: 1 / 0, "the slower path")  # a probe that fails counts as a mismatch
    False
"""

from __future__ import annotations

import logging
import struct
from typing import Callable

from pymunk._chipmunk_cffi import ffi

__all__ = ["layout_confirmed"]

logger = logging.getLogger(__name__)


def layout_confirmed(probe: Callable[[], bool], fallback: str) -> bool:
    """Whether ``probe`` confirms a struct layout on this build (64-bit, 8-byte doubles, the probe
    returns True without raising); otherwise logs ``fallback`` (what the worlds do instead)."""
    confirmed = False
    if ffi.sizeof("void *") == 8 and struct.calcsize("d") == 8:
        try:
            confirmed = bool(probe())
        except Exception:  # noqa: BLE001 - any failure of the probe means: take the fallback
            confirmed = False
    if not confirmed:
        logger.info("Chipmunk's struct layout is not the one expected: %s (slower, same results)", fallback)
    return confirmed
