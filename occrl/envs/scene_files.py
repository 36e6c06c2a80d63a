"""Scenes saved to and read from a JSON file (e.g. a pool of start states for training,
:class:`~occrl.envs.ShelfEnv`'s ``scene_pool``).

The file is ``{"format": "occrl-scenes-v1", "meta": {...}, "scenes": [...]}``, one entry per
scene with its objects (type id, vertices about the centroid, pose, target flag), the gripper's
pose and the scene's own ``meta``. Floats are written as Python's ``repr``, so a scene read back
is the scene written, bit for bit; reading checks every scene as :class:`~occrl.envs.Scene` does.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from occrl.envs.scene import Scene, SceneObject

__all__ = ["SCENES_FORMAT", "save_scenes", "load_scenes"]

SCENES_FORMAT = "occrl-scenes-v1"


def save_scenes(path: str | Path, scenes: Sequence[Scene], meta: dict | None = None) -> None:
    """Write ``scenes`` (and the file's ``meta``, e.g. how they were made) to ``path`` atomically.

    Examples:
        >>> import os, tempfile
        >>> from occrl.envs import Scene
        >>> from occrl.envs.scene_files import load_scenes, save_scenes
        >>> path = os.path.join(tempfile.mkdtemp(), "pool.json")
        >>> scenes = [Scene.sample(stage=2, seed=s) for s in range(3)]
        >>> save_scenes(path, scenes, meta={"made by": "doctest"})
        >>> back, meta = load_scenes(path)
        >>> [o.pose for o in back[2].objects] == [o.pose for o in scenes[2].objects], meta
        (True, {'made by': 'doctest'})
    """
    if not all(isinstance(s, Scene) for s in scenes):
        raise TypeError("scenes must be occrl.envs.Scene objects")
    entries = [
        {
            "objects": [
                {
                    "type_id": int(o.type_id),
                    "vertices": np.asarray(o.vertices, float).tolist(),
                    "pose": [float(v) for v in o.pose],
                    "is_target": bool(o.is_target),
                }
                for o in s.objects
            ],
            "gripper_pose": [float(v) for v in s.gripper_pose],
            "stage": s.stage,
            "seed": s.seed,
            "meta": s.meta,
        }
        for s in scenes
    ]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")  # written whole, then renamed over the target
    tmp.write_text(json.dumps({"format": SCENES_FORMAT, "meta": meta or {}, "scenes": entries}))
    os.replace(tmp, path)


def load_scenes(path: str | Path) -> tuple[list[Scene], dict]:
    """The scenes of a :func:`save_scenes` file and its ``meta``.

    Raises:
        ValueError: the file is not a scenes file of this format, or a scene in it is invalid
            (naming the scene and the problem).
    """
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ValueError(f"{path}: not a readable scenes file ({err})") from None
    if not isinstance(data, dict) or data.get("format") != SCENES_FORMAT:
        found = data.get("format") if isinstance(data, dict) else type(data).__name__
        raise ValueError(f"{path}: expected a scenes file of format {SCENES_FORMAT!r}, got {found!r}")
    scenes = []
    for k, entry in enumerate(data["scenes"]):
        try:
            objects = tuple(
                SceneObject(
                    int(o["type_id"]), np.asarray(o["vertices"], dtype=float), tuple(float(v) for v in o["pose"]), bool(o["is_target"])
                )
                for o in entry["objects"]
            )
            scenes.append(
                Scene(
                    objects=objects,
                    gripper_pose=tuple(float(v) for v in entry["gripper_pose"]),
                    stage=entry.get("stage"),
                    seed=entry.get("seed"),
                    meta=entry.get("meta") or {},
                )
            )
        except (KeyError, TypeError, ValueError) as err:
            raise ValueError(f"{path}: scene {k} is invalid ({err})") from None
    return scenes, data.get("meta", {})
