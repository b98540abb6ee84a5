"""Writing files atomically: the one helper of ``tooldesign_env`` (meshes, caches).

``benchmarks.storage.atomic`` does the same for run folders; ``tooldesign_env`` may not import
``benchmarks`` (docs/architecture.md), so it keeps these lines of its own.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path

__all__ = ["write_atomic"]


def write_atomic(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` so that readers see the old file, the new one, or none.

    The bytes go to a hidden temporary file in the same folder (same file system, so the rename
    is atomic), are flushed to disk, and the temporary file is ``os.replace``-d onto ``path``; on
    any error the temporary file is removed and the error raised. The folder must exist.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.
    """
    path = Path(path)
    # O_EXCL with a random name rather than mkstemp, whose 0600 would make a mesh unreadable to
    # anyone but its owner; this way the file gets the usual umask permissions.
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    handle = os.open(
        temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666
    )
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise
    return path
