"""Pictures of episodes: the true scene beside the network's abstract observation, per step.

``episode_frames`` turns a rollout tensordict (from the standard pipeline, which keeps
``"pixels"``) into RGB frames; ``save_gif`` and ``save_film_strip`` write them.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Sequence

import numpy as np
from PIL import Image, ImageDraw
from tensordict import TensorDictBase

from occrl.envs.perception import _world_vertices
from occrl.envs.render import SHELF_VIEW, labels_to_rgb, render_true_scene

__all__ = ["episode_frames", "frame", "save_gif", "save_film_strip"]

logger = logging.getLogger(__name__)

PANEL = 256  # pixels per panel side


def _true_panel(step: TensorDictBase) -> np.ndarray:
    priv = step.get("privileged")
    present = priv.get("object_present").numpy()
    verts = priv.get("object_vertices").numpy().astype(float)
    poses = priv.get("object_pose").numpy().astype(float)
    nv = priv.get("object_num_vertices").numpy()
    slot = int(priv.get("target_slot").reshape(-1)[0])
    world = _world_vertices(verts, poses)
    idx = np.flatnonzero(present)
    labels = render_true_scene(
        step.get("gripper_pose").numpy().astype(float),
        float(step.get("gripper_opening").reshape(-1)[0]),
        [world[k, : nv[k]] for k in idx],
        [k == slot for k in idx],
        SHELF_VIEW,
    )
    img = Image.fromarray(labels_to_rgb(labels)).resize((PANEL, int(PANEL * labels.shape[0] / labels.shape[1])), Image.BILINEAR)
    return np.asarray(img)


def _obs_panel(step: TensorDictBase, heatmap: np.ndarray | None = None) -> np.ndarray:
    pix = (step.get("pixels").permute(1, 2, 0).numpy() * 255).astype(np.uint8)
    img = Image.fromarray(pix).resize((PANEL, PANEL), Image.NEAREST)
    if heatmap is not None:
        # contour-like overlay: tint pixels by predicted likelihood
        hm = Image.fromarray((np.clip(heatmap, 0, 1) * 255).astype(np.uint8)).resize((PANEL, PANEL), Image.BILINEAR)
        hm = np.asarray(hm).astype(float) / 255.0
        arr = np.asarray(img).astype(float)
        band = (np.abs(hm - 0.25) < 0.03) | (np.abs(hm - 0.5) < 0.03) | (np.abs(hm - 0.75) < 0.03)
        arr[band] = [255, 0, 255]
        img = Image.fromarray(arr.astype(np.uint8))
    return np.asarray(img)


def frame(step: TensorDictBase, caption: str = "", heatmap: np.ndarray | None = None) -> np.ndarray:
    """One picture of one step (a tensordict with no batch dims): true scene | observation."""
    left = _true_panel(step)
    right = _obs_panel(step, heatmap)
    h = max(left.shape[0], right.shape[0]) + 18
    out = np.full((h, left.shape[1] + right.shape[1] + 6, 3), 255, np.uint8)
    out[18 : 18 + left.shape[0], : left.shape[1]] = left
    out[18 : 18 + right.shape[0], left.shape[1] + 6 :] = right
    img = Image.fromarray(out)
    ImageDraw.Draw(img).text((4, 3), caption, fill=(0, 0, 0))
    return np.asarray(img)


def episode_frames(rollout: TensorDictBase, heatmaps: Sequence[np.ndarray] | None = None) -> list[np.ndarray]:
    """Frames of a single-episode rollout (batch dims [T]); the last frame shows the final state."""
    if rollout.batch_dims != 1:
        raise ValueError(f"expected one episode with batch dims [T], got batch size {tuple(rollout.batch_size)}")
    frames = []
    T = rollout.shape[0]
    for t in range(T):
        step = rollout[t]
        a = step.get("action").numpy()
        cap = f"step {t}  action fwd {a[0]:+.2f} lat {a[1]:+.2f} rot {a[2]:+.2f} grip {'close' if a[3] > 0 else 'open'}"
        frames.append(frame(step, cap, None if heatmaps is None else heatmaps[t]))
    last = rollout[T - 1].get("next")
    end = "success" if bool(last.get("success").any()) else ("dropped an object" if bool(last.get("dropped").any()) else "not retrieved")
    frames.append(frame(last, f"after {T} actions: {end}"))
    return frames


def save_gif(frames: Sequence[np.ndarray], path: str | Path, fps: float = 4.0) -> Path:
    import imageio.v2 as imageio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(path, list(frames), duration=1.0 / fps, loop=0)
    logger.info("wrote %s (%d frames)", path, len(frames))
    return path


def save_film_strip(frames: Sequence[np.ndarray], path: str | Path, columns: int = 4, max_frames: int = 12) -> Path:
    """A grid of evenly spaced frames (first and last always included) as one PNG."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n = len(frames)
    idx = sorted(set(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int).tolist()))
    sel = [frames[i] for i in idx]
    h, w = sel[0].shape[:2]
    rows = (len(sel) + columns - 1) // columns
    grid = np.full((rows * (h + 4), min(columns, len(sel)) * (w + 4), 3), 255, np.uint8)
    for k, f in enumerate(sel):
        r, c = divmod(k, columns)
        grid[r * (h + 4) : r * (h + 4) + f.shape[0], c * (w + 4) : c * (w + 4) + f.shape[1]] = f
    Image.fromarray(grid).save(path)
    logger.info("wrote %s", path)
    return path
