"""One session of writing a run folder: start it or resume it, and keep its manifest current.

Both ``tooldesign design`` (one run) and ``tooldesign bench`` (a suite of runs) write a run folder
the same way, through :class:`RunSession`:

1. **Open.** An empty (or absent) folder starts a new run. A folder with content is resumed only
   when asked, and only if its ``manifest.json`` is of this format version and of the same kind
   of run, its config equals this one (apart from the fields that may change between sessions,
   such as the number of workers, and counts that may grow, such as a suite's number of seeds),
   and every part file matches the SHA-256 the manifest records.
   At most one part may be unrecorded: the one written just before a kill, whose manifest
   update was lost. Anything else raises :class:`ResumeError` and changes nothing on disk.
2. **Write.** :meth:`RunSession.write_batch` writes one part file atomically, records its
   checksum and rewrites the manifest, so the manifest is never more than one part behind.
3. **Close.** :meth:`RunSession.finish` writes the end time, the wall time summed over every
   session, the simulation and optimizer times summed over the evaluation table, and the
   number of evaluations of each status (``extra.evaluation_counts``: total, ok, invalid,
   failed).

The manifest's ``extra`` holds ``kind`` (what wrote the folder), ``sessions`` (start time and
wall time of each session) and ``part_sha256`` (checksums of the part files, by path relative
to the run folder), beside whatever the caller adds.
"""

from __future__ import annotations

import datetime as dt
import os
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from benchmarks.storage.manifest import (
    MANIFEST_VERSION,
    _jsonable,
    build_manifest,
    file_sha256,
    read_manifest,
    verify_checksums,
)
from benchmarks.storage.table import (
    ResultStore,
    Unit,
    part_checksums,
    status_counts,
    timing_totals,
)

__all__ = ["PART_CHECKSUMS", "ResumeError", "RunSession", "check_out_dir"]

PART_CHECKSUMS = "part_sha256"
"""Key in the manifest's ``extra`` of the part files' SHA-256 checksums."""


class ResumeError(ValueError):
    """A run folder cannot be continued with this config (or was tampered with)."""


def check_out_dir(out_dir: Any) -> Path:
    """``out_dir`` as a path that is not a file.

    Raises:
        TypeError: If it is not a ``str`` or ``os.PathLike``.
        ValueError: If it names an existing file.
    """
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir must be a path, got {type(out_dir).__name__}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    return out


def _now() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc)


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

    Raises:
        TypeError: If ``out_dir`` is not a path.
        ValueError: If ``out_dir`` is a file, or has content and ``resume`` is false.
        ResumeError: If the folder cannot be continued (see the module docstring).
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
    ) -> None:
        self.out = check_out_dir(out_dir)
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
        previous = self._previous(bool(resume))
        self.resumed = previous is not None
        if previous is None:
            self.start_time = _now()
            self.sessions: list[dict[str, Any]] = [self._session]
            self._checksums: dict[str, str] = {}
        else:
            self.start_time = dt.datetime.fromisoformat(previous["start_time"])
            self.sessions = [*previous["extra"].get("sessions", []), self._session]
            self._checksums = part_checksums(self.store)  # verified in _previous
            self.store.remove_stale_temp_files()  # only this process writes here
        # The parts of the manifest that do not change within a session (packages, commit,
        # host) are collected once: a manifest is rewritten after every part.
        self._base = build_manifest(config=self.config, start_time=self.start_time)

    # --- opening -------------------------------------------------------------------------------

    def _previous(self, resume: bool) -> dict[str, Any] | None:
        """The manifest of the run to continue, ``None`` for a new run; refuses to mix runs."""
        out = self.out
        if not (out.is_dir() and any(p.resolve() not in self._own for p in out.iterdir())):
            return None
        if not resume:
            raise ValueError(
                f"--out {out} exists and is not empty; pass --resume to continue the run in it, "
                "or choose another folder"
            )
        try:
            manifest = read_manifest(out)
        except FileNotFoundError:
            raise ResumeError(
                f"cannot resume: {out} is not empty and has no manifest.json, so it is not a "
                f"{self.kind} run folder; choose another folder"
            ) from None
        if manifest.get("format_version") != MANIFEST_VERSION:
            raise ResumeError(
                f"cannot resume: {out} was written by an incompatible version (manifest "
                f"format_version {manifest.get('format_version')!r}, this version writes "
                f"{MANIFEST_VERSION}); start a new run folder"
            )
        old, extra = manifest.get("config"), manifest.get("extra")
        if (
            not isinstance(old, dict)
            or not isinstance(extra, dict)
            or extra.get("kind") != self.kind
        ):
            raise ResumeError(
                f"cannot resume: {out} holds a run of another kind, not a {self.kind} run"
            )
        self._verify_parts(extra)
        old = {**self._added, **old}
        changed = sorted(
            k
            for k in (old.keys() | self.config.keys()) - self._runtime
            if old.get(k) != self.config.get(k)
            and not self._grows(old.get(k), self.config.get(k), k)
        )
        if changed:
            detail = ", ".join(f"{k}: {old.get(k)!r} -> {self.config.get(k)!r}" for k in changed)
            raise ResumeError(
                f"cannot resume: the run in {out} was made with other settings ({detail}); use "
                "the same settings, or another folder"
            )
        return manifest

    def _grows(self, old: Any, new: Any, key: str) -> bool:
        """Whether ``key`` is a growable count that this session raises (e.g. more seeds)."""
        return key in self._growable and all(type(v) is int for v in (old, new)) and new >= old

    def _verify_parts(self, extra: Mapping[str, Any]) -> None:
        recorded = extra.get(PART_CHECKSUMS)
        manifest = self.out / "manifest.json"
        if not isinstance(recorded, dict):
            raise ResumeError(
                f"cannot resume: {manifest} records no part checksums ({PART_CHECKSUMS!r}): it "
                "was written by an incompatible version or edited"
            )
        try:
            verify_checksums(self.out, recorded)
        except ValueError as error:
            raise ResumeError(f"cannot resume: {error}") from None
        unrecorded = sorted(set(part_checksums(self.store)) - set(recorded))
        if len(unrecorded) > 1:
            raise ResumeError(
                f"cannot resume: {self.out} holds part files the manifest does not record: "
                f"{unrecorded}"
            )

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
            **self._extra,
        }
        manifest["extra"] = _jsonable(extra, "extra")  # refuses NaN and what JSON cannot store
        return manifest

    def checkpoint(self) -> None:
        """Rewrite the manifest: times so far, checksums, ``extra``."""
        self.store.write_manifest(self.manifest())

    def finish(self, evaluations: pd.DataFrame | None) -> dict[str, Any]:
        """Write the final manifest (end time, summed times); returns it."""
        manifest = self.manifest(end=_now(), evaluations=evaluations)
        self.store.write_manifest(manifest)
        return manifest
