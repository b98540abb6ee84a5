"""Reading and writing a run folder's files safely: a folder received from someone else is data.

Every reader of a run folder (``tooldesign report``, ``html``, ``retest``, ``reproduce`` and a
resumed session) goes through these few functions, so that a folder cannot make a command read
or write anything outside it:

- :func:`run_file_path` takes a path *relative to the run folder* (as a manifest lists them) and
  refuses an absolute one, one with ``..`` or an empty part, in words.
- :func:`read_run_file` and :func:`run_file_sha256` open a file below the folder one path part at
  a time without following a symbolic link (``O_NOFOLLOW`` on every part, so a link swapped in
  between a check and the open is refused too), and read it only if it is a regular file (not a
  FIFO, which would block, nor a device) of at most :data:`MAX_RUN_FILE_BYTES`.
- :func:`list_run_files` lists the regular files below a folder without descending into a
  linked folder; what it leaves out (links, FIFOs, ...) it names, so a caller can say so.
- :func:`check_write_folder` refuses to write into a folder of the run that is a symbolic link
  (a suite's ``report/`` replaced by a link to another folder) or outside the run folder.

The run folder itself is the one the user named: if that path is a link, it is resolved once and
everything below it is checked. A file with other hard links is a regular file: it is read, but
only the files the manifest records are trusted (their SHA-256 must match), and files are always
replaced atomically (a new inode), so writing never changes the other names of a hard link.
"""

from __future__ import annotations

import errno
import hashlib
import os
import stat
from collections.abc import Callable, Iterator
from pathlib import Path, PurePosixPath

__all__ = [
    "MAX_RUN_FILE_BYTES",
    "UnsafeRunFileError",
    "check_write_folder",
    "list_run_files",
    "read_run_file",
    "refuse_links",
    "run_file_path",
    "run_file_sha256",
]

MAX_RUN_FILE_BYTES = 2 << 30
"""The largest run file read into memory (2 GiB): the committed suites' tables are a few MB."""

_BLOCK = 1 << 20
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_DIRECTORY = getattr(os, "O_DIRECTORY", 0)
_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_BINARY = getattr(os, "O_BINARY", 0)
# Walking one part at a time from a folder's descriptor needs openat(); without it (Windows) each
# part is checked with lstat before the open (a race there is the user's own machine).
_DIR_FD = os.open in os.supports_dir_fd and bool(_NOFOLLOW)


class UnsafeRunFileError(ValueError):
    """A run folder's file that a reader refuses: a link, outside the folder, not a file, too big.

    A ``ValueError``, so that the command line reports it in one line with exit 2.
    """


def run_file_path(run_folder: str | os.PathLike[str], relative: object) -> Path:
    """``run_folder / relative``, for a path the run folder's manifest lists.

    Args:
        run_folder: The run folder.
        relative: A path relative to it, with ``/`` between parts (as manifests record them).

    Returns:
        The path below ``run_folder``.

    Raises:
        UnsafeRunFileError: ``relative`` is not a str, is empty, absolute, holds ``..``, ``.``,
            an empty part, a backslash or a NUL: the message says which, in words.
    """
    folder = Path(run_folder)
    if not isinstance(relative, str):
        raise UnsafeRunFileError(
            f"{folder}: a run file's path must be a str relative to the folder, got {relative!r}"
        )
    return folder.joinpath(*_parts(folder, relative))


def _parts(folder: Path, relative: str) -> tuple[str, ...]:
    where = f"{folder}: the path {relative!r}"
    if not relative:
        raise UnsafeRunFileError(f"{where} is empty; a run file is named relative to its folder")
    if "\x00" in relative or "\\" in relative:
        raise UnsafeRunFileError(
            f"{where} holds a NUL or a backslash; a run file's path uses '/' between its parts"
        )
    if relative.startswith("/") or PurePosixPath(relative).is_absolute() or relative[1:2] == ":":
        raise UnsafeRunFileError(
            f"{where} is absolute, outside the run folder; its files are named relative to it"
        )
    parts = tuple(relative.split("/"))
    if ".." in parts:
        raise UnsafeRunFileError(
            f"{where} goes up with '..', outside the run folder; only files inside it are read"
        )
    if any(part in ("", ".") for part in parts):
        raise UnsafeRunFileError(f"{where} has an empty or '.' part; name the file plainly")
    return parts


