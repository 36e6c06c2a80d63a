"""CPU time of a training run's process tree: what a model card's ``cpu_hours`` reports.

A run's wall time says little about the CPU it used: a single-process run on one thread uses one
core, a run with collector workers uses several. :func:`tree_cpu_seconds` adds up the CPU time
(user + system) of this process (every thread), of its children that have ended and been waited
for, and, on Linux, of its live descendants read from ``/proc`` (collector workers, evaluation
workers, and a local Ray runtime that the run started: its raylet and actors descend from it).
The processes of a Ray cluster the run joined (``--ray-address``) are not counted.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

__all__ = ["tree_cpu_seconds", "live_descendants_cpu_seconds"]

_PROC = Path("/proc")


def _stat_fields(pid_dir: Path) -> list[str] | None:
    """The fields of ``/proc/PID/stat`` after the command name (which may hold spaces), or None
    when the process is gone."""
    try:
        text = (pid_dir / "stat").read_text()
    except OSError:
        return None
    return text[text.rfind(")") + 2 :].split()


def live_descendants_cpu_seconds(root: int | None = None) -> float:
    """CPU seconds used so far by the live descendants of process ``root`` (default: this one),
    from ``/proc``; 0.0 where there is no ``/proc`` (not Linux).

    Examples:
        >>> from occrl.training.cpu_time import live_descendants_cpu_seconds
        >>> live_descendants_cpu_seconds() >= 0.0
        True
    """
    if not _PROC.is_dir():
        return 0.0
    root = os.getpid() if root is None else root
    children: dict[int, list[int]] = {}
    used: dict[int, float] = {}
    tick = os.sysconf("SC_CLK_TCK")
    for pid_dir in _PROC.iterdir():
        if not pid_dir.name.isdigit():
            continue
        fields = _stat_fields(pid_dir)
        if fields is None:
            continue
        # after the name: state, ppid, ... utime and stime are the stat file's fields 14 and 15
        pid, ppid = int(pid_dir.name), int(fields[1])
        children.setdefault(ppid, []).append(pid)
        used[pid] = (int(fields[11]) + int(fields[12])) / tick
    total, stack = 0.0, list(children.get(root, []))
    while stack:
        pid = stack.pop()
        total += used.get(pid, 0.0)
        stack.extend(children.get(pid, []))
    return total


def tree_cpu_seconds() -> float:
    """CPU seconds used so far by this process (all threads), its ended children and its live
    descendants. Differences between two calls give the CPU a stretch of work used.

    Examples:
        >>> from occrl.training.cpu_time import tree_cpu_seconds
        >>> before = tree_cpu_seconds()
        >>> _ = sum(i * i for i in range(200_000))
        >>> tree_cpu_seconds() > before
        True
    """
    total = time.process_time()
    try:
        import resource
    except ImportError:  # Windows: no rusage of children
        return total
    ended = resource.getrusage(resource.RUSAGE_CHILDREN)
    return total + ended.ru_utime + ended.ru_stime + live_descendants_cpu_seconds()
