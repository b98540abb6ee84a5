"""What a run folder is, and which of its files a page may show: the readers' one gate.

:func:`run_folder_kind` says which command wrote a folder (its manifest's ``extra.kind``, or
the files of ``tooldesign evaluate``) and refuses any other folder; :func:`report_files` lists
the files a report page may embed: regular files inside the folder only (no link followed, no
FIFO opened), after the whole folder was checked against its manifest's checksums, without the
consolidated table when it differs from its checksum (:meth:`ResultStore.verify`), without a
report file that differs from the checksum :func:`record_report_files` recorded when the report
was written, and naming what it left out. :func:`read_report_file` checks one file the same way
for a reader that uses its numbers (``tooldesign reproduce``, ``equivalence verdicts``).
:func:`check_own_page` refuses to overwrite a page the command did not write.

A folder whose manifest records both its result files and its report files is taken to record
everything its commands wrote: a file it records nowhere is left out. A folder written before
(no report record) shows such files marked "unchecked", and one whose manifest records the
report's files leaves out an unrecorded file under ``report/``.
"""

from __future__ import annotations

import hashlib
import os
import stat
import warnings
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

from benchmarks.storage.manifest import (
    FILE_CHECKSUMS,
    MANIFEST_NAME,
    PART_CHECKSUMS,
    REPORT_CHECKSUMS,
    read_manifest,
    recorded_checksums,
    update_file_checksums,
)
from benchmarks.storage.runfiles import (
    UnsafeRunFileError,
    check_write_folder,
    list_run_files,
    read_run_file,
    run_file_sha256,
)
from benchmarks.storage.table import ResultStore

__all__ = [
    "EVALUATE_KIND",
    "PROTOCOL_KIND",
    "PAGE_MARKS",
    "RUN_KINDS",
    "ReportFiles",
    "check_own_page",
    "read_report_file",
    "record_report_files",
    "report_files",
    "run_folder_kind",
]

_HEARTBEAT = "heartbeat.json"  # benchmarks.storage.session.HEARTBEAT: the session's clock

RUN_KINDS: tuple[str, ...] = ("design", "suite", "rl-suite")
"""The ``extra.kind`` of the manifests the commands write: ``tooldesign design``, ``bench``,
``bench rl`` (``benchmarks.design.config.DESIGN_SUITE``, ``benchmarks.suites.config.SUITE_KIND``,
``benchmarks.rl.suite.RL_SUITE_KIND``; a test keeps them equal)."""

EVALUATE_KIND = "evaluate"
"""The kind of a ``tooldesign evaluate`` folder: no manifest, its ``terms.json`` and
``tool.urdf``."""

_EVALUATE_FILES = ("terms.json", "tool.urdf")

PROTOCOL_KIND = "protocol"
"""The kind of a ``tooldesign bench protocol`` folder: no manifest of its own, its
``protocol.json`` (``benchmarks.protocol.suite.PROTOCOL_FILE``; a test keeps them equal), one
suite run folder per cell under ``cells/`` and the IOHprofiler files under ``ioh/``."""

_PROTOCOL_FILE = "protocol.json"
_PROTOCOL_DATA = frozenset({"cells", "ioh"})  # data, not a page: each cell has its own report

PAGE_MARKS: tuple[bytes, ...] = (
    b'<meta name="generator" content="tooldesign html">',
    b"<title>tooldesign report: ",  # the pages written before the generator mark
)
"""How a page written by ``tooldesign html`` starts (one of these in its first 4 kB)."""

_PAGE_HEAD = 4096
_MAX_EMBED_BYTES = 64 << 20  # a design's rollout GIF is a few MB