def _relative(folder: Path, path: str | os.PathLike[str]) -> tuple[str, ...]:
    """The parts of ``path`` below ``folder``.

    A str is relative to it (as a manifest lists it); a Path must lie below it.
    """
    if isinstance(path, str):
        return _parts(folder, path)
    target = Path(path)
    try:
        inside = target.relative_to(folder)
    except ValueError:
        raise UnsafeRunFileError(
            f"{target} is outside the run folder {folder}; only files inside it are read"
        ) from None
    return _parts(folder, inside.as_posix())


def _kind(mode: int) -> str:
    if stat.S_ISREG(mode):
        return "a file"
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "not a regular file"


def _link_error(path: Path) -> UnsafeRunFileError:
    return UnsafeRunFileError(
        f"{path} is a symbolic link; a run folder's files are read only if they are regular "
        "files inside it (a link could point at any file of this machine)"
    )


def _open(folder: str | os.PathLike[str], path: str | os.PathLike[str]) -> tuple[int, Path]:
    """A read-only descriptor of the regular file ``path`` below ``folder``, and its path."""
    root = Path(folder)
    parts = _relative(root, path)
    shown = root.joinpath(*parts)
    if not _DIR_FD:
        current = root
        for part in parts:
            current = current / part
            try:
                mode = os.lstat(current).st_mode
            except FileNotFoundError:
                raise FileNotFoundError(f"{current} does not exist") from None
            if stat.S_ISLNK(mode):
                raise _link_error(current)
        fd = os.open(shown, os.O_RDONLY | _BINARY | _NONBLOCK)
    else:
        fd = os.open(root, os.O_RDONLY | _DIRECTORY | _CLOEXEC)
        current = root
        try:
            for i, part in enumerate(parts):
                current = current / part
                last = i == len(parts) - 1
                flags = os.O_RDONLY | _NOFOLLOW | _CLOEXEC | (_NONBLOCK if last else _DIRECTORY)
                try:
                    child = os.open(part, flags, dir_fd=fd)
                except OSError as err:
                    raise _open_error(current, err, fd, part) from None
                os.close(fd)
                fd = child
        except BaseException:
            os.close(fd)
            raise
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise UnsafeRunFileError(
                f"{shown} is {_kind(mode)}, not a regular file; a reader of a run folder reads "
                "regular files only"
            )
        if _NONBLOCK:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd, shown


def _open_error(path: Path, err: OSError, dir_fd: int, part: str) -> Exception:
    if err.errno in (errno.ELOOP, errno.ENOTDIR, errno.EMLINK):
        try:
            mode = os.lstat(part, dir_fd=dir_fd).st_mode
        except OSError:
            mode = 0
        if stat.S_ISLNK(mode):
            return _link_error(path)
        if err.errno == errno.ENOTDIR:
            return UnsafeRunFileError(f"{path} is {_kind(mode)}, where a folder was expected")
    if err.errno == errno.ENOENT:
        return FileNotFoundError(f"{path} does not exist")
    return OSError(err.errno, f"{path}: {err.strerror}")


