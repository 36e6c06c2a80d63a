"""MuJoCo for the shelf envs: importing the optional extra, offscreen rendering and the gripper
camera's pixel geometry (DESIGN section 10).

mujoco and dm_control are optional (``pip install -e ".[mujoco]"``): they are imported only by
:func:`require_mujoco`, so importing this module (or :mod:`occrl.envs`) never needs them.

Visibility of an object = (pixels whose first hit is the object) / (pixels the object would cover
with nothing else in the world). The numerator comes from a segmentation render (needs an OpenGL
backend) or from ``mujoco.mj_multiRay`` through the same pixel centres (no GL). The denominator
is exact and shared by both: the object's prism is clipped at the near plane and projected, and
the pixel centres inside the projection are counted row by row on the camera's rows extended
without bound sideways. So an object half out of the field of view to the side is 50 % visible,
as in the 2D model, while a tall object close to the camera is not penalised for reaching above
and below the image (the 2D model has no vertical field of view).

OpenGL: mujoco picks its GL context class when first imported (torchrl imports it early) from
``MUJOCO_GL``; unset, that is GLFW, which needs a display. :func:`gl_available` probes the
backends (the configured one, then headless EGL and OSMesa when ``MUJOCO_GL`` is unset) once.
"""

from __future__ import annotations

import atexit
import math
import os
import sys
import weakref
from dataclasses import dataclass

import numpy as np

from occrl.envs import world_constants as C
from occrl.envs.geometry import convex_hull, polygon_area

__all__ = [
    "MUJOCO_EXTRA",
    "require_mujoco",
    "gl_available",
    "new_renderer",
    "close_renderer",
    "RendererOwner",
    "CameraConfig",
    "NEAR",
    "VISIBLE_GROUPS",
    "prism_pixel_counts",
]

MUJOCO_EXTRA = 'pip install -e ".[mujoco]"'
NEAR = 0.002  # camera near plane (m)
# geom groups: 0 shelf, 1 objects, 2 gripper; the camera's visibility ignores the gripper (as in 2D)
VISIBLE_GROUPS = np.array([1, 1, 0, 0, 0, 0], dtype=np.uint8)

_mujoco = None
_mjcf = None
_live_renderers: "weakref.WeakSet" = weakref.WeakSet()
_GL_PROBE: tuple[bool, str] | None = None
_GL_CONTEXT = None


def require_mujoco():
    """Import ``mujoco`` and ``dm_control.mjcf`` or raise an ``ImportError`` naming the extra.

    Examples:
        >>> from occrl.envs.mujoco3d.camera import require_mujoco
        >>> mujoco, mjcf = require_mujoco()
        >>> mujoco.__name__, mjcf.__name__
        ('mujoco', 'dm_control.mjcf')
    """
    global _mujoco, _mjcf
    if _mujoco is not None:
        return _mujoco, _mjcf
    try:
        import mujoco
        from dm_control import mjcf
    except ImportError as e:
        raise ImportError(
            f"MujocoShelfEnv needs the optional MuJoCo backend (mujoco 3.17 and dm_control 1.0.50), "
            f"which could not be imported ({e}). Install it with: {MUJOCO_EXTRA}"
        ) from e
    _mujoco, _mjcf = mujoco, mjcf
    return mujoco, mjcf


def close_renderer(renderer) -> None:
    """Free a renderer's GL objects in its *own* context. (``mujoco.Renderer.close`` frees them in
    whatever context is current, which deletes another live renderer's framebuffer.)"""
    ctx = getattr(renderer, "_gl_context", None)
    if ctx is not None:
        ctx.make_current()
    renderer.close()
    _live_renderers.discard(renderer)


class RendererOwner:
    """A holder of one offscreen renderer (``self.renderer``, None when it has none): :meth:`close`
    frees it, and so does garbage collection."""

    renderer = None

    def close(self) -> None:
        """Free the renderer (also done when the holder is garbage collected)."""
        if getattr(self, "renderer", None) is not None:
            close_renderer(self.renderer)
            self.renderer = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # pragma: no cover - interpreter teardown
            pass


def _close_renderers() -> None:
    for r in list(_live_renderers):
        try:
            close_renderer(r)
        except Exception:  # pragma: no cover - interpreter teardown
            pass