def run_folder_kind(folder: str | os.PathLike[str]) -> str:
    """Which command wrote ``folder``: a :data:`RUN_KINDS`, or evaluate's, or the protocol's.

    One of :data:`RUN_KINDS`, :data:`EVALUATE_KIND` or :data:`PROTOCOL_KIND`.

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
    if _regular(root / _PROTOCOL_FILE):
        return PROTOCOL_KIND
    raise ValueError(
        f"{root} is not a run folder: it has no {MANIFEST_NAME} (a design, bench or bench rl "
        f"run), no {' and '.join(_EVALUATE_FILES)} (tooldesign evaluate) and no "
        f"{_PROTOCOL_FILE} (tooldesign bench protocol); give the folder a tooldesign command "
        "wrote"
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
        left_out: ``{relative path: why}``: links, FIFOs, files too large to embed,
            consolidated tables and report files that differ from their checksum, and (in a
            folder whose manifest records its files) files it does not record.
        unchecked: The files of ``files`` that no record of the manifest names, in a folder
            written before the manifest recorded them (or by ``tooldesign evaluate``, which
            writes none): shown, marked as unchecked.
    """

    kind: str
    files: tuple[str, ...]
    left_out: dict[str, str]
    unchecked: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Records:
    """What a run folder's manifest records: the checked files, and how strict to be."""

    checked: frozenset[str]  # parts and result files: verified by ResultStore.verify
    reports: dict[str, str]  # report files: {relative path: sha256}
    all_recorded: bool  # every file the commands write is recorded: others are left out
    reports_recorded: bool  # the report files are recorded: others under report/ left out

    def strict(self, relative: str) -> bool:
        """Whether ``relative``, recorded nowhere, is left out (else shown unchecked)."""
        return self.all_recorded or (self.reports_recorded and relative.startswith("report/"))


def _records(root: Path) -> _Records:
    if not os.path.lexists(root / MANIFEST_NAME):
        return _Records(frozenset(), {}, all_recorded=False, reports_recorded=False)
    manifest = read_manifest(root)
    where = root / MANIFEST_NAME
    parts = recorded_checksums(manifest, PART_CHECKSUMS, where)
    files = recorded_checksums(manifest, FILE_CHECKSUMS, where)
    reports = recorded_checksums(manifest, REPORT_CHECKSUMS, where)
    return _Records(
        checked=frozenset({*(parts or {}), *(files or {})}),
        reports=dict(reports or {}),
        all_recorded=files is not None and reports is not None,
        reports_recorded=reports is not None,
    )


def _report_status(root: Path, relative: str, records: _Records) -> str | None:
    """Why ``relative`` is left out (it differs from its record), or None: it matches."""
    try:
        actual = run_file_sha256(root, relative)
    except (OSError, ValueError) as err:
        return f"it cannot be checked ({err})"
    if actual != records.reports[relative]:
        return (
            "it differs from the checksum its manifest records (edited after the report was "
            "written; tooldesign report writes it again)"
        )
    return None


_UNRECORDED = "its manifest does not record it (it was not written by the run or its report)"


def record_report_files(
    run_folder: str | os.PathLike[str], paths: Collection[str | os.PathLike[str]]
) -> dict[str, str]:
    """Record the SHA-256 of report files just written into a run folder's manifest.

    The manifest's :data:`~benchmarks.storage.manifest.REPORT_CHECKSUMS` then names them, so
    that a reader shows them only while they are as written (:func:`report_files`,
    :func:`read_report_file`). Files outside the folder (``--out``) are the user's and are not
    recorded; a folder without a manifest (a bare store, an ``evaluate`` folder) records
    nothing. A kill between a file and its record leaves a file that differs from its old
    record: a reader leaves it out, never shows it as checked.

    Args:
        run_folder: The run folder.
        paths: The files written (absolute, or relative to the current folder).

    Returns:
        ``{path relative to the run folder: sha256}`` of what was recorded.

    Raises:
        UnsafeRunFileError: a file is a link or not a regular file.
        ValueError: the manifest cannot be read or a session of another process writes it.
    """
    root = Path(run_folder)
    if not os.path.lexists(root / MANIFEST_NAME):
        return {}
    real_root = Path(os.path.realpath(root))
    changes: dict[str, str] = {}
    for path in paths:
        # The folder it was written to was checked (check_write_folder): its real path says
        # whether it lies in the run folder; the file itself is hashed without following a link.
        folder = Path(os.path.realpath(Path(path).parent))
        if folder != real_root and real_root not in folder.parents:
            continue
        relative = (folder / Path(path).name).relative_to(real_root).as_posix()
        changes[relative] = run_file_sha256(real_root, relative)
    if changes:
        update_file_checksums(root, changes, key=REPORT_CHECKSUMS)
    return changes