def read_run_file(
    run_folder: str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    max_bytes: int = MAX_RUN_FILE_BYTES,
    expected_sha256: str | None = None,
    head: int | None = None,
) -> bytes:
    """The bytes of a regular file inside ``run_folder``, no symbolic link followed.

    Args:
        run_folder: The run folder.
        path: The file: a str relative to ``run_folder`` (``/`` between parts, as a manifest
            records it), or a Path below ``run_folder``.
        max_bytes: Refuse a larger file (it is not read).
        expected_sha256: The SHA-256 the manifest records for it: refused if it differs.
        head: Read only the first ``head`` bytes (any size of file is then fine).

    Raises:
        UnsafeRunFileError: the path leaves the folder, a part of it is a link, or it is not a
            regular file, or it is larger than ``max_bytes``.
        FileNotFoundError: it does not exist.
        ValueError: its SHA-256 is not ``expected_sha256``.
    """
    fd, shown = _open(run_folder, path)
    with os.fdopen(fd, "rb") as handle:
        if head is not None:
            return handle.read(head)
        size = os.fstat(handle.fileno()).st_size
        if size > max_bytes:
            raise UnsafeRunFileError(
                f"{shown} is {size} bytes, more than the {max_bytes} a run file may have; "
                "it was not read"
            )
        data = handle.read(max_bytes + 1)
    if len(data) > max_bytes:  # it grew while read
        raise UnsafeRunFileError(f"{shown} grew past {max_bytes} bytes while it was read")
    if expected_sha256 is not None:
        _check(shown, hashlib.sha256(data).hexdigest(), expected_sha256)
    return data


def run_file_sha256(
    run_folder: str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    max_bytes: int = MAX_RUN_FILE_BYTES,
) -> str:
    """Hex SHA-256 of a regular file inside ``run_folder`` (read in blocks, no link followed).

    Raises:
        UnsafeRunFileError, FileNotFoundError: as :func:`read_run_file` (a file larger than
            ``max_bytes`` is refused before it is read).
    """
    fd, shown = _open(run_folder, path)
    digest = hashlib.sha256()
    with os.fdopen(fd, "rb") as handle:
        size = os.fstat(handle.fileno()).st_size
        if size > max_bytes:
            raise UnsafeRunFileError(
                f"{shown} is {size} bytes, more than the {max_bytes} a run file may have; "
                "it was not read"
            )
        for block in iter(lambda: handle.read(_BLOCK), b""):
            digest.update(block)
    return digest.hexdigest()


def _check(path: Path, actual: str, expected: str) -> None:
    if actual != expected:
        raise ValueError(
            f"{path} has changed since it was written (sha256 {actual[:12]}..., the "
            f"manifest records {expected[:12]}...): the file was edited, truncated or "
            "corrupted; restore it or start a new run folder"
        )


def list_run_files(
    run_folder: str | os.PathLike[str],
    *,
    under: str = "",
    skip_dir: Callable[[str], bool] = lambda name: False,
) -> tuple[list[str], dict[str, str]]:
    """The regular files below a run folder, and what was left out and why.

    Symbolic links (to files or folders) are never followed, FIFOs, sockets and devices never
    opened: they are left out and named.

    Args:
        run_folder: The run folder.
        under: A folder relative to it to list instead of the whole folder (``""``).
        skip_dir: Whether to leave out a folder of this name (not reported).

    Returns:
        ``(files, left_out)``: the regular files' paths relative to ``run_folder`` (``/``
        between parts), sorted depth first; ``{relative path: why it was left out}``.

    Raises:
        UnsafeRunFileError: ``under`` leaves the folder or is a link.
    """
    root = Path(run_folder)
    start = root
    if under:
        start = run_file_path(root, under)
        if start.is_symlink():
            raise _link_error(start)
        if not start.is_dir():
            return [], {}
    files: list[str] = []
    left_out: dict[str, str] = {}
    for relative, entry in _walk(root, start, skip_dir):
        mode = entry.stat(follow_symlinks=False).st_mode
        if stat.S_ISREG(mode):
            files.append(relative)
        else:
            left_out[relative] = _kind(mode)
    return files, left_out


def _walk(
    root: Path, folder: Path, skip_dir: Callable[[str], bool]
) -> Iterator[tuple[str, os.DirEntry[str]]]:
    with os.scandir(folder) as scan:
        entries = sorted(scan, key=lambda e: e.name)
    for entry in entries:
        relative = Path(entry.path).relative_to(root).as_posix()
        if entry.is_dir(follow_symlinks=False):
            if not skip_dir(entry.name):
                yield from _walk(root, Path(entry.path), skip_dir)
        else:
            yield relative, entry


