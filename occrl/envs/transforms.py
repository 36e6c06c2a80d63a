"""TorchRL transforms from detections to the network's robot-centric image (DESIGN section 4).

``OcclusionRender`` draws the abstract observation in the shelf frame from the *detections* in
the tensordict; ``RobotCentricCrop`` cuts the window that moves and turns with the gripper out of
it and colours it; ``HeatmapTarget`` draws the true target footprint in the same window (a
privileged training label for the heat-map loss).
"""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Bounded, Composite
from torchrl.envs.transforms import Transform

from occrl.envs import world_constants as C
from occrl.envs.geometry import point_in_convex_polygon, transform_polygons
from occrl.envs.observation import crop_to_pixels, render_shelf_labels
from occrl.envs.perception import detected_polygons
from occrl.envs.palette import LABELS
from occrl.envs.render import DEFAULT_CANVAS, Canvas
from occrl.envs.robot_frame import DEFAULT_FORWARD_OFFSET, DEFAULT_SIZE, DEFAULT_WINDOW, robot_centric_pixels, robot_centric_points

__all__ = ["OcclusionRender", "RobotCentricCrop", "HeatmapTarget"]


def _flat(td: TensorDictBase) -> TensorDictBase:
    return td.reshape(-1) if td.batch_dims != 1 else td


def _fill_pixel_centres(image: np.ndarray, polygon_px: np.ndarray) -> None:
    """Set to 1 the pixels of ``image`` whose centres lie in a convex CCW polygon given in
    pixel (col, row) coordinates. Only the polygon's bounding box is tested."""
    h, w = image.shape
    c0, r0 = np.maximum(np.floor(polygon_px.min(0)).astype(int), 0)
    c1, r1 = np.minimum(np.ceil(polygon_px.max(0)).astype(int), [w - 1, h - 1])
    if c1 < c0 or r1 < r0:
        return
    cols, rows = np.meshgrid(np.arange(c0, c1 + 1), np.arange(r0, r1 + 1))
    pts = np.stack([cols, rows], -1).astype(float)
    # rows grow downwards, which mirrors the polygon: it is clockwise in (col, row)
    inside = point_in_convex_polygon(pts, polygon_px[::-1])
    image[r0 : r1 + 1, c0 : c1 + 1][inside] = 1.0


