"""Pictures of episodes: the true scene beside the network's abstract observation, per step.

``episode_frames`` turns a rollout tensordict (from the standard pipeline, which keeps
``"pixels"``) into RGB frames; ``save_gif`` and ``save_film_strip`` write them.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Sequence

import imageio.v2 as imageio
import numpy as np
from PIL import Image, ImageDraw
from tensordict import TensorDictBase

from occrl.envs.geometry import transform_polygons
from occrl.envs.palette import labels_to_rgb
from occrl.envs.render import SHELF_VIEW, render_true_scene

__all__ = ["episode_frames", "frame", "decision_panels", "save_gif", "save_film_strip"]

logger = logging.getLogger(__name__)

PANEL = 256  # pixels per panel side
CAPTION_HEIGHT = 18  # pixels above the panels for a frame's caption
TITLE_HEIGHT = 14  # then for each panel's title


def _panel_width(rgb: np.ndarray) -> Image.Image:
    """An RGB picture scaled to the panel width, aspect kept."""
    return Image.fromarray(rgb).resize((PANEL, int(PANEL * rgb.shape[0] / rgb.shape[1])), Image.BILINEAR)


def _shelf_picture(gripper_pose, opening: float, polygons, is_target) -> Image.Image:
    """The top-down shelf view of the given objects (target green, the others red) at panel width."""
    labels = render_true_scene(np.asarray(gripper_pose, float), float(opening), polygons, is_target, SHELF_VIEW)
    return _panel_width(labels_to_rgb(labels))


def _true_panel(step: TensorDictBase) -> np.ndarray:
    priv = step.get("privileged")
    present = priv.get("object_present").numpy()
    verts = priv.get("object_vertices").numpy().astype(float)
    poses = priv.get("object_pose").numpy().astype(float)
    nv = priv.get("object_num_vertices").numpy()
    slot = int(priv.get("target_slot").reshape(-1)[0])
    world = transform_polygons(verts, poses)
    idx = np.flatnonzero(present)
    img = _shelf_picture(
        step.get("gripper_pose").numpy(),
        step.get("gripper_opening").reshape(-1)[0],
        [world[k, : nv[k]] for k in idx],
        [k == slot for k in idx],
    )
    return np.asarray(img)


def _obs_panel(step: TensorDictBase, heatmap: np.ndarray | None = None, decision=None) -> np.ndarray:
    pix = (step.get("pixels").permute(1, 2, 0).numpy() * 255).astype(np.uint8)
    img = Image.fromarray(pix).resize((PANEL, PANEL), Image.NEAREST)
    if heatmap is not None:
        # contour lines of the heat-map at 25 / 50 / 75 % of its maximum (paper Fig. 3)
        hm = np.clip(heatmap, 0, None)
        hm = hm / hm.max() if hm.max() > 0 else hm
        hm = np.asarray(Image.fromarray((hm * 255).astype(np.uint8)).resize((PANEL, PANEL), Image.BILINEAR)).astype(float) / 255.0
        arr = np.asarray(img).astype(float)
        for level in (0.25, 0.5, 0.75):
            above = hm >= level
            edge = np.zeros_like(above)
            edge[1:] |= above[1:] != above[:-1]
            edge[:, 1:] |= above[:, 1:] != above[:, :-1]
            arr[edge] = [230, 0, 230]
        img = Image.fromarray(arr.astype(np.uint8))
    if decision is not None:
        draw = ImageDraw.Draw(img)
        scale = PANEL / step.get("pixels").shape[-1]  # heat-map pixels are the input image's pixels
        for k, root in enumerate(decision.roots):
            if root.peak_pixel is None:
                continue
            r, c = root.peak_pixel
            x, y = (c + 0.5) * scale, (r + 0.5) * scale
            colour = (255, 140, 0) if k == decision.chosen_root else (120, 0, 160)
            draw.ellipse([x - 5, y - 5, x + 5, y + 5], outline=colour, width=2)
            draw.text((x + 6, y - 6), f"{root.weight:.2f}", fill=colour)
        # the chosen action as an arrow from the camera (image: gripper below the centre)
        a = decision.action
        cx, cy = PANEL / 2, PANEL * (0.5 + 0.15 / 0.8)
        draw.line([cx, cy, cx + a[1] * 30, cy - a[0] * 30], fill=(255, 140, 0), width=3)
    return np.asarray(img)


def frame(step: TensorDictBase, caption: str = "", heatmap: np.ndarray | None = None, decision=None) -> np.ndarray:
    """One picture of one step (a tensordict with no batch dims), a caption above its titled
    panels: true scene | the network's input, with the heat-map's contours, the planner's root
    states (weights; orange = chosen) and action | the gripper-camera image when the step has
    ``"camera_rgb"`` (MuJoCo, ``record_camera=True``).

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.eval.film import frame
        >>> rollout = make_env(batch_size=1, seed=0, heatmap_target=False).rollout(1, ScriptedRetriever())
        >>> picture = frame(rollout[0, 0], "step 0")
        >>> picture.shape, picture.dtype
        ((320, 518, 3), dtype('uint8'))
    """
    panels = [_true_panel(step), _obs_panel(step, heatmap, decision)]
    titles = ["true scene (target green)", "network input" + (", heat-map (magenta)" if heatmap is not None else "")]
    if decision is not None:
        titles[1] += ", roots"
    if "camera_rgb" in step.keys():  # MujocoShelfEnv(record_camera=True): the real gripper-camera image
        cam = step.get("camera_rgb").permute(1, 2, 0).numpy()
        panels.append(np.asarray(_panel_width(cam)))
        titles.append("gripper camera (MuJoCo)")
    top = CAPTION_HEIGHT + TITLE_HEIGHT
    h = max(p.shape[0] for p in panels) + top
    out = np.full((h, sum(p.shape[1] for p in panels) + 6 * (len(panels) - 1), 3), 255, np.uint8)
    img = Image.fromarray(out)
    draw = ImageDraw.Draw(img)
    draw.text((4, 3), caption, fill=(0, 0, 0))
    x = 0
    for p, title in zip(panels, titles):
        img.paste(Image.fromarray(p), (x, top))
        draw.text((x + 4, CAPTION_HEIGHT), title, fill=(70, 70, 70))
        x += p.shape[1] + 6
    return np.asarray(img)


def episode_frames(
    rollout: TensorDictBase, heatmaps: Sequence[np.ndarray] | None = None, decisions: Sequence | None = None
) -> list[np.ndarray]:
    """Frames of a single-episode rollout (batch dims [T]); the last frame shows the final state.

    With a planner's ``decisions`` (``HybridPlanner.decisions``, one per step), each frame also
    shows the heat-map contours, the root states and the chosen action (paper Fig. 3 and 6).
    A ``"heatmap"`` entry in the rollout is drawn when ``heatmaps`` is not given.

    Examples:
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.eval.film import episode_frames
        >>> rollout = make_env(batch_size=1, seed=0, heatmap_target=False).rollout(3, ScriptedRetriever())
        >>> frames = episode_frames(rollout[0])  # one episode: batch dims [T]
        >>> len(frames), frames[0].shape  # one per action and the final state
        (4, (320, 518, 3))
    """
    if rollout.batch_dims != 1:
        raise ValueError(f"expected one episode with batch dims [T], got batch size {tuple(rollout.batch_size)}")
    frames = []
    T = rollout.shape[0]
    for t in range(T):
        step = rollout[t]
        a = step.get("action").numpy()
        cap = f"step {t}  action fwd {a[0]:+.2f} lat {a[1]:+.2f} rot {a[2]:+.2f} grip {'close' if a[3] > 0 else 'open'}"
        heat = heatmaps[t] if heatmaps is not None else (step.get("heatmap")[0].numpy() if "heatmap" in step.keys() else None)
        dec = decisions[t] if decisions is not None and t < len(decisions) else None
        if dec is not None:
            cap += f"  roots {len(dec.roots)}  plan {dec.seconds * 1000:.0f} ms"
        frames.append(frame(step, cap, heat, dec))
    last = rollout[T - 1].get("next")
    end = "success" if bool(last.get("success").any()) else ("dropped an object" if bool(last.get("dropped").any()) else "not retrieved")
    frames.append(frame(last, f"after {T} actions: {end}"))
    return frames


def decision_panels(decision) -> list[np.ndarray]:
    """One picture per root state of a planner decision (``HybridPlanner.decisions[t]``): the
    recreated shelf with the hypothesised target (green), the m roll-outs' gripper paths (grey; the
    root's best in blue, the executed one in orange) and a caption with the root's weight and
    return. This is the planner's own view: objects it has not detected are not drawn.

    Examples:
        >>> from occrl.envs import make_env
        >>> from occrl.modules import make_occnet
        >>> from occrl.planners import HybridPlanner
        >>> net = make_occnet("paper")
        >>> env = make_env(batch_size=1, stage=1, seed=0).append_transform(net.make_primer())
        >>> planner = HybridPlanner(net, m=2, h=2)
        >>> _ = env.rollout(1, planner)
        >>> panels = decision_panels(planner.decisions[-1])
        >>> len(panels) == len(planner.decisions[-1].roots), panels[0].dtype
        (True, dtype('uint8'))
    """
    result = decision.result
    panels = []
    for r, root in enumerate(decision.roots):
        st = root.state
        img = _shelf_picture(st.gripper_pose, st.opening, st.polygons(), [o.is_target for o in st.objects])
        sx = PANEL / SHELF_VIEW.shape[1]
        draw = ImageDraw.Draw(img)
        best = int(np.argmax(result.returns[r]))
        order = [i for i in range(result.returns.shape[1]) if i != best] + [best]  # best drawn last, on top
        for i in order:
            if result.paths is None:
                break
            path = result.paths[r, i]
            path = path[np.isfinite(path[:, 0])]
            pts = SHELF_VIEW.to_pixels(path[:, :2]) * sx + 0.5 * sx
            colour = ((255, 140, 0) if r == decision.chosen_root else (40, 90, 230)) if i == best else (110, 110, 110)
            if len(pts) > 1:
                draw.line([tuple(q) for q in pts], fill=colour, width=3 if i == best else 1)
            for q in pts[1:]:
                draw.ellipse([q[0] - 2, q[1] - 2, q[0] + 2, q[1] + 2], fill=colour)
        chosen = "  executed" if r == decision.chosen_root else ""
        where = "target seen" if root.peak_pixel is None else "target hypothesised"
        draw.text((4, 3), f"root {r}: w {root.weight:.2f}, {where}", fill=(0, 0, 0))
        draw.text((4, 15), f"best return {result.value[r]:.1f}{chosen}", fill=(0, 0, 0))
        panels.append(np.asarray(img))
    return panels


def save_gif(frames: Sequence[np.ndarray], path: str | Path, fps: float = 4.0) -> Path:
    """Write the frames as a looping animated GIF at ``fps`` frames per second; returns the path.

    Examples:
        >>> import os, tempfile
        >>> from PIL import Image
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.eval.film import episode_frames, save_gif
        >>> rollout = make_env(batch_size=1, seed=0, heatmap_target=False).rollout(3, ScriptedRetriever())
        >>> path = save_gif(episode_frames(rollout[0]), os.path.join(tempfile.mkdtemp(), "episode.gif"))
        >>> Image.open(path).n_frames
        4
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(path, list(frames), duration=1.0 / fps, loop=0)
    logger.info("wrote %s (%d frames)", path, len(frames))
    return path


def save_film_strip(frames: Sequence[np.ndarray], path: str | Path, columns: int = 4, max_frames: int = 12) -> Path:
    """A grid of evenly spaced frames (first and last always included) as one PNG.

    Examples:
        >>> import os, tempfile
        >>> from PIL import Image
        >>> from occrl.baselines import ScriptedRetriever
        >>> from occrl.envs import make_env
        >>> from occrl.eval.film import episode_frames, save_film_strip
        >>> rollout = make_env(batch_size=1, seed=0, heatmap_target=False).rollout(3, ScriptedRetriever())
        >>> frames = episode_frames(rollout[0])  # 4 frames of 320 x 518 pixels
        >>> path = save_film_strip(frames, os.path.join(tempfile.mkdtemp(), "strip.png"), columns=2)
        >>> Image.open(path).size  # (width, height) of a 2 x 2 grid with 4-pixel gaps
        (1044, 648)
    """
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
