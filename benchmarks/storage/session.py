"""One session of writing a run folder: start it or resume it, and keep its manifest current.

Both ``tooldesign design`` (one run) and ``tooldesign bench`` (a suite of runs) write a run folder
the same way, through :class:`RunSession`:

1. **Open.** An empty (or absent) folder starts a new run. A folder with content is resumed only
   when asked, and only if its ``manifest.json`` is of this format version and of the same kind
   of run, its config equals this one (apart from the fields that may change between sessions,
   such as the number of workers, and counts that may grow, such as a suite's number of seeds),
   and every part file matches the SHA-256 the manifest records.
   At most one part may be unrecorded: the one written just before a kill, whose manifest
   update was lost. Anything else raises :class:`ResumeError` and changes nothing on disk; a
   config that differs raises :class:`SettingsChanged`, whose message is a compact diff (the
   first differing fields, recorded -> requested, and how many more; see
   :mod:`~benchmarks.storage.configdiff`).
2. **Start.** :meth:`RunSession.start` (once the caller has checked the folder's parts are its
   own) records the session in the manifest and starts the heartbeat.
3. **Write.** :meth:`RunSession.write_batch` writes one part file atomically, records its
   checksum and rewrites the manifest, so the manifest is never more than one part behind.
4. **Close.** :meth:`RunSession.finish` writes the end time, the wall time summed over every
   session, the simulation and optimizer times summed over the evaluation table, and the
   number of evaluations of each status (``extra.evaluation_counts``: total, ok, invalid,
   failed). :meth:`RunSession.write_file` then adds a file written after the final manifest
   (a design run's card).

A session is a context manager, and the ``with`` block owns that sequence::

    with RunSession(out, kind="design", config=config, resume=True) as session:
        logged = check_parts(session.store)   # a refusal here leaves the folder as it was
        session.start()
        for batch in batches:
            session.write_batch(batch)         # one atomic part, one manifest
        session.finish(session.store.read(verify=False))
        session.write_file(out / "design.json", card_text)

Leaving the block before :meth:`~RunSession.finish` (on an exception, or on purpose) stops the
heartbeat, rewrites the manifest with the session's time so far and unlocks the folder; the
heartbeat's file stays, as after a kill, and an exception is never swallowed. A refusal before
:meth:`~RunSession.start` leaves the folder as it was. The folder stays locked until the block
ends, also after :meth:`~RunSession.finish`.

The manifest's ``extra`` holds ``kind`` (what wrote the folder), ``sessions`` (start time and
wall time of each session), ``part_sha256`` (checksums of the part files, by path relative
to the run folder) and ``file_sha256`` (checksums of the other result files the writer records
with :meth:`RunSession.record_file`, e.g. a suite's design files, and of the consolidated
evaluation table, recorded by :meth:`RunSession.finish`), beside whatever the caller adds.

**Checked on resume.** Every file either record lists must exist with its checksum, and the
manifest's own fields the session uses (``start_time``, ``extra.sessions``) must be what this
code writes; otherwise :class:`ResumeError` names the file and the field. A folder written
before ``file_sha256`` existed has none: its files are taken as they are, and the writer records
them from then on. The consolidated table is rewritten at the end of every session, so its
checksum is dropped when a session starts and recorded again when it finishes. It is derived
from the part files: when every part the manifest records is on disk with its checksum, a
table that is missing or differs is rebuilt from them, with a warning, once every other check
has passed. Without recorded parts (a folder shared without ``parts/``) it is the only copy of
the log and is refused like the parts and the design files are.

**Killed sessions keep their time.** The manifest is rewritten after each part, so a session that
is killed would lose the time since its last part (an interrupted iteration can take minutes).
From its first checkpoint on, a session also rewrites ``heartbeat.json`` (its start time and wall
time so far) every :data:`HEARTBEAT_INTERVAL` s from a background thread. :meth:`RunSession.finish`
deletes it, so a folder that holds one was left by a session that did not finish: the next session
raises that session's wall time to the heartbeat's and marks it ``"interrupted": true``. The total
is then short of the truth by at most one interval.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from benchmarks.storage.atomic import atomic_write_text
from benchmarks.storage.configdiff import FieldChange, config_changes, describe_changes
from benchmarks.storage.lock import FolderLock
from benchmarks.storage.manifest import (
    FILE_CHECKSUMS,
    MANIFEST_NAME,
    MANIFEST_VERSION,
    PART_CHECKSUMS,
    REPORT_CHECKSUMS,
    _jsonable,
    build_manifest,
    file_sha256,
    read_manifest,
    recorded_checksums,
    update_file_checksums,
    verify_checksums,
)
from benchmarks.storage.runfiles import read_run_file, refuse_links, run_file_sha256
from benchmarks.storage.table import (
    CONSOLIDATED_STEM,
    ResultStore,
    Unit,
    part_checksums,
    resolve_format,
    status_counts,
    timing_totals,
)

__all__ = [
    "FILE_CHECKSUMS",
    "HEARTBEAT",
    "HEARTBEAT_INTERVAL",
    "PART_CHECKSUMS",
    "ResumeError",
    "RunSession",
    "SettingsChanged",
    "check_out_dir",
    "with_added_fields",
]

HEARTBEAT = "heartbeat.json"
"""File of a running (or killed) session's wall time in the run folder; see the module docstring."""

