"""Where a sweep keeps its points: one JSON file per point while it runs, one archive when it ends.

A point is the result of one method at one sweep value (its summary and every episode). While a
sweep runs, each finished point is written whole to ``out/points/METHOD__SWEEP__VALUE.json``
(crash-safe: an interrupted sweep resumes from the points it finished). When the sweep ends,
:func:`pack_points` gathers them into ``out/points.json.gz`` and removes the folder, so a
finished sweep is a handful of files (the archive, ``results.json``, ``results.csv``,
``sweep.png``). A sweep that is resumed or extended unpacks the archive first
(:func:`unpack_points`). Readers use :func:`sweep_points`, which reads either form, and both
at once after an interruption (a point in the folder is newer than the archive's).
"""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

from occrl.atomic_files import write_bytes_atomic, write_text_atomic
from occrl.envs.episodes import EpisodeResult

__all__ = ["POINTS_ARCHIVE", "point_path", "read_point", "point_episodes", "sweep_points", "pack_points", "unpack_points"]

POINTS_ARCHIVE = "points.json.gz"  # a finished sweep's points, beside results.json


def point_path(out: str | Path, method: str, sweep: str, value: float) -> Path:
    """The file of one point while a sweep runs.

    Examples:
        >>> from occrl.eval.sweep_store import point_path
        >>> point_path("runs/sweep", "hybrid-4x4", "clutter", 3.0).as_posix()
        'runs/sweep/points/hybrid-4x4__clutter__3.json'
    """
    return Path(out) / "points" / f"{method}__{sweep}__{value:g}.json"


def read_point(path: Path) -> dict | None:
    """A point as written (None when there is no point yet)."""
    return json.loads(path.read_text()) if path.exists() else None


def point_episodes(point: dict | None) -> dict[int, EpisodeResult]:
    """The episodes a point holds, by task seed (empty for no point).

    Examples:
        >>> from occrl.eval.sweep_store import point_episodes
        >>> point = {"episodes": [{"seed": 7, "objects": 1, "success": True, "dropped": False, "actions": 9, "seconds": 0.3}]}
        >>> point_episodes(point)[7].success, point_episodes(None)
        (True, {})
    """
    return {} if point is None else {e["seed"]: EpisodeResult(**e) for e in point["episodes"]}


def _archived_points(out: Path) -> list[dict]:
    archive = out / POINTS_ARCHIVE
    return json.loads(gzip.decompress(archive.read_bytes())) if archive.exists() else []


def _key(point: dict) -> str:
    return point_path(".", point["method"], point["sweep"], float(point["value"])).name


def sweep_points(out: str | Path, method: str | None = None, sweep: str | None = None) -> list[dict]:
    """The points of the sweep folder ``out`` (its ``points.json.gz`` and ``points/*.json``, a
    file in the folder before the archive's copy of the same point), those of one ``method``
    and / or one ``sweep`` ("clutter", "noise") when given, in file-name order; their episodes:
    :func:`point_episodes`. What the analysis scripts read (``scripts/sweep_claims.py``,
    ``sweep_compare.py``, ``timing_table.py``).

    Examples:
        >>> import json, tempfile
        >>> from occrl.eval.sweep_store import pack_points, point_path, sweep_points
        >>> out = tempfile.mkdtemp()
        >>> for value in (1.0, 2.0):
        ...     point_path(out, "scripted", "clutter", value).parent.mkdir(exist_ok=True)
        ...     _ = point_path(out, "scripted", "clutter", value).write_text(
        ...         json.dumps({"method": "scripted", "sweep": "clutter", "value": value, "episodes": []}))
        >>> [p["value"] for p in sweep_points(out)] == [p["value"] for p in sweep_points(pack_points(out).parent)] == [1.0, 2.0]
        True
    """
    out = Path(out)
    points = {_key(p): p for p in _archived_points(out)}
    points |= {p.name: json.loads(p.read_text()) for p in (out / "points").glob("*.json")}
    return [p for _, p in sorted(points.items()) if method in (None, p["method"]) and sweep in (None, p["sweep"])]


def pack_points(out: str | Path) -> Path:
    """Gather the points of ``out`` into ``out/points.json.gz`` (written whole, the same bytes
    for the same points) and remove ``out/points/``; returns the archive's path."""
    out = Path(out)
    points = sweep_points(out)
    archive = out / POINTS_ARCHIVE
    write_bytes_atomic(archive, gzip.compress(json.dumps(points).encode(), mtime=0))
    shutil.rmtree(out / "points", ignore_errors=True)
    return archive


def unpack_points(out: str | Path) -> None:
    """Write every archived point of ``out`` that is not in ``out/points/`` back there, then
    remove the archive (killed half way, the next call finishes the job)."""
    out = Path(out)
    for point in _archived_points(out):
        path = out / "points" / _key(point)
        if not path.exists():
            write_text_atomic(path, json.dumps(point))
    (out / POINTS_ARCHIVE).unlink(missing_ok=True)