def _context_candidates():
    """(name, GL context class) pairs to try, best first. mujoco picks its context class when it
    is first imported (torchrl imports it early), from ``MUJOCO_GL``; with ``MUJOCO_GL`` unset
    that is GLFW, which needs a display. Headless Linux then falls back to EGL, then OSMesa."""
    from mujoco.rendering.classic import gl_context as glc

    explicit = os.environ.get("MUJOCO_GL", "").strip().lower()
    linux = sys.platform.startswith("linux")
    display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    if explicit or not linux or display:
        yield f"MUJOCO_GL={explicit or '(unset)'}", getattr(glc, "GLContext", None)
    if not explicit and linux:
        for name in ("egl", "osmesa"):
            try:
                module = __import__(f"mujoco.{name}", fromlist=["GLContext"])
            except Exception:  # missing library or a PyOpenGL platform already fixed to another one
                continue
            yield f"{name} (MUJOCO_GL unset, no display)", module.GLContext


def gl_available() -> tuple[bool, str]:
    """Whether MuJoCo can render offscreen here, and the backend or the reason why not (cached)."""
    global _GL_PROBE, _GL_CONTEXT
    if _GL_PROBE is None:
        mujoco, _ = require_mujoco()
        model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='0.1'/></worldbody></mujoco>")
        errors = []
        for name, cls in _context_candidates():
            if cls is None:
                errors.append(f"{name}: no GL context class")
                continue
            try:
                r = _renderer_with(cls, model, 8, 8)
                r.update_scene(mujoco.MjData(model))
                r.render()
                close_renderer(r)
            except Exception as e:  # FatalError, ImportError, RuntimeError, EGLError ...
                errors.append(f"{name}: {type(e).__name__}: {e}".strip())
                continue
            _GL_PROBE, _GL_CONTEXT = (True, name), cls
            # atexit runs last-registered first: free our contexts before the GL module tears down
            atexit.register(_close_renderers)
            break
        else:
            _GL_PROBE = (False, "; ".join(errors) or "no OpenGL backend")
    return _GL_PROBE


def _renderer_with(cls, model, height: int, width: int):
    """``mujoco.Renderer`` on a given GL context class (it reads the module attribute)."""
    mujoco, _ = require_mujoco()
    from mujoco.rendering.classic import gl_context as glc

    old = getattr(glc, "GLContext", None)
    glc.GLContext = cls
    try:
        return mujoco.Renderer(model, height, width)
    finally:
        glc.GLContext = old


def new_renderer(model, height: int, width: int):
    """An offscreen renderer on the backend :func:`gl_available` found (RuntimeError if none)."""
    ok, why = gl_available()
    if not ok:
        raise RuntimeError(
            f"no OpenGL backend for MuJoCo rendering ({why}); on a headless Linux machine install EGL "
            f"(libegl1) or OSMesa, or set MUJOCO_GL before anything imports mujoco"
        )
    r = _renderer_with(_GL_CONTEXT, model, height, width)
    _live_renderers.add(r)
    return r


@dataclass(frozen=True)
class CameraConfig:
    """The gripper camera: image size and horizontal field of view.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.mujoco3d.camera import CameraConfig
        >>> camera = CameraConfig()  # 160 x 120 pixels, 70 degrees across
        >>> round(camera.fovy_degrees, 1), camera.ray_directions().shape
        (55.4, (19200, 3))
        >>> camera.pixel_u(np.array([0, camera.width - 1])).round(3).tolist()  # tangents of the edge columns
        [-0.696, 0.696]
    """

    height: int = 120
    width: int = 160
    fov: float = C.CAMERA_FOV

    @property
    def tan_x(self) -> float:
        return math.tan(self.fov / 2)

    @property
    def tan_y(self) -> float:
        return self.tan_x * self.height / self.width

    @property
    def fovy_degrees(self) -> float:
        return math.degrees(2 * math.atan(self.tan_y))

    def pixel_u(self, cols: np.ndarray) -> np.ndarray:
        """Tangent of the horizontal angle (right positive) of pixel-centre columns."""
        return (2.0 * (np.asarray(cols, float) + 0.5) / self.width - 1.0) * self.tan_x

    def pixel_v(self, rows: np.ndarray) -> np.ndarray:
        """Tangent of the vertical angle (up positive) of pixel-centre rows (row 0 at the top)."""
        return (1.0 - 2.0 * (np.asarray(rows, float) + 0.5) / self.height) * self.tan_y

    def ray_directions(self) -> np.ndarray:
        """(H*W, 3) unit directions of the pixel centres in the camera frame (looks along -z)."""
        u = self.pixel_u(np.arange(self.width))
        v = self.pixel_v(np.arange(self.height))
        uu, vv = np.meshgrid(u, v)
        d = np.stack([uu, vv, -np.ones_like(uu)], -1).reshape(-1, 3)
        return d / np.linalg.norm(d, axis=1, keepdims=True)