HEARTBEAT_INTERVAL = 2.0
"""Seconds between two writes of :data:`HEARTBEAT`: the most wall time a killed session loses."""

CLOCK_TOLERANCE = 86_400.0
"""Seconds a session's recorded wall time may exceed the time from its start to now.

A session cannot have lasted longer than the time since it started; the tolerance (a day)
allows for a folder moved between machines whose clocks differ.
"""


class ResumeError(ValueError):
    """A run folder cannot be continued with this config (or was tampered with)."""


class SettingsChanged(ResumeError):
    """A run folder records other settings than the ones asked for now.

    Its message is a compact diff: the folder, the first differing fields (recorded ->
    requested), how many more differ, and how to go on.

    Attributes:
        out: The run folder.
        changes: Every differing field (see :func:`~benchmarks.storage.configdiff.config_changes`).
    """

    def __init__(self, message: str, *, out: Path, changes: list[FieldChange]) -> None:
        super().__init__(message)
        self.out = out
        self.changes = changes


def with_added_fields(config: Mapping[str, Any], added: Mapping[str, Any]) -> dict[str, Any]:
    """A stored ``config`` as its run had it: the fields a later version added, at their old value.

    ``added`` maps a field to the value every run made before it existed had. A value that is a
    table (a mapping) adds its keys to the stored table of that name, keeping the stored ones:
    ``{"scene": {"merge_fixed_links": False}}`` makes a stored ``scene`` without that key read
    as having it ``False``.
    """
    out = {**added, **config}
    for key, value in added.items():
        stored = config.get(key)
        if isinstance(value, Mapping) and isinstance(stored, Mapping):
            out[key] = {**value, **stored}
    return out


def check_out_dir(out_dir: Any) -> Path:
    """``out_dir`` as a path that is not a file.

    Raises:
        TypeError: If it is not a ``str`` or ``os.PathLike``.
        ValueError: If it names an existing file, or is empty (an unset shell variable would
            otherwise write the run into the current folder).
    """
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir must be a path, got {type(out_dir).__name__}")
    if not os.fspath(out_dir).strip():
        raise ValueError(f"--out must name a folder for the run, got {os.fspath(out_dir)!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    return out


def _now() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc)


def _parse_time(value: Any, where: Path, field: str) -> dt.datetime:
    """``value``, a timezone-aware ISO 8601 time as :class:`RunSession` writes, as a datetime.

    Raises:
        ResumeError: Naming the file ``where`` and the ``field`` otherwise.
    """
    moment = None
    if isinstance(value, str):
        try:
            moment = dt.datetime.fromisoformat(value)
        except ValueError:
            moment = None
    if moment is None or moment.utcoffset() is None:
        got = "nothing" if value is None else repr(value)
        raise ResumeError(
            f"cannot resume: {where}: field {field!r} must be a time with its time zone in ISO "
            f"8601 form, e.g. '2026-01-31T12:00:00+00:00', got {got}"
        )
    return moment


def _wall_time_error(wall: Any, start: dt.datetime) -> str | None:
    """Why ``wall`` is not a wall time of a session that started at ``start``; None if it is."""
    limit = max((_now() - start).total_seconds(), 0.0) + CLOCK_TOLERANCE
    if isinstance(wall, bool) or not isinstance(wall, (int, float)):
        got = "nothing" if wall is None else f"{wall!r} ({type(wall).__name__})"
    elif not (math.isfinite(wall) and 0 <= wall <= limit):
        got = repr(wall)
    else:
        return None
    return (
        f"must be a number of seconds from 0 to the time since the session started "
        f"({limit:.0f} s, a day's tolerance included), got {got}"
    )


