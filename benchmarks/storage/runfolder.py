"""What a run folder is, and which of its files a page may show: the readers' one gate.

:func:`run_folder_kind` says which command wrote a folder (its manifest's ``extra.kind``, or
the files of ``tooldesign evaluate``) and refuses any other folder; :func:`report_files` lists
the files a report page may embed: regular files inside the folder only (no link followed, no
FIFO opened), after the whole folder was checked against its manifest's checksums, without the
consolidated table when it differs from its checksum (:meth:`ResultStore.verify`), and naming
what it left out. :func:`check_own_page` refuses to overwrite a page the command did not write.
"""

from __future__ import annotations

import os
import stat
import warnings
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

from benchmarks.storage.manifest import MANIFEST_NAME, read_manifest
from benchmarks.storage.runfiles import (
    UnsafeRunFileError,
    check_write_folder,
    list_run_files,
    read_run_file,
)
from benchmarks.storage.table import ResultStore

__all__ = [
    "EVALUATE_KIND",
    "PAGE_MARKS",
    "RUN_KINDS",
    "ReportFiles",
    "check_own_page",
    "report_files",
    "run_folder_kind",
]

RUN_KINDS: tuple[str, ...] = ("design", "suite", "rl-suite")
"""The ``extra.kind`` of the manifests the commands write: ``tooldesign design``, ``bench``,
``bench rl`` (``benchmarks.design.config.DESIGN_SUITE``, ``benchmarks.suites.config.SUITE_KIND``,
``benchmarks.rl.suite.RL_SUITE_KIND``; a test keeps them equal)."""

EVALUATE_KIND = "evaluate"
"""The kind of a ``tooldesign evaluate`` folder: no manifest, its ``terms.json`` and
``tool.urdf``."""

_EVALUATE_FILES = ("terms.json", "tool.urdf")

PAGE_MARKS: tuple[bytes, ...] = (
    b'<meta name="generator" content="tooldesign html">',
    b"<title>tooldesign report: ",  # the pages written before the generator mark
)
"""How a page written by ``tooldesign html`` starts (one of these in its first 4 kB)."""

_PAGE_HEAD = 4096
_MAX_EMBED_BYTES = 64 << 20  # a design's rollout GIF is a few MB


def run_folder_kind(folder: str | os.PathLike[str]) -> str:
    """Which command wrote ``folder``: one of :data:`RUN_KINDS` or :data:`EVALUATE_KIND`.

    Raises:
        FileNotFoundError: ``folder`` is not a folder.
        ValueError: it is not a run folder of a known kind (the message says what it holds),
            or its manifest cannot be read or is a link.
    """
    root = Path(folder)
    if not root.is_dir():
        name = str(root)  # one line, whatever the name holds (a newline is legal)
        raise FileNotFoundError(f"{name if name.isprintable() else repr(name)} is not a folder")
    if os.path.lexists(root / MANIFEST_NAME):
        manifest = read_manifest(root)
        extra = manifest.get("extra")
        kind = extra.get("kind") if isinstance(extra, dict) else None
        if kind in RUN_KINDS:
            return str(kind)
        raise ValueError(
            f"{root / MANIFEST_NAME} names no run of a known kind (extra.kind is {kind!r}; the "
            f"commands write {', '.join(RUN_KINDS)}): {root} is not a run folder"
        )
    if all(_regular(root / name) for name in _EVALUATE_FILES):
        return EVALUATE_KIND
    raise ValueError(
        f"{root} is not a run folder: it has no {MANIFEST_NAME} (a design, bench or bench rl "
        f"run) and no {' and '.join(_EVALUATE_FILES)} (tooldesign evaluate); give the folder "
        "a tooldesign command wrote"
    )


def _regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


@dataclass(frozen=True)
class ReportFiles:
    """The files of a run folder a page may show.

    Attributes:
        kind: What wrote the folder (:func:`run_folder_kind`).
        files: Paths relative to the folder (``/`` between parts), sorted depth first:
            regular files inside it, checked against the manifest where it records them.
        left_out: ``{relative path: why}``: links, FIFOs, files too large to embed, and
            consolidated tables that differ from their checksum.
    """

    kind: str
    files: tuple[str, ...]
    left_out: dict[str, str]


def report_files(
    folder: str | os.PathLike[str],
    *,
    skip_dirs: Collection[str] = (),
    skip_names: Collection[str] = (),
) -> ReportFiles:
    """The files of the run folder ``folder`` a report page may embed, after checking it.

    Args:
        folder: The run folder.
        skip_dirs: Names of folders not to list (``parts``); hidden ones never are.
        skip_names: Names of files not to list (the page itself); hidden ones never are.

    Returns:
        The files, and what was left out and why; each left-out entry is also warned about
        (``RuntimeWarning``), so nothing is dropped from a page silently.

    Raises:
        FileNotFoundError: ``folder`` is not a folder.
        ValueError: it is not a run folder of a known kind, or a file its manifest records is
            missing, changed, a link or outside it (:meth:`ResultStore.verify`).
    """
    root = Path(folder)
    kind = run_folder_kind(root)
    untrusted = ResultStore(root).verify()
    names = set(skip_names)
    listed, left_out = list_run_files(
        root, skip_dir=lambda name: name in skip_dirs or name.startswith(".")
    )
    left_out = {k: f"it is {v}" for k, v in left_out.items()}
    files = []
    for relative in listed:
        name = relative.rpartition("/")[2]
        if name in names or name.startswith("."):
            continue
        if relative in untrusted:
            left_out[relative] = "it differs from the checksum its manifest records"
            continue
        size = os.lstat(root / relative).st_size
        if size > _MAX_EMBED_BYTES:
            left_out[relative] = f"it is {size} bytes, more than a page embeds"
            continue
        files.append(relative)
    for relative, why in left_out.items():
        warnings.warn(
            f"{root / relative} is left out of the page: {why}", RuntimeWarning, stacklevel=2
        )
    return ReportFiles(kind=kind, files=tuple(files), left_out=left_out)


def check_own_page(run_folder: str | os.PathLike[str], page: str | os.PathLike[str]) -> Path:
    """Refuse to overwrite ``page`` unless a page command wrote it (:data:`PAGE_MARKS`).

    Args:
        run_folder: The run folder the page is of.
        page: The page about to be written (in the run folder or, with ``--out``, elsewhere).

    Returns:
        ``page`` as a Path.

    Raises:
        UnsafeRunFileError: ``page`` is a link, not a regular file, or a file that no page
            command wrote (a user's own ``report.html``), or its folder in the run folder is
            reached through a link.
    """
    target = Path(page)
    check_write_folder(run_folder, target.parent)
    if not os.path.lexists(target):
        return target
    mode = os.lstat(target).st_mode
    if stat.S_ISLNK(mode):
        raise UnsafeRunFileError(
            f"{target} is a symbolic link; it is left as it is and nothing is written through "
            "it: remove it, or give another --out"
        )
    if not stat.S_ISREG(mode):
        raise UnsafeRunFileError(f"{target} exists and is not a regular file; give another --out")
    head = read_run_file(target.parent, target.name, head=_PAGE_HEAD)
    if not any(mark in head for mark in PAGE_MARKS):
        raise UnsafeRunFileError(
            f"{target} exists and was not written by tooldesign html; it is left as it is: "
            "move it away, or give another --out"
        )
    return target
