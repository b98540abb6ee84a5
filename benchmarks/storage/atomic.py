"""Atomic writes: a file is either its old content or its whole new content, never a part.

Every file a user keeps (tables, manifests, design cards, figures) is written to a temporary name
in the same folder, flushed to disk and ``os.replace``-d into place, so a kill at any moment
leaves whole files only.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path

_TEMP_SUFFIX = ".tmp"


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, *, durable: bool = True) -> Path:
    """Write ``data`` to ``path`` so that readers see the old file or the new one, never half.

    The bytes go to a hidden temporary file in the same folder (same file system, so the rename
    is atomic), are flushed to disk, and the temporary file is ``os.replace``-d onto ``path``.
    A crash leaves at most a ``.<name>.<random>.tmp`` file, which readers ignore.

    Args:
        path: Destination file; its parent folders are created.
        data: The complete file content.
        durable: Flush the file and its folder to disk (``fsync``). Without it the write is
            still atomic for every reader and survives a killed process, but not a power cut:
            for files rewritten every few seconds, such as a run's heartbeat.

    Returns:
        The destination path.

    Raises:
        TypeError: If ``data`` is not bytes-like.
        IsADirectoryError: If ``path`` is a folder.
        NotADirectoryError: If a file stands where one of its parent folders would be.
    """
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise TypeError(f"data must be bytes, got {type(data).__name__}")
    target = Path(path)
    check_file_target(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    # A random suffix (not mkstemp) so the file gets the usual umask permissions, not 0600.
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}{_TEMP_SUFFIX}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            if durable:
                os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if durable:
        _fsync_folder(target.parent)
    return target


def check_file_target(path: str | os.PathLike[str], *, parent_must_exist: bool = False) -> Path:
    """``path`` as a file to write, or an error naming what is in the way (nothing is written).

    Args:
        path: The file to write.
        parent_must_exist: Refuse a missing parent folder (a mistyped ``--out``) instead of
            leaving it to be created.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        IsADirectoryError: ``path`` is a folder.
        NotADirectoryError: a file stands where one of its parent folders would be.
        FileNotFoundError: its parent folder does not exist and ``parent_must_exist``.
    """
    target = Path(path)
    if target.is_dir():
        raise IsADirectoryError(f"{target} is a folder; give the path of a file to write")
    for folder in target.parents:
        if folder.exists():
            if not folder.is_dir():
                raise NotADirectoryError(f"cannot write {target}: {folder} is a file, not a folder")
            break
        if parent_must_exist:
            raise FileNotFoundError(
                f"cannot write {target}: its folder {target.parent} does not exist"
            )
    return target


def atomic_write_text(
    path: str | os.PathLike[str], text: str, *, encoding: str = "utf-8", durable: bool = True
) -> Path:
    """Write ``text`` atomically (see :func:`atomic_write_bytes`), without newline translation.

    Args:
        path: Destination file; its parent folders are created.
        text: The complete file content; newlines are written as they are (no ``CRLF`` on
            Windows), so the bytes are the same everywhere.
        encoding: Text encoding.
        durable: See :func:`atomic_write_bytes`.

    Returns:
        The destination path.

    Raises:
        TypeError: If ``text`` is not a string.
    """
    if not isinstance(text, str):
        raise TypeError(f"text must be str, got {type(text).__name__}")
    return atomic_write_bytes(path, text.encode(encoding), durable=durable)


def _fsync_folder(folder: Path) -> None:
    # Makes the rename itself durable on POSIX; folders cannot be opened this way on Windows.
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