def _check_wall_time(wall: Any, start: dt.datetime, where: Path, field: str) -> None:
    error = _wall_time_error(wall, start)
    if error is not None:
        raise ResumeError(f"cannot resume: {where}: field {field!r} {error}")


class RunSession:
    """A session of writing one run folder (see the module docstring).

    Args:
        out_dir: The run folder; created by the first write.
        kind: What writes it, e.g. ``"design"`` or ``"suite"``: recorded, and checked on resume.
        config: The JSON form of the run's config.
        resume: Continue a folder that has content; with ``False`` such a folder is an error.
        runtime_fields: Config keys that may differ between sessions (workers, executor, ...).
        growable_fields: Config keys holding a count that a later session may raise but not
            lower (a suite's ``n_seeds``: the runs already made are kept, the new ones added).
        added_fields: Config keys a later version added, with the value every run made before
            had: a manifest without one is compared as if it held that value.
        extra: More JSON-able entries for the manifest's ``extra``; :meth:`update_extra` changes
            them later.
        own_files: The user's files that may sit in ``out_dir`` before the run began, e.g. the
            suite file given with ``--config`` kept with its results: they do not make the
            folder non-empty.
        rewritten_files: Result files every session writes again (a design run's card): their
            recorded checksums are dropped from the first manifest this session writes, so a
            session killed after rewriting one leaves it unrecorded (read unchecked), never
            recorded with the checksum of the file it replaced.
        first_fields: Dotted config fields a refusal for other settings names first (those the
            command's options set); the others follow by name.
        resume_hint: ``resume_hint(out_dir, recorded_config)``: the lines that end a refusal
            for other settings (e.g. the command that continues the folder); by default "use
            the same settings, or another folder".
        heartbeat_interval: Seconds between two writes of :data:`HEARTBEAT`.

    Raises:
        TypeError: If ``out_dir`` is not a path, ``first_fields`` not a list of names or
            ``resume_hint`` not callable.
        ValueError: If ``out_dir`` is a file, or has content and ``resume`` is false, or
            ``heartbeat_interval`` is not a positive finite number of seconds, or a session
            of another process is writing the folder (it holds the folder's lock until it
            closes or its process ends), or a file of ``rewritten_files`` is outside it.
        ResumeError: If the folder cannot be continued (see the module docstring);
            :class:`SettingsChanged` if its config differs from ``config``.
    """

    def __init__(
        self,
        out_dir: Any,
        *,
        kind: str,
        config: Mapping[str, Any],
        resume: bool,
        runtime_fields: Iterable[str] = (),
        growable_fields: Iterable[str] = (),
        added_fields: Mapping[str, Any] | None = None,
        extra: Mapping[str, Any] | None = None,
        own_files: Iterable[str | os.PathLike[str]] = (),
        rewritten_files: Iterable[str | os.PathLike[str]] = (),
        first_fields: Sequence[str] = (),
        resume_hint: Callable[[Path, Mapping[str, Any]], Sequence[str]] | None = None,
        heartbeat_interval: float = HEARTBEAT_INTERVAL,
    ) -> None:
        self.out = check_out_dir(out_dir)
        if (
            isinstance(heartbeat_interval, bool)
            or not isinstance(heartbeat_interval, (int, float))
            or not (math.isfinite(heartbeat_interval) and heartbeat_interval > 0)
        ):
            raise ValueError(
                f"heartbeat_interval must be a positive finite number of seconds, got "
                f"{heartbeat_interval!r}"
            )
        self._heartbeat_interval = float(heartbeat_interval)
        self._heartbeat: _Heartbeat | None = None
        self._closed = False
        self._started = False
        self._finished = False
        self._in_block = False
        if isinstance(first_fields, str) or not all(isinstance(f, str) for f in first_fields):
            raise TypeError(f"first_fields must be a list of field names, got {first_fields!r}")
        if resume_hint is not None and not callable(resume_hint):
            raise TypeError(
                f"resume_hint must be a function of (out_dir, recorded config), got "
                f"{type(resume_hint).__name__}"
            )
        self._first_fields = tuple(first_fields)
        self._resume_hint = resume_hint
        # One session at a time per folder: a second one would redo the work and then fail on
        # the first one's parts. Taken now if the folder exists, else when it is first written.
        self._lock = FolderLock(self.out)
        self._lock.acquire_if_present()
        try:
            self._own = frozenset(Path(f).resolve() for f in own_files)
            self.kind = kind
            self.config = dict(config)
            self._runtime = frozenset(runtime_fields)
            self._growable = frozenset(growable_fields)
            self._added = dict(added_fields or {})
            self.store = ResultStore(self.out)
            self._clock = time.perf_counter()
            self._session: dict[str, Any] = {"start_time": _now().isoformat(), "wall_time": 0.0}
            self._extra: dict[str, Any] = dict(extra or {})
            self._damaged_tables: list[str] = []  # found by _verify_parts
            rewritten = [self._relative(path) for path in rewritten_files]
            previous = self._previous(bool(resume))
            self.resumed = previous is not None
            if previous is None:
                self.start_time = _now()
                self.sessions: list[dict[str, Any]] = [self._session]
                self._checksums: dict[str, str] = {}
                self._files: dict[str, str] = {}
            else:
                self.start_time, sessions = self._previous_times(previous)
                earlier = self._with_killed_session(
                    sessions, finished=previous.get("end_time") is not None
                )
                self.sessions = [*earlier, self._session]
                self._checksums = part_checksums(self.store)  # verified in _previous
                # Verified in _previous too. The consolidated table is rewritten by finish().
                files = recorded_checksums(previous, FILE_CHECKSUMS, self.out / MANIFEST_NAME)
                self._files = {k: v for k, v in (files or {}).items() if not _is_table(k)}
                self.store.remove_stale_temp_files()  # only this process writes here
                self._rebuild_tables()
            for relative in rewritten:
                self._files.pop(relative, None)
            # The parts of the manifest that do not change within a session (packages, commit,
            # host) are collected once: a manifest is rewritten after every part.
            self._base = build_manifest(config=self.config, start_time=self.start_time)
        except BaseException:
            self._lock.release()  # a refused session leaves the folder to the next one
            raise

    # --- opening -------------------------------------------------------------------------------

    def _previous(self, resume: bool) -> dict[str, Any] | None:
        """The manifest of the run to continue, ``None`` for a new run; refuses to mix runs."""
        out = self.out
        if not (out.is_dir() and any(p.resolve() not in self._own for p in out.iterdir())):
            return None
        if not resume:
            raise ValueError(
                f"--out {out} exists and is not empty; pass --resume (API: resume=True) to "
                "continue the run in it, or choose another folder"
            )
        try:
            manifest = read_manifest(out)
        except FileNotFoundError:
            raise ResumeError(
                f"cannot resume: {out} is not empty and has no manifest.json, so it is not a "
                f"{self.kind} run folder; choose another folder"
            ) from None
        except ValueError as error:
            raise ResumeError(f"cannot resume: {error}") from None
        heartbeat = out / HEARTBEAT
        if heartbeat.exists() and not heartbeat.is_file():
            raise ResumeError(
                f"cannot resume: {heartbeat} is not a file; it is the file a session writes its "
                "wall time to: remove it"
            )
        if manifest.get("format_version") != MANIFEST_VERSION:
            raise ResumeError(
                f"cannot resume: {out} was written by an incompatible version (manifest "
                f"format_version {manifest.get('format_version')!r}, this version writes "
                f"{MANIFEST_VERSION}); start a new run folder"
            )
        old, extra = manifest.get("config"), manifest.get("extra")
        where = out / MANIFEST_NAME
        if "extra" in manifest and not isinstance(extra, dict):
            raise ResumeError(
                f"cannot resume: {where}: field 'extra' must be a JSON object (the run's kind, "
                f"sessions and checksums), got {_json_kind(extra)}; the manifest was edited or "
                "damaged: restore it or start a new run folder"
            )
        if not isinstance(extra, dict) or extra.get("kind") != self.kind:
            kind = extra.get("kind") if isinstance(extra, dict) else None
            raise ResumeError(
                f"cannot resume: {out} is {_kind_words(kind)}, not a {self.kind} run folder (a "
                "run of another kind); choose another folder"
            )
        # Checked apart from the kind: a folder of the right kind whose config was edited away
        # must not be called a folder of another kind (it would name its own kind twice).
        if not isinstance(old, dict):
            got = _json_kind(old) if "config" in manifest else "nothing"
            raise ResumeError(
                f"cannot resume: {where}: field 'config' must be a JSON object of the run's "
                f"settings, got {got}; the manifest was edited or damaged: restore it or start "
                "a new run folder"
            )
        self._verify_parts(extra)
        old = with_added_fields(old, self._added)
        changes = config_changes(old, self.config, ignore=self._runtime, allowed=self._grows)
        if changes:
            raise SettingsChanged(self._settings_message(old, changes), out=out, changes=changes)
        return manifest

    def _settings_message(self, recorded: Mapping[str, Any], changes: list[FieldChange]) -> str:
        """The refusal for other settings: one line if it is short, else a few short lines."""
        lines = describe_changes(changes, first=self._first_fields)
        head = f"cannot resume: the run in {self.out} was made with other settings"
        advice = ["use the same settings, or another folder"]
        if self._resume_hint is not None:
            advice = list(self._resume_hint(self.out, recorded)) or advice
        detail = "; ".join(line.strip() for line in lines)
        if len(advice) == 1 and len(changes) == len(lines) and len(detail) <= 160:
            return f"{head} ({detail}); {advice[0]}"
        return "\n".join([f"{head} (recorded -> requested):", *lines, *advice])

    def _with_killed_session(self, sessions: list[Any], *, finished: bool) -> list[Any]:
        """``sessions`` with the wall time of a session that was killed taken from its heartbeat.

        Its manifest was last written after its last part; :data:`HEARTBEAT` was written every
        few seconds until the kill. A heartbeat that cannot be read, or that names no session
        of the manifest, is reported and left out: it only ever adds time, never results. The
        session it names is marked interrupted, and so is the last one of a run that has no end
        time (``finished`` false) when no heartbeat was left (killed before its first beat).
        """
        path = self.out / HEARTBEAT
        if not os.path.lexists(path):
            return _mark_last_interrupted(sessions) if not finished else list(sessions)
        try:
            raw = read_run_file(self.out, HEARTBEAT, max_bytes=1 << 16)
            beat = json.loads(raw.decode("utf-8"))
            if not isinstance(beat, dict):
                raise ValueError(f"it must hold a JSON object, got {type(beat).__name__}")
            start = beat.get("start_time")
            wall: Any = beat.get("wall_time")
            try:
                began = _parse_time(start, path, "start_time")
            except ResumeError:
                raise ValueError(
                    f"field 'start_time' must be an ISO 8601 time with its zone, got {start!r}"
                ) from None
            error = _wall_time_error(wall, began)
            if error is not None:
                raise ValueError(f"field 'wall_time' {error}")
        except (OSError, ValueError, RecursionError) as error:
            warnings.warn(
                f"{path} cannot be read ({error}); the wall time of the session that was "
                "interrupted is counted up to its last part only",
                RuntimeWarning,
                stacklevel=3,
            )
            return _mark_last_interrupted(sessions) if not finished else list(sessions)
        out = []
        matched = False
        for session in sessions:
            if isinstance(session, dict) and session.get("start_time") == start:
                matched = True
                # Killed at once with its process group, the session may have recorded as much
                # time as its last beat: interrupted all the same.
                longest = max(float(wall), float(session.get("wall_time", 0.0)))
                session = {**session, "wall_time": longest, "interrupted": True}
            out.append(session)
        if not matched:
            out = _mark_last_interrupted(out) if not finished else out
            warnings.warn(
                f"{path} is of a session ({start}) that manifest.json does not record; its "
                "wall time is left out",
                RuntimeWarning,
                stacklevel=3,
            )
        return out

    def _grows(self, key: str, old: Any, new: Any) -> bool:
        """Whether ``key`` is a growable count that this session raises (e.g. more seeds)."""
        return key in self._growable and all(type(v) is int for v in (old, new)) and new >= old

    def _previous_times(self, manifest: Mapping[str, Any]) -> tuple[dt.datetime, list[Any]]:
        """The start time and the sessions of the manifest to continue, checked."""
        where = self.out / MANIFEST_NAME
        start = _parse_time(manifest.get("start_time"), where, "start_time")
        sessions = manifest["extra"].get("sessions", [])
        if not isinstance(sessions, list):
            raise ResumeError(
                f"cannot resume: {where}: field 'extra.sessions' must be a list of sessions "
                f"({{'start_time': ISO time, 'wall_time': seconds}}), got {type(sessions).__name__}"
            )
        for i, session in enumerate(sessions):
            field = f"extra.sessions[{i}]"
            if not isinstance(session, dict):
                raise ResumeError(
                    f"cannot resume: {where}: field {field!r} must be an object with "
                    f"'start_time' and 'wall_time', got {type(session).__name__}"
                )
            began = _parse_time(session.get("start_time"), where, f"{field}.start_time")
            _check_wall_time(session.get("wall_time"), began, where, f"{field}.wall_time")
        return start, sessions

    def _verify_parts(self, extra: Mapping[str, Any]) -> None:
        manifest = self.out / MANIFEST_NAME
        try:
            recorded = recorded_checksums({"extra": extra}, PART_CHECKSUMS, manifest)
            files = recorded_checksums({"extra": extra}, FILE_CHECKSUMS, manifest)
        except ValueError as error:
            raise ResumeError(f"cannot resume: {error}") from None
        if recorded is None:
            raise ResumeError(
                f"cannot resume: {manifest} records no part checksums ({PART_CHECKSUMS!r}): it "
                "was written by an incompatible version or edited"
            )
        files = dict(files or {})
        try:
            refuse_links(self.out)  # a linked parts/ or designs/ would be written through
            verify_checksums(self.out, recorded)
            if recorded:
                # The consolidated table is derived: every part it was made from is on disk with
                # its recorded checksum (just verified), so a damaged or deleted table is made
                # again from them (_rebuild_tables) rather than blocking the resume. Without
                # recorded parts (a folder shared without parts/) the table is the only copy of
                # the log, and is checked as original data.
                for relative in [k for k in files if _is_table(k)]:
                    if (self.out / relative).is_dir():
                        continue  # not a table to replace: refused below
                    digest = files.pop(relative)
                    if not _intact(self.out / relative, digest):
                        self._damaged_tables.append(relative)
            verify_checksums(self.out, files)
        except ValueError as error:
            raise ResumeError(f"cannot resume: {error}") from None
        unrecorded = sorted(set(part_checksums(self.store)) - set(recorded))
        if len(unrecorded) > 1:
            raise ResumeError(
                f"cannot resume: {self.out} holds part files the manifest does not record: "
                f"{unrecorded}"
            )

    def _rebuild_tables(self) -> None:
        """Make the damaged or missing consolidated tables again from the verified part files.

        Called once every check of the folder has passed, so a refused resume still leaves the
        folder as it was. The table is written in its recorded format (CSV where Parquet is
        recorded but pyarrow is missing) and the manifest records its new checksum.
        """
        for relative in self._damaged_tables:
            path = self.out / relative
            what = "was missing" if not path.exists() else "had changed since it was written"
            parquet = relative.endswith(".parquet") and resolve_format() == "parquet"
            target = self.store.consolidate(format="parquet" if parquet else "csv")
            warnings.warn(
                f"{path} {what}; rebuilt as {target.name} from the part files, whose checksums "
                "match the manifest",
                RuntimeWarning,
                stacklevel=4,
            )
        self._damaged_tables = []

    # --- writing -------------------------------------------------------------------------------

    @property
    def session_time(self) -> float:
        """Wall time of this session so far, s."""
        return time.perf_counter() - self._clock

    @property
    def wall_time(self) -> float:
        """Wall time summed over every session of the folder, this one up to now, s."""
        self._session["wall_time"] = self.session_time
        return float(sum(s["wall_time"] for s in self.sessions))

    def record_file(self, path: str | os.PathLike[str]) -> None:
        """Record the SHA-256 of a result file of the run (written at the next checkpoint).

        Call it once the file is written for good: a later session, ``tooldesign report`` and
        :meth:`ResultStore.read` refuse the folder if the file then differs.

        Args:
            path: A file inside the run folder.
        """
        self._files[self._relative(path)] = file_sha256(path)

    def forget_file(self, path: str | os.PathLike[str]) -> None:
        """Drop the recorded SHA-256 of a file that is about to be rewritten (or is gone).

        Once the session has started, the manifest is rewritten at once if it recorded the
        file, so the record is gone from disk before the file is rewritten; before
        :meth:`start`, the record is left out of the first manifest the session writes.
        """
        recorded = self._files.pop(self._relative(path), None)
        if recorded is not None and self._started and not self._closed:
            self.checkpoint()

    def is_recorded(self, path: str | os.PathLike[str]) -> bool:
        """Whether the manifest records the SHA-256 of ``path`` (see :meth:`record_file`)."""
        return self._relative(path) in self._files

    def _relative(self, path: str | os.PathLike[str]) -> str:
        try:
            return Path(path).resolve().relative_to(self.out.resolve()).as_posix()
        except ValueError:
            raise ValueError(f"{path} is not inside the run folder {self.out}") from None

    def write_file(self, path: str | os.PathLike[str], text: str) -> Path:
        """Write a result file of the run atomically and record its SHA-256.

        Before :meth:`finish` the record goes into the next manifest (its old record is dropped
        first, see :meth:`forget_file`); after it, into the final manifest on disk at once, old
        record first, so a kill between the writes leaves the file unrecorded, never recorded
        with the checksum of the file it replaced.

        Args:
            path: A file inside the run folder.
            text: Its text, written as UTF-8.

        Returns:
            ``path`` as a :class:`~pathlib.Path`.
        """
        target = Path(path)
        relative = self._relative(target)
        if not self._finished:
            self.forget_file(target)
            atomic_write_text(target, text)
            self.record_file(target)
            return target
        self._files.pop(relative, None)
        update_file_checksums(self.out, {relative: None})
        atomic_write_text(target, text)
        self._files[relative] = file_sha256(target)
        update_file_checksums(self.out, {relative: self._files[relative]})
        return target

    def update_extra(self, **entries: Any) -> None:
        """Set entries of the manifest's ``extra`` (written at the next checkpoint)."""
        self._extra.update(entries)

    def write_batch(self, rows: pd.DataFrame) -> Unit:
        """Write one batch as a part file, record its checksum, and rewrite the manifest."""
        unit = self.store.write_batch(rows)
        path = self.store.part_path(unit)
        self._checksums[path.relative_to(self.out).as_posix()] = file_sha256(path)
        self.checkpoint()
        return unit

    def manifest(
        self, *, end: dt.datetime | None = None, evaluations: pd.DataFrame | None = None
    ) -> dict[str, Any]:
        """The manifest as it stands now (``end`` and ``evaluations`` when the run is done)."""
        totals = timing_totals(evaluations) if evaluations is not None and len(evaluations) else {}
        if evaluations is not None:
            # The run says how many evaluations failed (a worker error or a worker that kept
            # dying) where a reader of the folder looks first.
            self._extra["evaluation_counts"] = status_counts(evaluations)
        manifest = dict(self._base)
        manifest.update(
            end_time=None if end is None else end.isoformat(),
            wall_time=self.wall_time,
            simulation_time=totals.get("simulation_time"),
            optimizer_time=totals.get("optimizer_time"),
        )
        extra = {
            "kind": self.kind,
            "sessions": self.sessions,
            PART_CHECKSUMS: dict(sorted(self._checksums.items())),
            FILE_CHECKSUMS: dict(sorted(self._files.items())),
            # The report files are written once the session is over (record_report_files); a
            # session's results make the earlier ones stale, so their records start empty.
            REPORT_CHECKSUMS: {},
            **self._extra,
        }
        manifest["extra"] = _jsonable(extra, "extra")  # refuses NaN and what JSON cannot store
        return manifest

    def start(self) -> None:
        """Begin writing: the first manifest of this session, and its heartbeat.

        Call it once the folder's content is known to be this run's (the caller's own checks of
        its parts, which may still refuse the folder and leave it as it was), before the long
        work: a session killed later keeps its time (see the module docstring). The first
        :meth:`write_batch` starts the session too.
        """
        self.checkpoint()

    def checkpoint(self) -> None:
        """Rewrite the manifest: times so far, checksums, ``extra``; start the heartbeat."""
        self._started = True
        self.store.write_manifest(self.manifest())
        if not self._closed:  # a closed session (stopped on an error) leaves the folder free
            self._lock.acquire_if_present()
        if self._heartbeat is None and not self._closed:
            self._heartbeat = _Heartbeat(
                self.out / HEARTBEAT,
                self._session["start_time"],
                self._clock,
                self._heartbeat_interval,
            )
            self._heartbeat.start()

    def finish(
        self, evaluations: pd.DataFrame | None, *, keep_lock: bool = False
    ) -> dict[str, Any]:
        """Write the final manifest (end time, summed times) and delete the heartbeat.

        The consolidated evaluation table, if the caller wrote one, is recorded in
        ``file_sha256``. Inside a ``with`` block the folder stays locked until the block ends
        (files written after the manifest go through :meth:`write_file`); outside one, only
        with ``keep_lock``, until :meth:`release`.
        """
        self._finished = True
        self.close(keep_lock=keep_lock or self._in_block)
        consolidated = self.store.consolidated_path()
        if consolidated is not None:
            self.record_file(consolidated)
        manifest = self.manifest(end=_now(), evaluations=evaluations)
        self.store.write_manifest(manifest)
        (self.out / HEARTBEAT).unlink(missing_ok=True)
        return manifest

    def close(self, *, keep_lock: bool = False) -> None:
        """Stop the heartbeat for good; its file stays, as after a kill.

        :meth:`finish` calls this. A caller whose run stops on an error calls it too, so that no
        thread keeps writing into the folder; the next session then counts this one's time. The
        folder's lock is released too, unless ``keep_lock`` (then :meth:`release` does it).
        """
        self._closed = True
        if self._heartbeat is not None:
            self._heartbeat.stop()
            self._heartbeat = None
        if not keep_lock:
            self.release()

    def release(self) -> None:
        """Unlock the folder for other processes (:meth:`close` does it unless told not to)."""
        self._lock.release()

    def __enter__(self) -> RunSession:
        self._in_block = True
        return self

    def __exit__(self, kind: type[BaseException] | None, error: object, trace: object) -> None:
        """End the session: see the module docstring. An exception is never swallowed."""
        self._in_block = False
        try:
            if self._started and not self._finished:
                # Stopped by an error, or left unfinished on purpose: the manifest keeps the
                # session's time so far and the files recorded since the last part. The
                # heartbeat's file stays, as after a kill.
                self.close(keep_lock=True)
                try:
                    self.checkpoint()
                except Exception:
                    if kind is None:
                        raise  # else the error that ended the block is the one to see
        finally:
            self.close()