def refuse_links(run_folder: str | os.PathLike[str]) -> None:
    """Refuse a run folder that holds a symbolic link, FIFO, socket or device anywhere below it.

    For a command about to write into the folder (a resumed run): a linked ``parts/`` or
    ``designs/`` would have its files written into another folder. The folder itself may be a
    link (the user named it).

    Raises:
        UnsafeRunFileError: naming the first such entry and what it is.
    """
    root = Path(run_folder)
    if not root.is_dir():
        return
    _, left_out = list_run_files(root)
    for relative, kind in left_out.items():
        raise UnsafeRunFileError(
            f"{root / relative} is {kind}; a run folder holds regular files and folders only, "
            "and nothing is written into it while it holds one (it could lead anywhere on this "
            "machine): remove it"
        )


def check_write_folder(run_folder: str | os.PathLike[str], folder: str | os.PathLike[str]) -> Path:
    """Refuse to write into ``folder`` if it lies in ``run_folder`` through a symbolic link.

    A folder outside the run folder (an ``--out`` the user gave) is the user's and is returned
    as it is. One inside it must be reached through real folders only: a ``report/`` that is a
    link to another folder would have that folder's files overwritten.

    The path is followed as the system will follow it when the command writes: part by part,
    ``..`` going up from where the parts so far lead (``run/../outdir`` is ``outdir``, the same
    folder as its absolute path). A link met on the way is followed if it lies outside the run
    folder (the user's own ``runs/latest``) and refused if it lies inside it, however the path
    reaches it (``run/report``, ``run/../run/report`` or its absolute path alike).

    Args:
        run_folder: The run folder.
        folder: Where a command is about to write (it may not exist yet).

    Returns:
        ``folder`` as a Path.

    Raises:
        UnsafeRunFileError: a part of ``folder`` in ``run_folder`` is a symbolic link or not
            a folder.
    """
    target = Path(folder)
    real_root = Path(os.path.realpath(run_folder))
    current = Path(os.path.abspath(target.anchor or os.curdir))
    remaining = list(target.parts[1:] if target.anchor else target.parts)
    links = 0
    while remaining:
        part = remaining.pop(0)
        if part in ("", "."):
            continue
        if part == "..":
            current = current.parent  # ``current`` holds no link: '..' is its real parent
            continue
        step = current / part
        try:
            mode = os.lstat(step).st_mode
        except (FileNotFoundError, NotADirectoryError):
            # Nothing below a missing folder exists, so no link either; a '..' in the rest is
            # refused by the system (the folder is missing) when the command writes.
            break
        inside = _is_within(step, real_root)
        if stat.S_ISLNK(mode):
            if inside:
                raise UnsafeRunFileError(
                    f"{step} is a symbolic link; nothing is written through it (it could lead "
                    "to any folder of this machine): replace it by a folder, or give --out"
                )
            # The user's own link (runs/latest): followed as the system follows it, one part
            # at a time, so a link of the run folder it leads through is refused too.
            links += 1
            if links > _MAX_LINKS:
                raise UnsafeRunFileError(f"{target}: too many levels of symbolic links")
            destination = Path(os.readlink(step))
            if destination.anchor:
                current = Path(destination.anchor)
                remaining[:0] = destination.parts[1:]
            else:
                remaining[:0] = destination.parts
            continue
        if not stat.S_ISDIR(mode):
            if inside:
                raise UnsafeRunFileError(f"cannot write into {step}: it is {_kind(mode)}")
            break  # the user's own file: the write fails there, and the system says why
        current = step
    return target


_MAX_LINKS = 40  # as Linux's ELOOP


def _is_within(path: Path, root: Path) -> bool:
    """Whether the link-free absolute ``path`` is ``root`` or below it."""
    return path == root or root in path.parents