def prism_pixel_counts(prism: np.ndarray, camera: CameraConfig) -> tuple[int, int]:
    """Pixel centres a prism covers alone: on the camera's rows extended sideways without bound
    (the visibility denominator), and within the image. ``prism``: its 2n vertices in the camera
    frame (x right, y up, looking along -z), bottom ring then top ring.

    Examples:
        >>> import numpy as np
        >>> from occrl.envs.mujoco3d.camera import CameraConfig, prism_pixel_counts
        >>> ring = np.array([[-0.02, -0.02, -0.22], [0.02, -0.02, -0.22], [0.02, -0.02, -0.18], [-0.02, -0.02, -0.18]])
        >>> cube = np.concatenate([ring, ring + [0.0, 0.04, 0.0]])  # a 4 cm cube 20 cm ahead of the camera
        >>> camera = CameraConfig(height=12, width=16)
        >>> prism_pixel_counts(cube, camera)  # all its pixels are in the image
        (4, 4)
        >>> prism_pixel_counts(cube + [0.3, 0.0, 0.0], camera)  # moved out of view to the right
        (10, 0)
    """
    poly = _projected_polygon(prism, len(prism) // 2)
    if poly is None:
        return 0, 0
    lo, hi = _row_intervals(poly, camera.pixel_v(np.arange(camera.height)))
    # pixel-centre columns c with u_c = (2 (c + 0.5) / W - 1) tan_x in [lo, hi]
    s = camera.width / (2 * camera.tan_x)
    with np.errstate(invalid="ignore"):
        c_lo = np.ceil((lo * s + camera.width / 2 - 0.5) - 1e-9)
        c_hi = np.floor((hi * s + camera.width / 2 - 0.5) + 1e-9)
    ok = np.isfinite(c_lo) & np.isfinite(c_hi)
    total = np.maximum(c_hi - c_lo + 1, 0)[ok].sum()
    inside = np.maximum(np.minimum(c_hi, camera.width - 1) - np.maximum(c_lo, 0) + 1, 0)[ok].sum()
    return int(total), int(inside)


def _projected_polygon(pc: np.ndarray, n: int) -> np.ndarray | None:
    """Convex polygon (tangent coordinates u right, v up) of a prism given by its 2n vertices in the
    camera frame (bottom ring then top ring), clipped at the near plane; None if wholly behind."""
    depth = -pc[:, 2]
    ring = np.arange(n)
    edges = np.concatenate([np.c_[ring, (ring + 1) % n], np.c_[ring + n, (ring + 1) % n + n], np.c_[ring, ring + n]])
    pts = [pc[depth >= NEAR]]
    da, db = depth[edges[:, 0]], depth[edges[:, 1]]
    cross = (da - NEAR) * (db - NEAR) < 0
    if cross.any():
        a, b = pc[edges[cross, 0]], pc[edges[cross, 1]]
        t = ((da[cross] - NEAR) / (da[cross] - db[cross]))[:, None]
        pts.append(a + t * (b - a))
    p = np.concatenate(pts)
    if len(p) < 3:
        return None
    uv = p[:, :2] / (-p[:, 2:3])
    hull = convex_hull(uv)
    if len(hull) < 3 or polygon_area(hull) <= 0:
        return None
    return hull


def _row_intervals(poly: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each horizontal line v, the [lo, hi] u-interval of a convex polygon (NaN if missed)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    va, vb = a[:, 1][None], b[:, 1][None]
    vv = v[:, None]
    span = (np.minimum(va, vb) <= vv) & (vv <= np.maximum(va, vb)) & (va != vb)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (vv - va) / (vb - va)
    u = a[:, 0][None] + t * (b[:, 0] - a[:, 0])[None]
    lo = np.where(span, u, np.inf).min(1)
    hi = np.where(span, u, -np.inf).max(1)
    hit = np.isfinite(lo) & np.isfinite(hi)
    return np.where(hit, lo, np.nan), np.where(hit, hi, np.nan)
