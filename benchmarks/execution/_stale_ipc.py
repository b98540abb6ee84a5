"""Remove what a process pool killed with its whole process group left behind (Linux).

A pool started with ``forkserver`` or ``spawn`` names its semaphores (``/dev/shm/sem.mp-*``) so
that workers can open them, and the forkserver listens on a socket in a ``pymp-*`` folder of the
temporary folder. Python's resource tracker unlinks them when the main process dies; SIGKILL to
the process *group* kills the tracker too, and they stay: five semaphores and a folder per run.

No primitive of ``concurrent.futures`` avoids the names, so the next pool of this user removes
them before it starts (:func:`remove_stale_ipc`), and only what no process can still use:

- a ``sem.mp-*`` entry owned by this user that no live process has mapped (glibc maps a named
  semaphore before the name appears, and every process that opened it keeps it mapped);
- a ``pymp-*`` folder owned by this user holding only sockets, none of them bound by a live
  process (``/proc/net/unix``), and nothing else.

Both names are CPython's own (``multiprocessing``), so what is removed was left by a killed
Python program of this user; no process of any kind can reach it again.
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
from pathlib import Path

__all__ = ["remove_stale_ipc"]

_SHM = Path("/dev/shm")
_SEM_PREFIX = "sem.mp-"
_TMP_PREFIX = "pymp-"
_done = False


def remove_stale_ipc(*, force: bool = False) -> list[Path]:
    """Remove stale multiprocessing semaphores and forkserver folders of this user (once).

    Args:
        force: Look again even if this process already did (tests).

    Returns:
        What was removed. Nothing on systems without ``/proc`` (only Linux names semaphores
        in ``/dev/shm``); errors (a race with another cleaner) are ignored.
    """
    global _done
    if (_done and not force) or not sys.platform.startswith("linux"):
        return []
    _done = True
    removed: list[Path] = []
    try:
        removed += _stale_semaphores()
        removed += _stale_folders()
    except OSError:
        pass
    return removed


def _owned(path: Path) -> os.stat_result | None:
    try:
        info = os.lstat(path)
    except OSError:
        return None
    return info if info.st_uid == os.getuid() else None


def _mapped() -> set[str]:
    """The ``/dev/shm`` names some live process has mapped."""
    names: set[str] = set()
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/maps", encoding="utf-8", errors="replace") as maps:
                for line in maps:
                    if "/dev/shm/" in line:
                        names.add(line.rsplit("/dev/shm/", 1)[1].split()[0])
        except OSError:  # the process ended, or its maps are not ours to read
            continue
    return names


def _stale_semaphores() -> list[Path]:
    if not _SHM.is_dir():
        return []
    candidates = []
    for name in os.listdir(_SHM):
        info = _owned(_SHM / name) if name.startswith(_SEM_PREFIX) else None
        if info is not None and stat.S_ISREG(info.st_mode):
            candidates.append(name)
    if not candidates:
        return []
    mapped = _mapped()
    removed = []
    for name in candidates:
        if name in mapped:
            continue
        try:
            os.unlink(_SHM / name)
        except OSError:
            continue
        removed.append(_SHM / name)
    return removed


def _bound_sockets() -> set[str]:
    try:
        with open("/proc/net/unix", encoding="utf-8", errors="replace") as table:
            lines = table.read().splitlines()[1:]
    except OSError:
        return set()
    return {fields[7] for line in lines if len(fields := line.split()) >= 8}


def _stale_folders() -> list[Path]:
    root = Path(tempfile.gettempdir())
    folders = []
    for name in os.listdir(root):
        info = _owned(root / name) if name.startswith(_TMP_PREFIX) else None
        if info is not None and stat.S_ISDIR(info.st_mode):
            folders.append(root / name)
    if not folders:
        return []
    bound = _bound_sockets()
    removed = []
    for folder in folders:
        try:
            entries = [folder / e for e in os.listdir(folder)]
            kinds = [os.lstat(e).st_mode for e in entries]
        except OSError:
            continue
        if not entries or not all(stat.S_ISSOCK(k) for k in kinds):
            continue  # in use, or not what a forkserver leaves: not ours to judge
        if any(str(e) in bound for e in entries):
            continue
        try:
            for entry in entries:
                os.unlink(entry)
            os.rmdir(folder)
        except OSError:
            continue
        removed.append(folder)
    return removed
