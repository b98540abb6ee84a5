"""Atomic, resumable result files of a benchmark run folder.

A run folder holds the evaluation log of a suite: one row per evaluation (one simulated tool
design), in the long format documented in ``docs/results-format.md``. It is written as the suite
goes, one part file per finished unit of work (one batch: suite, variant, optimizer, seed and
iteration), each written to a temporary name and then ``os.replace``-d into place. A kill at any
moment therefore leaves only whole parts, and a resumed suite skips the units already on disk and
ends with the same results as an uninterrupted one.

Layout of a run folder::

    run_folder/
        manifest.json                  config, package versions, git commit, host, times
        parts/suite=<s>/variant=<v>/optimizer=<o>/seed=<n>/iteration=<nnnnnn>.csv
        evaluations.parquet            after consolidate(), if pyarrow is importable
        evaluations.csv                after consolidate(), otherwise

Names are percent-encoded in part paths (``urllib.parse.quote`` with no safe characters), so any
suite, variant or optimizer name maps to one valid path component and back.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import enum
import hashlib
import importlib.metadata
import io
import json
import math
import os
import platform
import re
import secrets
import subprocess
import urllib.parse
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

__all__ = [
    "COEFFICIENT_PATTERN",
    "FLOAT_COLUMNS",
    "ID_COLUMNS",
    "RUN_COLUMNS",
    "SORT_COLUMNS",
    "STATUSES",
    "STRING_COLUMNS",
    "TASK_COLUMNS",
    "MANIFEST_VERSION",
    "EmptyStoreError",
    "ResultStore",
    "Unit",
    "atomic_write_bytes",
    "atomic_write_text",
    "build_manifest",
    "file_sha256",
    "part_checksums",
    "git_commit",
    "host_info",
    "package_versions",
    "read_manifest",
    "resolve_format",
    "timing_totals",
    "validate_evaluations",
    "verify_checksums",
    "write_manifest",
]

# --- schema ------------------------------------------------------------------------------------

STATUSES: tuple[str, ...] = ("ok", "invalid", "failed")
"""Allowed values of the ``status`` column."""

STRING_COLUMNS: tuple[str, ...] = ("suite", "optimizer", "status", "variant")
ID_COLUMNS: tuple[str, ...] = ("seed", "iteration", "candidate", "eval_id")
METRIC_COLUMNS: tuple[str, ...] = ("free_energy", "goal_error", "confidence", "final_distance")
TIMING_COLUMNS: tuple[str, ...] = ("eval_time", "opt_time")
TASK_COLUMNS: tuple[str, ...] = ("goal_x", "goal_y", "goal_z", "goal_precision", "box_mass")
FLOAT_COLUMNS: tuple[str, ...] = METRIC_COLUMNS + TIMING_COLUMNS + TASK_COLUMNS
DERIVED_COLUMN = "best_so_far"

RUN_COLUMNS: tuple[str, ...] = ("suite", "variant", "optimizer", "seed")
"""Columns naming one optimisation run; ``best_so_far`` is a running minimum within a run."""

SORT_COLUMNS: tuple[str, ...] = RUN_COLUMNS + ("iteration", "candidate")
"""Deterministic row order of :meth:`ResultStore.read`."""

COEFFICIENT_PATTERN = re.compile(r"c([1-9][0-9]*)")
"""Coefficient columns ``c1..cn``; ``n`` varies per suite."""

_REQUIRED: tuple[str, ...] = (
    ("suite", "optimizer") + ID_COLUMNS + METRIC_COLUMNS + ("status",) + TIMING_COLUMNS
) + TASK_COLUMNS

Format = Literal["csv", "parquet"]
CONSOLIDATED_STEM = "evaluations"
MANIFEST_NAME = "manifest.json"
PARTS_DIR = "parts"
_TEMP_SUFFIX = ".tmp"
_PART_NAME = re.compile(r"iteration=([0-9]+)\.csv")


class EmptyStoreError(ValueError):
    """A run folder exists but holds no evaluations yet."""


# --- atomic writes -----------------------------------------------------------------------------


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` to ``path`` so that readers see the old file or the new one, never half.

    The bytes go to a hidden temporary file in the same folder (same file system, so the rename
    is atomic), are flushed to disk, and the temporary file is ``os.replace``-d onto ``path``.
    A crash leaves at most a ``.<name>.<random>.tmp`` file, which readers ignore.

    Args:
        path: Destination file; its parent folders are created.
        data: The complete file content.

    Returns:
        The destination path.

    Raises:
        TypeError: If ``data`` is not bytes-like.
    """
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise TypeError(f"data must be bytes, got {type(data).__name__}")
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    # A random suffix (not mkstemp) so the file gets the usual umask permissions, not 0600.
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}{_TEMP_SUFFIX}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_folder(target.parent)
    return target