def _mark_last_interrupted(sessions: list[Any]) -> list[Any]:
    """``sessions`` with the last one marked ``"interrupted": true`` (it did not finish)."""
    out = list(sessions)
    if out and isinstance(out[-1], dict):
        out[-1] = {**out[-1], "interrupted": True}
    return out


class _Heartbeat(threading.Thread):
    """Rewrites ``path`` with the session's wall time every ``interval`` s until stopped."""

    def __init__(self, path: Path, start_time: str, clock: float, interval: float) -> None:
        super().__init__(name="tooldesign-heartbeat", daemon=True)
        self._path, self._start, self._clock, self._interval = path, start_time, clock, interval
        self._stopped = threading.Event()

    def beat(self) -> None:
        if not self._path.parent.is_dir():  # the folder was removed under the run
            return
        wall = time.perf_counter() - self._clock
        text = json.dumps({"start_time": self._start, "wall_time": wall})
        try:
            atomic_write_text(self._path, text + "\n", durable=False)
        except OSError:  # a full disk must not kill the run: the manifest reports the error
            pass

    def run(self) -> None:
        self.beat()
        while not self._stopped.wait(self._interval):
            self.beat()

    def stop(self) -> None:
        self._stopped.set()
        self.join()


#: The command that makes (and continues) a run folder of each kind, for messages.
_KIND_COMMANDS = {
    "design": "tooldesign design --resume",
    "suite": "tooldesign bench",
    "rl-suite": "tooldesign bench rl",
}


def _kind_words(kind: object) -> str:
    """A run folder's kind in words, with the command that continues it."""
    if kind in _KIND_COMMANDS:
        return f"a {kind} run folder (continue it with `{_KIND_COMMANDS[str(kind)]}`)"
    return f"a run folder of kind {kind!r}" if kind is not None else "a run folder of unknown kind"


def _json_kind(value: object) -> str:
    """What a JSON value is, in the words of a message: ``null``, ``a list``, ``an int``, ..."""
    if value is None:
        return "null"
    name = type(value).__name__
    return f"{'an' if name[0] in 'aeiou' else 'a'} {name} ({value!r:.40})"


def _is_table(relative: str) -> bool:
    """Whether a path recorded in ``file_sha256`` is the consolidated evaluation table."""
    return relative.rpartition(".")[0] == CONSOLIDATED_STEM


def _intact(path: Path, digest: str) -> bool:
    """Whether ``path`` is a regular file (not a link) whose SHA-256 is ``digest``."""
    try:
        return run_file_sha256(path.parent, Path(path)) == digest
    except (OSError, ValueError):
        return False