def read_report_file(run_folder: str | os.PathLike[str], relative: str) -> bytes | None:
    """The bytes of a file of a run folder a reader uses, if it is as the manifest records.

    A file the manifest records among the results (parts, designs, retests) must match its
    checksum (else ``ValueError``); a report file (``report/summary.csv``) that differs from its
    record, or that the manifest does not record although it records the report's files, is
    left out: ``None``, with a ``RuntimeWarning`` naming it. A file of a folder written before
    its manifest recorded report files is read as it is, with a warning that it is unchecked.
    A folder without a manifest is read as it is (nothing can be checked).

    Args:
        run_folder: The run folder.
        relative: The file, relative to it (``/`` between parts).

    Returns:
        The bytes, or ``None`` if the file is absent or left out.

    Raises:
        UnsafeRunFileError: the path leaves the folder, or the file is a link, FIFO, ...
        ValueError: a file the manifest records among the results differs from its checksum.
    """
    root = Path(run_folder)
    if not os.path.lexists(root / relative):
        return None
    if not os.path.lexists(root / MANIFEST_NAME):
        return read_run_file(root, relative)
    manifest = read_manifest(root)
    where = root / MANIFEST_NAME
    for key in (PART_CHECKSUMS, FILE_CHECKSUMS, REPORT_CHECKSUMS):
        recorded = recorded_checksums(manifest, key, where) or {}
        if relative not in recorded:
            continue
        if key != REPORT_CHECKSUMS:
            return read_run_file(root, relative, expected_sha256=recorded[relative])
        data = read_run_file(root, relative)
        actual = hashlib.sha256(data).hexdigest()
        if actual != recorded[relative]:
            warnings.warn(
                f"{root / relative} has changed since its report was written (sha256 "
                f"{actual[:12]}..., the manifest records {recorded[relative][:12]}...): it is "
                "left out; tooldesign report writes it again",
                RuntimeWarning,
                stacklevel=2,
            )
            return None
        return data
    if recorded_checksums(manifest, REPORT_CHECKSUMS, where) is not None:
        warnings.warn(f"{root / relative} is left out: {_UNRECORDED}", RuntimeWarning, stacklevel=2)
        return None
    warnings.warn(
        f"{root / relative} is read unchecked: {where} records no checksums of the report "
        "files (it was written before they were recorded; tooldesign report records them)",
        RuntimeWarning,
        stacklevel=2,
    )
    return read_run_file(root, relative)


def report_files(
    folder: str | os.PathLike[str],
    *,
    skip_dirs: Collection[str] = (),
    skip_names: Collection[str] = (),
    suffixes: Collection[str] = (),
) -> ReportFiles:
    """The files of the run folder ``folder`` a report page may embed, after checking it.

    Args:
        folder: The run folder.
        skip_dirs: Names of folders not to list (``parts``); hidden ones never are.
        skip_names: Names of files not to list (the page itself); hidden ones never are.
        suffixes: List only files with these endings (``".png"``, ...: what the page
            embeds); all if empty.

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
    records = _records(root)
    names = {*skip_names, _HEARTBEAT}  # the session's clock: no result
    wanted = {s.lower() for s in suffixes}
    skipped = {*skip_dirs, *(_PROTOCOL_DATA if kind == PROTOCOL_KIND else ())}
    listed, left_out = list_run_files(
        root, skip_dir=lambda name: name in skipped or name.startswith(".")
    )
    left_out = {k: f"it is {v}" for k, v in left_out.items()}
    files: list[str] = []
    unchecked: list[str] = []
    for relative in listed:
        name = relative.rpartition("/")[2]
        if name in names or name.startswith("."):
            continue
        if wanted and Path(name).suffix.lower() not in wanted:
            continue
        if relative in untrusted:
            left_out[relative] = "it differs from the checksum its manifest records"
            continue
        size = os.lstat(root / relative).st_size
        if size > _MAX_EMBED_BYTES:
            left_out[relative] = f"it is {size} bytes, more than a page embeds"
            continue
        if relative in records.reports and relative not in records.checked:
            why = _report_status(root, relative, records)
            if why is not None:
                left_out[relative] = why
                continue
        elif relative not in records.checked and relative != MANIFEST_NAME:
            if records.strict(relative):
                left_out[relative] = _UNRECORDED
                continue
            unchecked.append(relative)
        files.append(relative)
    for relative, why in left_out.items():
        warnings.warn(
            f"{root / relative} is left out of the page: {why}", RuntimeWarning, stacklevel=2
        )
    if unchecked and kind not in (EVALUATE_KIND, PROTOCOL_KIND):
        # evaluate and the protocol record no checksums of their pages' files: the page says so
        warnings.warn(
            f"{len(unchecked)} files of {root} are shown unchecked, marked so on the page: its "
            "manifest records no checksums for them (a folder written before they were "
            "recorded, or by tooldesign evaluate); tooldesign report records the report's",
            RuntimeWarning,
            stacklevel=2,
        )
    return ReportFiles(kind=kind, files=tuple(files), left_out=left_out, unchecked=tuple(unchecked))


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