def atomic_write_text(path: str | os.PathLike[str], text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` atomically (see :func:`atomic_write_bytes`), without newline translation.

    Args:
        path: Destination file; its parent folders are created.
        text: The complete file content; newlines are written as they are (no ``CRLF`` on
            Windows), so the bytes are the same everywhere.
        encoding: Text encoding.

    Returns:
        The destination path.

    Raises:
        TypeError: If ``text`` is not a string.
    """
    if not isinstance(text, str):
        raise TypeError(f"text must be str, got {type(text).__name__}")
    return atomic_write_bytes(path, text.encode(encoding))


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


# --- units of work -----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True, order=True)
class Unit:
    """One unit of work: the batch of one iteration of one optimisation run.

    Attributes:
        suite: Suite name, non-empty.
        variant: Free-form variant of the suite ("" if none); distinguishes runs of the same
            optimizer and seed, e.g. different ``goal_precision`` in a precision sweep.
        optimizer: Optimizer name, non-empty.
        seed: Seed of the run, >= 0.
        iteration: 0-based iteration, >= 0.
    """

    suite: str
    variant: str = ""
    optimizer: str
    seed: int
    iteration: int

    def __post_init__(self) -> None:
        for name in ("suite", "optimizer", "variant"):
            value = getattr(self, name)
            if not isinstance(value, str):
                raise TypeError(f"Unit.{name} must be str, got {type(value).__name__}")
            if name != "variant" and not value:
                raise ValueError(f"Unit.{name} must be a non-empty string")
        for name in ("seed", "iteration"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise TypeError(f"Unit.{name} must be an int, got {type(value).__name__}")
            if value < 0:
                raise ValueError(f"Unit.{name} must be >= 0, got {value}")
            object.__setattr__(self, name, int(value))

    def relative_path(self) -> Path:
        """Path of this unit's part file relative to the ``parts/`` folder."""
        return Path(
            f"suite={_quote(self.suite)}",
            f"variant={_quote(self.variant)}",
            f"optimizer={_quote(self.optimizer)}",
            f"seed={self.seed}",
            f"iteration={self.iteration:06d}.csv",
        )

    @classmethod
    def from_relative_path(cls, relative: Path) -> Unit | None:
        """Parse a part path made by :meth:`relative_path`; ``None`` if it is not exactly one."""
        parts = relative.parts
        if len(parts) != 5:
            return None
        prefixes = ("suite=", "variant=", "optimizer=", "seed=")
        if not all(p.startswith(k) for p, k in zip(parts[:4], prefixes, strict=True)):
            return None
        match = _PART_NAME.fullmatch(parts[4])
        seed = parts[3][len("seed=") :]
        if match is None or not seed.isdigit():
            return None
        try:
            unit = cls(
                suite=urllib.parse.unquote(parts[0][len("suite=") :]),
                variant=urllib.parse.unquote(parts[1][len("variant=") :]),
                optimizer=urllib.parse.unquote(parts[2][len("optimizer=") :]),
                seed=int(seed),
                iteration=int(match.group(1)),
            )
        except ValueError:
            return None
        # Only names the store itself writes count, so one unit never has two files.
        return unit if unit.relative_path() == relative else None


def _quote(name: str) -> str:
    return urllib.parse.quote(name, safe="")


# --- validation --------------------------------------------------------------------------------


def _coefficient_columns(columns: Iterable[str]) -> list[str]:
    found = [c for c in columns if isinstance(c, str) and COEFFICIENT_PATTERN.fullmatch(c)]
    return sorted(found, key=lambda c: int(c[1:]))


def _canonical_order(columns: Iterable[str]) -> list[str]:
    columns = list(columns)
    coefficients = _coefficient_columns(columns)
    head = ["suite", "optimizer", *ID_COLUMNS, *coefficients, *METRIC_COLUMNS, "status"]
    head += [*TIMING_COLUMNS, DERIVED_COLUMN, *TASK_COLUMNS, "variant"]
    present, listed = set(columns), set(head)
    known = [c for c in head if c in present]
    extra = sorted(c for c in columns if c not in listed)
    return known + extra


def validate_evaluations(rows: pd.DataFrame, *, source: str = "rows") -> pd.DataFrame:
    """Check evaluation rows against the results format and return a canonical copy.

    The copy has the canonical column order, dtypes (``str``, ``int64``, ``float64``) and a
    ``variant`` column ("" when absent). A ``best_so_far`` column, if given, is dropped: it is
    derived from the whole run by :meth:`ResultStore.read`.

    Args:
        rows: (n_rows, n_columns) evaluation rows in the format of ``docs/results-format.md``.
            Columns beyond the documented ones must be numeric; they are kept as float64.
        source: What the rows are, for error messages (e.g. a file path).

    Returns:
        The canonical copy, index reset, rows in their given order.

    Raises:
        TypeError: If ``rows`` is not a DataFrame or a column has the wrong type.
        ValueError: If ``rows`` is empty, a column is missing or a value is out of range.
    """
    if not isinstance(rows, pd.DataFrame):
        raise TypeError(f"{source}: expected a pandas DataFrame, got {type(rows).__name__}")
    if len(rows) == 0:
        raise ValueError(f"{source}: holds no rows; a batch has at least one evaluation")
    non_str = [repr(c) for c in rows.columns if not isinstance(c, str)]
    if non_str:
        raise TypeError(f"{source}: column names must be str, got {', '.join(non_str)}")
    if rows.columns.duplicated().any():
        dup = sorted(set(rows.columns[rows.columns.duplicated()]))
        raise ValueError(f"{source}: duplicate columns {dup}")
    missing = [c for c in _REQUIRED if c not in rows.columns]
    if missing:
        raise ValueError(
            f"{source}: missing columns {missing}; see docs/results-format.md for the format"
        )
    coefficients = _coefficient_columns(rows.columns)
    expected = [f"c{i}" for i in range(1, len(coefficients) + 1)]
    if not coefficients or coefficients != expected:
        raise ValueError(
            f"{source}: coefficient columns must be c1..cn with n >= 1 and no gaps, "
            f"got {coefficients or 'none'}"
        )

    out = rows.drop(columns=[DERIVED_COLUMN], errors="ignore").reset_index(drop=True)
    if "variant" not in out.columns:
        out["variant"] = ""
    known = set(STRING_COLUMNS) | set(ID_COLUMNS) | set(FLOAT_COLUMNS) | set(coefficients)
    converted: dict[str, pd.Series] = {}
    for name in out.columns:
        column = out[name]
        if name in STRING_COLUMNS:
            converted[name] = _as_string(column, name, source, allow_missing=name == "variant")
        elif name in ID_COLUMNS:
            converted[name] = _as_int(column, name, source)
        else:
            converted[name] = _as_float(column, name, source, extra=name not in known)
    out = pd.DataFrame(converted)[_canonical_order(converted)]

    for name in ("suite", "optimizer"):
        if (out[name] == "").any():
            raise ValueError(f"{source}: column {name!r} holds empty strings; names are required")
    bad_status = sorted(set(out["status"]) - set(STATUSES))
    if bad_status:
        raise ValueError(f"{source}: column 'status' holds {bad_status}; allowed: {STATUSES}")
    for name in ("seed", "iteration", "candidate"):
        if (out[name] < 0).any():
            raise ValueError(f"{source}: column {name!r} must be >= 0")
    for name in TIMING_COLUMNS:
        if (out[name] < 0).any():
            raise ValueError(f"{source}: column {name!r} (seconds) must be >= 0 or NaN")
    nan_ok = (out["status"] == "ok") & out["free_energy"].isna()
    if nan_ok.any():
        ids = out.loc[nan_ok, "eval_id"].tolist()[:5]
        raise ValueError(
            f"{source}: free_energy is NaN in rows with status 'ok' (eval_id {ids}); "
            "NaN is allowed only for status 'invalid' or 'failed'"
        )
    duplicated = out.duplicated(list(SORT_COLUMNS))
    if duplicated.any():
        first = out.loc[duplicated, list(SORT_COLUMNS)].iloc[0].to_dict()
        raise ValueError(f"{source}: duplicate evaluation {first}")
    return out


def _as_string(column: pd.Series, name: str, source: str, *, allow_missing: bool) -> pd.Series:
    if isinstance(column.dtype, pd.CategoricalDtype):
        column = column.astype(object)
    if allow_missing:
        column = column.where(column.notna(), "")
    elif column.isna().any():
        raise ValueError(f"{source}: column {name!r} holds missing values; strings are required")
    kind = pd.api.types.infer_dtype(column, skipna=False)
    if kind != "string":
        raise TypeError(f"{source}: column {name!r} must hold strings, got {kind} values")
    return column.astype(str)


def _as_int(column: pd.Series, name: str, source: str) -> pd.Series:
    kind = pd.api.types.infer_dtype(column, skipna=False)
    if pd.api.types.is_bool_dtype(column.dtype) or kind != "integer":
        raise TypeError(
            f"{source}: column {name!r} must hold integers, got dtype {column.dtype} ({kind})"
        )
    return column.astype(np.int64)


def _as_float(column: pd.Series, name: str, source: str, *, extra: bool) -> pd.Series:
    kind = pd.api.types.infer_dtype(column, skipna=True)
    numeric = kind in ("floating", "integer", "mixed-integer-float", "decimal", "empty")
    if pd.api.types.is_bool_dtype(column.dtype) or not numeric:
        what = "extra columns must be numeric" if extra else "must hold numbers"
        raise TypeError(f"{source}: column {name!r} {what}, got dtype {column.dtype} ({kind})")
    return column.astype(np.float64)


def _with_best_so_far(frame: pd.DataFrame) -> pd.DataFrame:
    """Sort rows deterministically and add the running best finite F of each run."""
    frame = frame.sort_values(list(SORT_COLUMNS), kind="mergesort").reset_index(drop=True)
    energy = frame["free_energy"]
    finite = energy.where((frame["status"] == "ok") & np.isfinite(energy))
    keys = [frame[c] for c in RUN_COLUMNS]
    # cummin leaves NaN where the row itself is NaN; the forward fill carries the running best.
    best = finite.groupby(keys, sort=False).cummin()
    frame[DERIVED_COLUMN] = best.groupby(keys, sort=False).ffill()
    return frame[_canonical_order(frame.columns)]


# --- file formats ------------------------------------------------------------------------------


def _pyarrow_available() -> bool:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        return False
    return True


def resolve_format(format: str = "auto") -> Format:
    """Choose the consolidated file format.

    The rule: ``"auto"`` is Parquet when pyarrow (the optional extra ``tooldesign[parquet]``)
    is importable and CSV otherwise. Part files are always CSV.

    Args:
        format: ``"auto"``, ``"csv"`` or ``"parquet"``.

    Returns:
        ``"csv"`` or ``"parquet"``.

    Raises:
        ValueError: If ``format`` is not one of the three.
        ImportError: If ``"parquet"`` is asked for and pyarrow is not importable.
    """
    if format not in ("auto", "csv", "parquet"):
        raise ValueError(f"format must be 'auto', 'csv' or 'parquet', got {format!r}")
    if format == "auto":
        return "parquet" if _pyarrow_available() else "csv"
    if format == "parquet" and not _pyarrow_available():
        raise ImportError(_NO_PYARROW)
    return format  # type: ignore[return-value]


_NO_PYARROW = (
    "Parquet needs pyarrow, which is not installed; install it with "
    "`pip install 'tooldesign[parquet]'` or use format='csv'"
)


def _csv_bytes(frame: pd.DataFrame) -> bytes:
    # repr() is the shortest string that parses back to the same double, so CSV floats
    # round-trip bit for bit; NaN is written as an empty field.
    text = frame.to_csv(index=False, lineterminator="\n", float_format=lambda v: repr(float(v)))
    return text.encode("utf-8")


# pandas < 3 parses floats with a fast but not always exact routine unless asked to round-trip;
# pandas 3 is exact by default and deprecates the option.
_CSV_FLOAT_KW: dict[str, Any] = (
    {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
)


def _read_csv(path: Path | io.StringIO) -> pd.DataFrame:
    # Only empty fields are missing; a suite called "NA" or "nan" stays a string.
    return pd.read_csv(
        path,
        dtype={c: str for c in STRING_COLUMNS},
        keep_default_na=False,
        na_values=[""],
        **_CSV_FLOAT_KW,
    )


def _read_table(path: Path) -> pd.DataFrame:
    if path.suffix == ".parquet":
        if not _pyarrow_available():
            raise ImportError(f"{path}: {_NO_PYARROW}")
        return pd.read_parquet(path)
    return _read_csv(path)


# --- the store ---------------------------------------------------------------------------------


class ResultStore:
    """The evaluation log of one run folder, written one whole part file per unit of work.

    Writers call :meth:`write_batch` once per finished batch and skip :meth:`completed_units` on
    resume; several processes may write different units into the same folder at once. Readers
    call :meth:`read`, which concatenates the parts (or, if there are none, reads the
    consolidated file) and returns them in a deterministic order with ``best_so_far`` derived.

    Args:
        run_folder: The run folder; it is created by the first write, not here.

    Example:
        >>> store = ResultStore("runs/optimizers")  # doctest: +SKIP
        >>> for unit in store.pending_units(planned):  # doctest: +SKIP
        ...     store.write_batch(evaluate(unit))
        >>> df = store.read()  # doctest: +SKIP
    """

    def __init__(self, run_folder: str | os.PathLike[str]) -> None:
        if not isinstance(run_folder, (str, os.PathLike)):
            raise TypeError(f"run_folder must be a path, got {type(run_folder).__name__}")
        self._folder = Path(run_folder)

    def __repr__(self) -> str:
        return f"ResultStore({str(self._folder)!r})"

    @property
    def run_folder(self) -> Path:
        """The run folder."""
        return self._folder

    @property
    def parts_dir(self) -> Path:
        """The folder of part files, ``run_folder/parts``."""
        return self._folder / PARTS_DIR

    @property
    def manifest_path(self) -> Path:
        """``run_folder/manifest.json``."""
        return self._folder / MANIFEST_NAME

    def part_path(self, unit: Unit) -> Path:
        """Path of the part file of ``unit``."""
        return self.parts_dir / unit.relative_path()

    # writing

    def write_batch(self, rows: pd.DataFrame, *, overwrite: bool = False) -> Unit:
        """Validate the rows of one finished batch and write them as one part file, atomically.

        Args:
            rows: (batch_size, n_columns) evaluation rows that share suite, variant, optimizer,
                seed and iteration (see :func:`validate_evaluations`).
            overwrite: Replace an existing part of the same unit instead of raising.

        Returns:
            The unit written.

        Raises:
            TypeError: If a column has the wrong type.
            ValueError: If the rows are invalid or span more than one unit.
            FileExistsError: If the unit is already stored and ``overwrite`` is false.
        """
        frame = validate_evaluations(rows, source="write_batch rows")
        units = frame[[*RUN_COLUMNS, "iteration"]].drop_duplicates()
        if len(units) != 1:
            raise ValueError(
                "write_batch rows must belong to one unit (suite, variant, optimizer, seed, "
                f"iteration); got {len(units)}: {units.to_dict('records')[:3]}"
            )
        unit = Unit(**units.iloc[0].to_dict())
        path = self.part_path(unit)
        if path.exists() and not overwrite:
            raise FileExistsError(f"{path}: unit {unit} is already stored; pass overwrite=True")
        frame = frame.sort_values("candidate", kind="mergesort").reset_index(drop=True)
        atomic_write_bytes(path, _csv_bytes(frame))
        return unit

    # resuming

    def completed_units(self) -> frozenset[Unit]:
        """Units whose part file is on disk (temporary files of interrupted writes are not)."""
        if not self.parts_dir.is_dir():
            return frozenset()
        units = set()
        for path in self.parts_dir.rglob("iteration=*.csv"):
            unit = Unit.from_relative_path(path.relative_to(self.parts_dir))
            if unit is not None:
                units.add(unit)
        return frozenset(units)

    def is_complete(self, unit: Unit) -> bool:
        """Whether the part file of ``unit`` is on disk."""
        return self.part_path(unit).is_file()

    def pending_units(self, planned: Iterable[Unit]) -> list[Unit]:
        """The planned units not yet stored, in the planned order."""
        done = self.completed_units()
        return [u for u in planned if u not in done]

    def stale_temp_files(self) -> list[Path]:
        """Temporary files left by interrupted writes (``.<name>.<pid>.<random>.tmp``)."""
        if not self._folder.is_dir():
            return []
        return sorted(p for p in self._folder.rglob(f".*{_TEMP_SUFFIX}") if p.is_file())

    def remove_stale_temp_files(self) -> list[Path]:
        """Delete :meth:`stale_temp_files`; call it only while no other process writes here.

        Returns:
            The files removed.
        """
        removed = self.stale_temp_files()
        for path in removed:
            path.unlink(missing_ok=True)
        return removed

    # reading

    def _check_folder(self) -> None:
        if not self._folder.exists():
            raise FileNotFoundError(f"run folder {self._folder} does not exist")
        if not self._folder.is_dir():
            raise NotADirectoryError(f"run folder {self._folder} is not a folder")

    def consolidated_path(self) -> Path | None:
        """The consolidated file that :meth:`read` would fall back to, or ``None``."""
        parquet = self._folder / f"{CONSOLIDATED_STEM}.parquet"
        csv = self._folder / f"{CONSOLIDATED_STEM}.csv"
        if parquet.is_file() and (_pyarrow_available() or not csv.is_file()):
            return parquet
        return csv if csv.is_file() else None

    def read(self) -> pd.DataFrame:
        """All stored evaluations with ``best_so_far``, sorted by :data:`SORT_COLUMNS`.

        Part files are the source of truth; the consolidated file is read only when there are
        no parts (e.g. a run folder shared without them).

        Returns:
            (n_evaluations, n_columns) DataFrame in the canonical column order and dtypes.

        Raises:
            FileNotFoundError: If the run folder does not exist.
            NotADirectoryError: If it is a file.
            EmptyStoreError: If it holds neither part files nor a consolidated file.
            TypeError, ValueError: If a stored file does not follow the results format; the
                message names the file and the column.
        """
        self._check_folder()
        units = sorted(self.completed_units())
        if units:
            combined = self._read_parts(units)
        else:
            path = self.consolidated_path()
            if path is None:
                raise EmptyStoreError(
                    f"run folder {self._folder} holds no results: no part files under "
                    f"{PARTS_DIR}/ and no {CONSOLIDATED_STEM}.csv or {CONSOLIDATED_STEM}.parquet"
                )
            combined = validate_evaluations(_read_table(path), source=str(path))
        return _with_best_so_far(combined)

    def _read_parts(self, units: list[Unit]) -> pd.DataFrame:
        try:
            combined = self._read_parts_fast(units)
        except (TypeError, ValueError):
            # Find the file to blame (pandas' parser errors are ValueErrors too); the rows carry
            # their own keys, so the per-file check of the unit is needed only here.
            for unit in units:
                path = self.part_path(unit)
                try:
                    raw = _read_csv(path)
                except ValueError as err:
                    raise ValueError(f"{path}: not a readable CSV part file: {err}") from err
                frame = validate_evaluations(raw, source=str(path))
                got = frame[[*RUN_COLUMNS, "iteration"]].drop_duplicates().to_dict("records")
                if got != [dataclasses.asdict(unit)]:
                    raise ValueError(f"{path}: rows belong to {got}, not to {unit}") from None
            raise
        return combined

    def _read_parts_fast(self, units: list[Unit]) -> pd.DataFrame:
        # One read_csv per distinct header instead of one per file: a suite has hundreds of
        # small parts and pandas' per-call overhead, not parsing, would dominate.
        bodies: dict[str, list[str]] = {}
        for unit in units:
            header, _, body = self.part_path(unit).read_text(encoding="utf-8").partition("\n")
            if body and not body.endswith("\n"):
                body += "\n"
            bodies.setdefault(header, []).append(body)
        frames = [_read_csv(io.StringIO(h + "\n" + "".join(b))) for h, b in bodies.items()]
        combined = validate_evaluations(
            pd.concat(frames, ignore_index=True), source=f"part files under {self.parts_dir}"
        )
        keys = combined[[*RUN_COLUMNS, "iteration"]].drop_duplicates().to_dict("records")
        if {Unit(**key) for key in keys} != set(units):
            raise ValueError(f"part files under {self.parts_dir} do not match their rows")
        return combined

    def consolidate(self, format: str = "auto") -> Path:
        """Write all evaluations as one file, atomically, and remove one of the other format.

        Args:
            format: ``"auto"`` (Parquet if pyarrow is importable, else CSV), ``"csv"`` or
                ``"parquet"``; see :func:`resolve_format`.

        Returns:
            ``run_folder/evaluations.parquet`` or ``run_folder/evaluations.csv``.

        Raises:
            EmptyStoreError: If there is nothing to consolidate.
        """
        chosen = resolve_format(format)
        frame = self.read()
        target = self._folder / f"{CONSOLIDATED_STEM}.{chosen}"
        if chosen == "parquet":
            buffer = io.BytesIO()
            frame.to_parquet(buffer, index=False, engine="pyarrow")
            atomic_write_bytes(target, buffer.getvalue())
        else:
            atomic_write_bytes(target, _csv_bytes(frame))
        other = "csv" if chosen == "parquet" else "parquet"
        # A stale file of the other format would be read instead of the fresh one elsewhere.
        (self._folder / f"{CONSOLIDATED_STEM}.{other}").unlink(missing_ok=True)
        return target

    # manifest

    def write_manifest(self, manifest: Mapping[str, Any]) -> Path:
        """Write ``manifest.json`` of this run folder; see :func:`write_manifest`."""
        return write_manifest(self._folder, manifest)

    def read_manifest(self) -> dict[str, Any]:
        """Read ``manifest.json`` of this run folder; see :func:`read_manifest`."""
        return read_manifest(self._folder)


def timing_totals(evaluations: pd.DataFrame) -> dict[str, float]:
    """Sum the simulation and optimizer time of an evaluation log.

    ``opt_time`` is the ask+tell time of an iteration divided by its batch size, so its sum over
    rows is the total optimizer time. NaN times count as 0.

    Args:
        evaluations: Rows with ``eval_time`` and ``opt_time`` columns in s.

    Returns:
        ``{"simulation_time": s, "optimizer_time": s}``.
    """
    for name in TIMING_COLUMNS:
        if name not in evaluations.columns:
            raise ValueError(f"evaluations: missing column {name!r}")
    return {
        "simulation_time": float(evaluations["eval_time"].sum()),
        "optimizer_time": float(evaluations["opt_time"].sum()),
    }


# --- manifest ----------------------------------------------------------------------------------

MANIFEST_VERSION = 1
# Distribution names (what importlib.metadata knows), not module names: skopt is scikit-optimize.
_PACKAGES: tuple[str, ...] = (
    "tooldesign",
    "numpy",
    "scipy",
    "pandas",
    "gymnasium",
    "pybullet",
    "cma",
    "scikit-optimize",
    "pyswarms",
    "pyarrow",
    "matplotlib",
)


def package_versions(packages: Iterable[str] = _PACKAGES) -> dict[str, str]:
    """Versions of the installed distributions among ``packages``; absent ones are left out.

    Uses ``importlib.metadata`` so that nothing is imported (importing pybullet prints a banner
    and takes time).

    Args:
        packages: Distribution names.

    Returns:
        ``{name: version}`` in the order given.
    """
    versions = {}
    for name in packages:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
    return versions


def git_commit(repo_dir: str | os.PathLike[str] | None = None) -> str | None:
    """The commit checked out in ``repo_dir``, or ``None`` if git or the repository is absent.

    Args:
        repo_dir: A folder inside the repository; defaults to the folder of this module.

    Returns:
        The 40-hex-digit commit or ``None``.
    """
    folder = Path(repo_dir) if repo_dir is not None else Path(__file__).resolve().parent
    try:
        result = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    commit = result.stdout.strip()
    return commit if re.fullmatch(r"[0-9a-f]{40}", commit) else None


def host_info() -> dict[str, Any]:
    """The machine: platform string, machine, Python version and CPU count (no host name)."""
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
    }


def build_manifest(
    *,
    config: Mapping[str, Any] | Any,
    start_time: dt.datetime,
    end_time: dt.datetime | None = None,
    wall_time: float | None = None,
    simulation_time: float | None = None,
    optimizer_time: float | None = None,
    repo_dir: str | os.PathLike[str] | None = None,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Describe a run: what was asked, with which software, where and how long it took.

    Args:
        config: The suite configuration: a mapping or a dataclass instance; it must be made of
            JSON values, numpy scalars/arrays, paths, enums, tuples and nested dataclasses.
        start_time: When the run started, timezone-aware.
        end_time: When it ended, timezone-aware, or ``None`` while it runs.
        wall_time: Total wall time in s; defaults to ``end_time - start_time`` (pass the sum of
            sessions for a resumed run).
        simulation_time: Sum of ``eval_time`` in s (see :func:`timing_totals`).
        optimizer_time: Sum of ``opt_time`` in s.
        repo_dir: Where to ask git for the commit; see :func:`git_commit`.
        extra: More JSON-able entries, stored under ``"extra"``.

    Returns:
        A JSON-able dict.

    Raises:
        TypeError: If a time has the wrong type or the config holds a value JSON cannot store.
        ValueError: If a datetime is naive, times are negative or the config holds NaN or inf.
    """
    for name, moment in (("start_time", start_time), ("end_time", end_time)):
        if moment is None:
            continue
        if not isinstance(moment, dt.datetime):
            raise TypeError(f"{name} must be a datetime, got {type(moment).__name__}")
        if moment.tzinfo is None or moment.utcoffset() is None:
            raise ValueError(f"{name} must be timezone-aware, e.g. datetime.now(timezone.utc)")
    if wall_time is None and end_time is not None:
        wall_time = (end_time - start_time).total_seconds()
    for name, seconds in (
        ("wall_time", wall_time),
        ("simulation_time", simulation_time),
        ("optimizer_time", optimizer_time),
    ):
        if seconds is None:
            continue
        if isinstance(seconds, bool) or not isinstance(seconds, (int, float, np.number)):
            raise TypeError(f"{name} must be a number of seconds, got {type(seconds).__name__}")
        if not (math.isfinite(seconds) and seconds >= 0):
            raise ValueError(f"{name} must be a finite number of seconds >= 0, got {seconds}")
    if dataclasses.is_dataclass(config) and not isinstance(config, type):
        config = dataclasses.asdict(config)
    if not isinstance(config, Mapping):
        raise TypeError(f"config must be a mapping or a dataclass, got {type(config).__name__}")
    return {
        "format_version": MANIFEST_VERSION,
        "config": _jsonable(config, "config"),
        "packages": package_versions(),
        "git_commit": git_commit(repo_dir),
        "host": host_info(),
        "start_time": start_time.isoformat(),
        "end_time": None if end_time is None else end_time.isoformat(),
        "wall_time": None if wall_time is None else float(wall_time),
        "simulation_time": None if simulation_time is None else float(simulation_time),
        "optimizer_time": None if optimizer_time is None else float(optimizer_time),
        "extra": _jsonable(dict(extra or {}), "extra"),
    }


def _jsonable(value: Any, where: str) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = dataclasses.asdict(value)
    if isinstance(value, enum.Enum):
        value = value.value
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{where} is {value}; JSON has no NaN or inf")
        return value
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise TypeError(f"{where} has a key {key!r} that is not a str")
            out[key] = _jsonable(item, f"{where}.{key}")
        return out
    if isinstance(value, (list, tuple)):
        return [_jsonable(item, f"{where}[{i}]") for i, item in enumerate(value)]
    raise TypeError(f"{where} is a {type(value).__name__}, which JSON cannot store")


def json_ready(value: Any) -> Any:
    """``value`` as plain JSON types: mappings, lists, numbers, strings, None.

    NumPy arrays and scalars become lists and numbers; a non-finite float becomes None (JSON has
    no NaN, and a failed metric is null in the files users keep). Manifests use a stricter
    check that refuses NaN instead.
    """
    if isinstance(value, Mapping):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(data: Mapping[str, Any], *, compact: bool = False) -> str:
    """``data`` as JSON text with sorted keys (see :func:`json_ready`): equal data, equal bytes."""
    if compact:
        return json.dumps(json_ready(data), separators=(",", ":"), sort_keys=True, allow_nan=False)
    return json.dumps(json_ready(data), indent=2, sort_keys=True, allow_nan=False) + "\n"


def file_sha256(path: str | os.PathLike[str]) -> str:
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def part_checksums(store: ResultStore) -> dict[str, str]:
    """``{path relative to the run folder: sha256}`` of every completed part file."""
    out: dict[str, str] = {}
    for unit in sorted(store.completed_units(), key=lambda u: str(u.relative_path)):
        path = store.part_path(unit)
        out[path.relative_to(store.run_folder).as_posix()] = file_sha256(path)
    return out


def verify_checksums(run_folder: str | os.PathLike[str], recorded: Mapping[str, Any]) -> None:
    """Refuse a run folder whose recorded files are missing or changed.

    Args:
        run_folder: The folder.
        recorded: ``{relative path: sha256}`` as stored in the manifest.

    Raises:
        ValueError: A recorded file is missing, truncated or edited (its sha256 differs), or
            the record itself is malformed. Nothing is written or removed.
    """
    folder = Path(run_folder)
    if not isinstance(recorded, Mapping):
        raise ValueError(f"{folder / 'manifest.json'}: the checksums are not a mapping")
    for relative, expected in sorted(recorded.items()):
        path = (folder / relative).resolve()
        if not isinstance(expected, str) or folder.resolve() not in path.parents:
            raise ValueError(f"{folder / 'manifest.json'}: bad checksum entry {relative!r}")
        if not path.is_file():
            raise ValueError(
                f"{path} is listed in the manifest but missing; the run folder is incomplete"
            )
        actual = file_sha256(path)
        if actual != expected:
            raise ValueError(
                f"{path} has changed since it was written (sha256 {actual[:12]}..., the "
                f"manifest records {expected[:12]}...): the file was edited, truncated or "
                "corrupted; restore it or start a new run folder"
            )


def write_manifest(run_folder: str | os.PathLike[str], manifest: Mapping[str, Any]) -> Path:
    """Write ``run_folder/manifest.json`` atomically, keys sorted, so equal input gives equal bytes.

    Args:
        run_folder: The run folder; created if absent.
        manifest: Usually from :func:`build_manifest`.

    Returns:
        The manifest path.

    Raises:
        TypeError, ValueError: If the manifest holds values JSON cannot store.
    """
    if not isinstance(manifest, Mapping):
        raise TypeError(f"manifest must be a mapping, got {type(manifest).__name__}")
    text = json.dumps(_jsonable(manifest, "manifest"), indent=2, sort_keys=True, allow_nan=False)
    return atomic_write_text(Path(run_folder) / MANIFEST_NAME, text + "\n")


def read_manifest(run_folder: str | os.PathLike[str]) -> dict[str, Any]:
    """Read ``run_folder/manifest.json``.

    Raises:
        FileNotFoundError: If there is no manifest.
        ValueError: If it is not a JSON object.
    """
    path = Path(run_folder) / MANIFEST_NAME
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not valid JSON: {err}") from err
    if not isinstance(data, dict):
        raise ValueError(f"{path} must hold a JSON object, got {type(data).__name__}")
    return data
