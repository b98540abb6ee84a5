"""An advisory lock on a run folder: one writing process at a time.

A :class:`~benchmarks.storage.RunSession` holds it while it writes; :func:`holding` takes it for
a single change by another writer (``tooldesign retest`` adding its checksums to the manifest).
"""

from __future__ import annotations

import contextlib
import os
import threading
import weakref
from collections.abc import Iterator
from pathlib import Path

__all__ = ["FolderLock", "holding"]


#: The folders this process holds the lock of: {resolved folder: (descriptor, owner)}; the owner
#: by weak reference, so that a session dropped without close() frees its folder when collected.
_HELD: dict[Path, tuple[int, weakref.ref[FolderLock]]] = {}
_HELD_GUARD = threading.Lock()


class FolderLock:
    """An advisory lock on a run folder, held by the session writing it (``flock``).

    The kernel releases it when the process ends, also on SIGKILL, so a killed run never leaves
    a stale lock. Within one process a new session takes the folder over from one that was left
    unclosed (a caller that stopped on an error, or a test that simulates a kill): the lock is
    against other processes. Where ``fcntl`` is missing (Windows) or the file system refuses
    locks (some network file systems), nothing is locked: the folder's checksums still refuse a
    folder that two sessions mixed up, later.
    """

    def __init__(self, folder: Path) -> None:
        self._folder = folder
        self._key: Path | None = None

    def acquire_if_present(self, *, take_over: bool = True) -> None:
        """Lock the folder if it exists and this session does not hold it yet.

        Args:
            take_over: If this process already holds the folder (another session), become its
                holder; with False, leave it to that holder and hold nothing.

        Raises:
            ValueError: A session of another process holds the lock.
        """
        if self._key is not None or not self._folder.is_dir():
            return
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            return
        key = self._folder.resolve()
        with _HELD_GUARD:
            held = _HELD.get(key)
            if held is not None:
                if take_over:
                    _HELD[key] = (held[0], weakref.ref(self))
                    self._key = key
                return
            try:
                fd = os.open(key, os.O_RDONLY)
            except OSError:
                return
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise ValueError(
                    f"another process is writing {self._folder} (a run in progress); wait for "
                    "it to end, or choose another output folder"
                ) from None
            except OSError:  # the file system does not lock
                os.close(fd)
                return
            _HELD[key] = (fd, weakref.ref(self))
            self._key = key

    def release(self) -> None:
        """Unlock, unless another session of this process has taken the folder over."""
        if self._key is None:
            return
        with _HELD_GUARD:
            held = _HELD.get(self._key)
            if held is not None and held[1]() in (self, None):
                os.close(held[0])  # closing the descriptor releases the flock
                del _HELD[self._key]
        self._key = None

    def __del__(self) -> None:
        # A session dropped without close() (an error its caller did not handle) frees the folder.
        try:
            self.release()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass


@contextlib.contextmanager
def holding(folder: str | os.PathLike[str]) -> Iterator[None]:
    """Hold ``folder``'s lock for the duration of a change, unless this process already does.

    Raises:
        ValueError: A session of another process is writing the folder.
    """
    lock = FolderLock(Path(folder))
    lock.acquire_if_present(take_over=False)
    try:
        yield
    finally:
        lock.release()