class _ObservationWriter(Transform):
    """Shared plumbing: compute on step and on reset, declare the written entry's spec."""

    def __init__(self, in_keys, out_key) -> None:
        super().__init__(in_keys=in_keys, out_keys=[out_key])

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        return self._call(tensordict_reset)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Apply to a tensordict outside an env (e.g. one built from real detections)."""
        return self._call(tensordict)

    def _out_spec(self, batch_shape: torch.Size):  # pragma: no cover - abstract
        raise NotImplementedError

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        observation_spec[self.out_keys[0]] = self._out_spec(observation_spec.shape)
        return observation_spec


class OcclusionRender(_ObservationWriter):
    """Render the abstract occlusion-aware image (paper Sec. IV-A) as a shelf-frame label map.

    Reads the gripper pose and opening and the detected objects (``("objects", ...)``), never
    ``"privileged"`` entries; writes ``out_key`` (default ``"shelf_labels"``), an (H, W) uint8
    map of the classes in :data:`occrl.envs.palette.LABELS`.

    Examples:
        >>> from torchrl.envs import TransformedEnv
        >>> from occrl.envs import ShelfEnv, OcclusionRender
        >>> env = TransformedEnv(ShelfEnv(batch_size=2, seed=0), OcclusionRender())
        >>> env.reset()["shelf_labels"].dtype
        torch.uint8
    """

    def __init__(self, canvas: Canvas = DEFAULT_CANVAS, fov: float = C.CAMERA_FOV, out_key="shelf_labels") -> None:
        super().__init__(in_keys=["gripper_pose", "gripper_opening", "objects", "target_type"], out_key=out_key)
        self.canvas = canvas
        self.fov = fov

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        flat = _flat(next_tensordict)
        poses = flat.get("gripper_pose").cpu().numpy()
        opening = flat.get("gripper_opening").cpu().numpy()
        labels = render_shelf_labels(poses, opening, detected_polygons(flat), self.canvas, self.fov)
        out = torch.from_numpy(labels).reshape(*next_tensordict.shape, *self.canvas.shape)
        next_tensordict.set(self.out_keys[0], out)
        return next_tensordict

    def _out_spec(self, batch_shape):
        return Bounded(0, len(LABELS) - 1, shape=(*batch_shape, *self.canvas.shape), dtype=torch.uint8)


class RobotCentricCrop(_ObservationWriter):
    """Cut the gripper-centred, gripper-aligned window out of a shelf-frame label map.

    The window (``window`` metres, ``size`` pixels a side) has the approach axis pointing up and
    its centre ``forward_offset`` ahead of the gripper. Labels are coloured with ``palette`` into a
    (3, size, size) float image in [0, 1] under ``out_key`` (default ``"pixels"``), the network
    input. The label map is removed unless ``keep_input`` (it is large).

    Examples:
        >>> from torchrl.envs import Compose, TransformedEnv
        >>> from occrl.envs import ShelfEnv, OcclusionRender, RobotCentricCrop
        >>> env = TransformedEnv(ShelfEnv(batch_size=2, seed=0), Compose(OcclusionRender(), RobotCentricCrop()))
        >>> env.reset()["pixels"].shape
        torch.Size([2, 3, 64, 64])
    """

    def __init__(
        self,
        window: float = DEFAULT_WINDOW,
        size: int = DEFAULT_SIZE,
        forward_offset: float = DEFAULT_FORWARD_OFFSET,
        in_key="shelf_labels",
        out_key="pixels",
        canvas: Canvas = DEFAULT_CANVAS,
        keep_input: bool = False,
    ) -> None:
        if size < 1 or window <= 0:
            raise ValueError(f"window must be > 0 m and size >= 1 pixel, got window={window}, size={size}")
        super().__init__(in_keys=[in_key, "gripper_pose"], out_key=out_key)
        self.window, self.size, self.forward_offset = float(window), int(size), float(forward_offset)
        self.canvas = canvas
        self.keep_input = keep_input

    def crop_labels(self, labels: np.ndarray, gripper_poses: np.ndarray) -> np.ndarray:
        """(B, H, W) shelf-frame labels -> (B, size, size) robot-centric labels."""
        pts = robot_centric_points(np.asarray(gripper_poses, dtype=np.float64), self.window, self.size, self.forward_offset)
        return self.canvas.lookup(labels, pts)

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        labels_t = next_tensordict.get(self.in_keys[0])
        lead = labels_t.shape[:-2]
        labels = labels_t.reshape(-1, *labels_t.shape[-2:]).numpy()
        poses = next_tensordict.get("gripper_pose").reshape(-1, 3).cpu().numpy()
        pixels = crop_to_pixels(labels, poses, self.window, self.size, self.forward_offset, self.canvas)
        next_tensordict.set(self.out_keys[0], pixels.reshape(*lead, 3, self.size, self.size))
        if not self.keep_input:
            next_tensordict.exclude(self.in_keys[0], inplace=True)
        return next_tensordict

    def _out_spec(self, batch_shape):
        return Bounded(0.0, 1.0, shape=(*batch_shape, 3, self.size, self.size), dtype=torch.float32)

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        observation_spec = super().transform_observation_spec(observation_spec)
        if not self.keep_input and self.in_keys[0] in observation_spec.keys(True):
            del observation_spec[self.in_keys[0]]
        return observation_spec


class HeatmapTarget(_ObservationWriter):
    """The heat-map label: the true target footprint in the robot-centric window, (1, S, S) in {0, 1}.

    Reads ``("privileged", ...)`` ground truth and writes ``("privileged", "heatmap_target")``;
    only losses read it.

    Examples:
        >>> from torchrl.envs import TransformedEnv
        >>> from occrl.envs import ShelfEnv, HeatmapTarget
        >>> env = TransformedEnv(ShelfEnv(batch_size=1, seed=0), HeatmapTarget())
        >>> env.reset()["privileged", "heatmap_target"].shape
        torch.Size([1, 1, 64, 64])
    """

    def __init__(
        self,
        window: float = DEFAULT_WINDOW,
        size: int = DEFAULT_SIZE,
        forward_offset: float = DEFAULT_FORWARD_OFFSET,
        out_key=("privileged", "heatmap_target"),
    ) -> None:
        super().__init__(in_keys=["gripper_pose", "privileged"], out_key=out_key)
        self.window, self.size, self.forward_offset = float(window), int(size), float(forward_offset)

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        flat = _flat(next_tensordict)
        gp = flat.get("gripper_pose").cpu().numpy().astype(np.float64)
        priv = flat.get("privileged")
        slot = priv.get("target_slot").cpu().numpy().reshape(-1)
        ar = np.arange(len(slot))
        verts = priv.get("object_vertices").cpu().numpy()[ar, slot].astype(np.float64)
        nv = priv.get("object_num_vertices").cpu().numpy()[ar, slot]
        world = transform_polygons(verts, priv.get("target_pose").cpu().numpy().astype(np.float64))
        pix = robot_centric_pixels(world, gp, self.window, self.size, self.forward_offset)
        heat = np.zeros((len(slot), 1, self.size, self.size), np.float32)
        for b in range(len(slot)):
            if nv[b] >= 3:
                _fill_pixel_centres(heat[b, 0], pix[b, : nv[b]])
        next_tensordict.set(self.out_keys[0], torch.from_numpy(heat).reshape(*next_tensordict.shape, 1, self.size, self.size))
        return next_tensordict

    def _out_spec(self, batch_shape):
        return Bounded(0.0, 1.0, shape=(*batch_shape, 1, self.size, self.size), dtype=torch.float32)
