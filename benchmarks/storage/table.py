"""The evaluation table of a run folder: one row per evaluation, stored in whole part files.

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
import io
import os
import re
import urllib.parse
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import pandas as pd

from benchmarks.storage.atomic import _TEMP_SUFFIX, atomic_write_bytes
from benchmarks.storage.manifest import (
    FILE_CHECKSUMS,
    MANIFEST_NAME,
    PART_CHECKSUMS,
    file_sha256,
    read_manifest,
    recorded_checksums,
    update_file_checksums,
    verify_checksums,
    write_manifest,
)
from benchmarks.storage.runfiles import UnsafeRunFileError, read_run_file
from tooldesign_env.schema import (
    BEST_SO_FAR,
    COEFFICIENT_PATTERN,
    FLOAT_COLUMNS,
    ID_COLUMNS,
    METRICS,
    RUN_COLUMNS,
    SORT_COLUMNS,
    STANDING_COLUMNS,
    STATUSES,
    STRING_COLUMNS,
    TASK_COLUMNS,
    TIMING_COLUMNS,
)

_REQUIRED: tuple[str, ...] = (
    ("suite", "optimizer") + ID_COLUMNS + METRICS + ("status",) + TIMING_COLUMNS
) + TASK_COLUMNS


Format = Literal["csv", "parquet"]


CONSOLIDATED_STEM = "evaluations"


PARTS_DIR = "parts"


_PART_NAME = re.compile(r"iteration=([0-9]+)\.csv")


class EmptyStoreError(ValueError):
    """A run folder exists but holds no evaluations yet."""


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


def _coefficient_columns(columns: Iterable[str]) -> list[str]:
    found = [c for c in columns if isinstance(c, str) and COEFFICIENT_PATTERN.fullmatch(c)]
    return sorted(found, key=lambda c: int(c[1:]))


def _canonical_order(columns: Iterable[str]) -> list[str]:
    columns = list(columns)
    coefficients = _coefficient_columns(columns)
    head = ["suite", "optimizer", *ID_COLUMNS, *coefficients, *METRICS, *STANDING_COLUMNS, "status"]
    head += [*TIMING_COLUMNS, BEST_SO_FAR, *TASK_COLUMNS, "variant"]
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

    out = rows.drop(columns=[BEST_SO_FAR], errors="ignore").reset_index(drop=True)
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
    frame[BEST_SO_FAR] = best.groupby(keys, sort=False).ffill()
    return frame[_canonical_order(frame.columns)]


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


def _check_frame(value: Any, name: str) -> None:
    if not isinstance(value, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame, got {type(value).__name__}")


def csv_text(frame: pd.DataFrame) -> str:
    """``frame`` as the CSV text of every table a run or a report keeps (no index).

    Floats are written with ``repr``, the shortest string that parses back to the same double,
    so they round-trip bit for bit and do not depend on the locale; NaN is an empty field;
    every line ends with a bare line feed, on every platform.
    """
    _check_frame(frame, "frame")
    return cast(
        "str", frame.to_csv(index=False, lineterminator="\n", float_format=lambda v: repr(float(v)))
    )


def _csv_bytes(frame: pd.DataFrame) -> bytes:
    return csv_text(frame).encode("utf-8")


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


def _read_table(path: Path, folder: Path) -> pd.DataFrame:
    """The consolidated table ``path``, read as a regular file inside ``folder`` only."""
    if path.suffix == ".parquet" and not _pyarrow_available():
        raise ImportError(f"{path}: {_NO_PYARROW}")
    data = read_run_file(folder, path)
    if path.suffix == ".parquet":
        return pd.read_parquet(io.BytesIO(data))
    return _read_csv(io.StringIO(data.decode("utf-8")))


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

    def verify(self) -> list[str]:
        """Refuse a run folder whose files differ from what its manifest records.

        The checks a resumed session makes (:class:`~benchmarks.storage.RunSession`), without
        the ones on the config: every file the manifest's :data:`PART_CHECKSUMS` and
        :data:`FILE_CHECKSUMS` list exists, is a regular file inside the folder (no symbolic
        link, no ``..``) and has its recorded SHA-256, and at most one part file is unrecorded
        (the one written just before a kill, ahead of its manifest). A folder shared without its
        ``parts/`` (the committed results) is read from its consolidated file, which must then
        match its checksum. With parts, the consolidated file is a copy that :meth:`read` does
        not read: if it differs from its checksum (an edit, or a consolidation interrupted
        before the manifest was updated) or the manifest does not list it, a ``RuntimeWarning``
        says so and it is returned as not to be used. A folder without a manifest (a bare
        store) is not checked, and neither is a file the manifest does not list (e.g. the
        design files of a folder written before their checksums were recorded). Nothing is
        written.

        Returns:
            The consolidated tables (paths relative to the folder) that must not be used: they
            differ from their checksum, or the manifest records file checksums but not them.

        Raises:
            ValueError: If the manifest cannot be read, its checksums are malformed, or a
                recorded file is missing, changed, a link or outside the folder; the message
                names the file.
        """
        manifest_path = self.manifest_path
        if not os.path.lexists(manifest_path):
            return []
        manifest = read_manifest(self._folder)
        parts = recorded_checksums(manifest, PART_CHECKSUMS, manifest_path)
        files = recorded_checksums(manifest, FILE_CHECKSUMS, manifest_path)
        on_disk = part_checksums(self, hashed=False)
        if parts is not None and on_disk:
            verify_checksums(self._folder, parts)
            unrecorded = sorted(set(on_disk) - set(parts))
            if len(unrecorded) > 1:
                raise ValueError(
                    f"{self._folder} holds part files {manifest_path} does not record: "
                    f"{unrecorded}; at most one (written just before a kill) may be unrecorded"
                )
        untrusted: list[str] = []
        if files is not None:
            tables = {f"{CONSOLIDATED_STEM}.{suffix}" for suffix in ("csv", "parquet")}
            present = {t for t in tables if os.path.lexists(self._folder / t)}
            untrusted = sorted(present - set(files))
            if on_disk:
                # The parts are the source of truth and read() reads them: the consolidated
                # file, a copy rewritten at every session's end, must not lock the folder out
                # (an interrupted consolidation), nor be shown if it differs.
                for table in sorted(tables & set(files)):
                    try:
                        verify_checksums(self._folder, {table: files[table]})
                    except (ValueError, OSError) as err:
                        if table in present:
                            untrusted.append(table)
                            warnings.warn(
                                f"{err}. It is not used: the results are read from the part "
                                "files (resume the run to rebuild it)",
                                RuntimeWarning,
                                stacklevel=2,
                            )
                files = {k: v for k, v in files.items() if k not in tables}
            verify_checksums(self._folder, files)
        return sorted(set(untrusted))

    def read(self, *, verify: bool = True) -> pd.DataFrame:
        """All stored evaluations with ``best_so_far``, sorted by :data:`SORT_COLUMNS`.

        Part files are the source of truth; the consolidated file is read only when there are
        no parts (e.g. a run folder shared without them).

        Args:
            verify: First check the folder against the checksums its manifest records
                (:meth:`verify`); a caller that has just verified it may skip this.

        Returns:
            (n_evaluations, n_columns) DataFrame in the canonical column order and dtypes.

        Raises:
            FileNotFoundError: If the run folder does not exist.
            NotADirectoryError: If it is a file.
            EmptyStoreError: If it holds neither part files nor a consolidated file.
            TypeError, ValueError: If a stored file does not follow the results format, or
                (``verify``) differs from what the manifest records; the message names the
                file and the column.
        """
        self._check_folder()
        untrusted = self.verify() if verify else []
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
            if path.name in untrusted:
                raise UnsafeRunFileError(
                    f"{path} is not listed among the files {self.manifest_path} records; it "
                    "was not written by this run and is not read"
                )
            combined = validate_evaluations(_read_table(path, self._folder), source=str(path))
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
                    raw = _read_csv(io.StringIO(read_run_file(self._folder, path).decode("utf-8")))
                except UnsafeRunFileError:
                    raise
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
            text = read_run_file(self._folder, self.part_path(unit)).decode("utf-8")
            header, _, body = text.partition("\n")
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

        In a run folder whose manifest records file checksums, the manifest is updated to name
        the new file (and forget the removed one), so the folder stays readable.

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
        stale = self._folder / f"{CONSOLIDATED_STEM}.{other}"
        if self.manifest_path.exists():
            # The manifest names the new file before the old one goes: an interrupt between the
            # two leaves an unlisted file, which nothing checks, never a listed one missing.
            manifest = read_manifest(self._folder)
            if recorded_checksums(manifest, FILE_CHECKSUMS, self.manifest_path) is not None:
                update_file_checksums(
                    self._folder, {target.name: file_sha256(target), stale.name: None}
                )
        # A stale file of the other format would be read instead of the fresh one elsewhere.
        stale.unlink(missing_ok=True)
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
    _check_frame(evaluations, "evaluations")
    for name in TIMING_COLUMNS:
        if name not in evaluations.columns:
            raise ValueError(f"evaluations: missing column {name!r}")
    return {
        "simulation_time": float(evaluations["eval_time"].sum()),
        "optimizer_time": float(evaluations["opt_time"].sum()),
    }


def status_counts(evaluations: pd.DataFrame) -> dict[str, int]:
    """How many evaluations of a log there are, and of each status.

    Args:
        evaluations: Rows with a ``status`` column (an empty frame has none).

    Returns:
        ``{"total": n, "ok": n, "invalid": n, "failed": n}``.
    """
    _check_frame(evaluations, "evaluations")
    counts = evaluations["status"].value_counts() if "status" in evaluations.columns else {}
    return {"total": int(len(evaluations)), **{s: int(counts.get(s, 0)) for s in STATUSES}}


def part_checksums(store: ResultStore, *, hashed: bool = True) -> dict[str, str]:
    """``{path relative to the run folder: sha256}`` of every completed part file.

    With ``hashed`` false the values are ``""``: the paths alone, without reading the files.
    """
    if not isinstance(store, ResultStore):
        raise TypeError(f"store must be a ResultStore, got {type(store).__name__}")
    out: dict[str, str] = {}
    for unit in sorted(store.completed_units(), key=lambda u: str(u.relative_path)):
        path = store.part_path(unit)
        out[path.relative_to(store.run_folder).as_posix()] = file_sha256(path) if hashed else ""
    return out
