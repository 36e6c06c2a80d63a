"""Crash-safe file writes: a result file is either the old one or the complete new one, never a
part. The text goes to ``<name>.tmp`` beside the target and is renamed over it (``os.replace``
is atomic on POSIX and Windows); a crash leaves at most that temporary file."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["write_text_atomic", "write_bytes_atomic"]


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (creating the parent folder).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from occrl.atomic_files import write_text_atomic
        >>> target = Path(tempfile.mkdtemp()) / "out" / "result.json"
        >>> write_text_atomic(target, '{"tasks": 3}')
        >>> target.read_text(), sorted(p.name for p in target.parent.iterdir())
        ('{"tasks": 3}', ['result.json'])
    """
    write_bytes_atomic(path, text.encode())


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (creating the parent folder); see :func:`write_text_atomic`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
