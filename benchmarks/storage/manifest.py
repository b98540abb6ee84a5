"""``manifest.json``: what made a run folder (config, versions, commit, host, times); checksums."""

from __future__ import annotations

import dataclasses
import datetime as dt
import enum
import hashlib
import importlib.metadata
import json
import math
import os
import platform
import re
import subprocess
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.storage.atomic import atomic_write_text
from benchmarks.storage.lock import holding
from benchmarks.storage.runfiles import (
    UnsafeRunFileError,
    read_run_file,
    run_file_path,
    run_file_sha256,
)

MANIFEST_NAME = "manifest.json"


MANIFEST_VERSION = 1


PART_CHECKSUMS = "part_sha256"
"""Key in the manifest's ``extra`` of the part files' SHA-256 checksums."""

FILE_CHECKSUMS = "file_sha256"
"""Key in the manifest's ``extra`` of the SHA-256 checksums of the run's other result files.

The design files of a suite (and their box-path files), the retest files and the consolidated
evaluation table, by path relative to the run folder. Folders written before this key existed
do not have it: their files are read unchecked (see :func:`recorded_checksums`).
"""


REPORT_CHECKSUMS = "report_sha256"
"""Key in the manifest's ``extra`` of the SHA-256 checksums of the files a report wrote.

What ``tooldesign report`` (and ``bench``, ``bench rl``, ``reproduce``, which make the same
report) writes under ``report/``, and the figures and video of a design run, by path relative to
the run folder. They are made from the checked results and can be made again, so a file that
differs is not a damaged run: the readers (``html``, ``reproduce``, ``equivalence verdicts``)
leave it out with a warning instead of refusing the folder, and the next ``tooldesign report``
writes and records it again (:func:`benchmarks.storage.runfolder.record_report_files`). Kept
apart from :data:`FILE_CHECKSUMS` for that reason, and because a folder written before that key
existed would otherwise gain it and have its consolidated table read as unlisted.
"""


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
    "trimesh",
    "scikit-learn",  # BO's Gaussian process
    # the optional backends, executors and agents a run may use (recorded when installed)
    "optuna",
    "nevergrad",
    "dask",
    "distributed",
    "stable-baselines3",
    "torch",
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
    folder = _code_folder(repo_dir)
    commit = None if folder is None else _git(folder, "rev-parse", "HEAD")
    return commit if commit is not None and re.fullmatch(r"[0-9a-f]{40}", commit) else None


def _git(folder: Path, *args: str) -> str | None:
    """``git ARGS`` run in ``folder``: its stripped output, or None without git or on failure."""
    try:
        result = subprocess.run(
            ["git", *args], cwd=folder, capture_output=True, text=True, timeout=10, check=True
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return result.stdout.strip()


def _code_folder(repo_dir: str | os.PathLike[str] | None) -> Path | None:
    """Where to ask git: ``repo_dir``, or this package's folder if git tracks this file there.

    An installed copy inside another project's work tree (its ``.venv``) is not tracked, and
    that project's commit would otherwise be recorded as the code's.
    """
    if repo_dir is not None:
        return Path(repo_dir)
    here = Path(__file__).resolve()
    tracked = _git(here.parent, "ls-files", "--error-unmatch", here.name) is not None
    return here.parent if tracked else None


def git_dirty(repo_dir: str | os.PathLike[str] | None = None) -> bool | None:
    """Whether the repository's tracked files differ from its commit, or ``None`` without git.

    A run's :func:`git_commit` names the code only if this is False: ``git status --porcelain
    --untracked-files=no`` lists changed tracked files (new untracked files are not code the
    package imports unless added, so they are not counted).

    Args:
        repo_dir: A folder inside the repository; defaults to the folder of this module.
    """
    folder = _code_folder(repo_dir)
    if folder is None:
        return None
    status = _git(folder, "status", "--porcelain", "--untracked-files=no")
    return None if status is None else bool(status)


def host_info() -> dict[str, Any]:
    """The machine: platform, CPU, Python version, CPU count, control loop (no host name).

    The CPU's model is kept because results agree bit for bit only on the same kind of CPU
    (PyBullet's maths routines are chosen by the CPU's features), and the control loop because
    the times depend on it (its results do not: ``tooldesign_env.native``).
    """
    from tooldesign_env.native import status

    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "cpu": _cpu_model(),
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "control_loop": status(),
    }


def platform_id() -> str:
    """Which platform a run of the physics is on: the last bits of its results depend on it.

    PyBullet's physics is deterministic on one machine, but glibc and NumPy pick their maths
    routines by the CPU's features at run time (an FMA ``sin`` or ``cos`` rounds differently), so
    the same code gives other last bits on another kind of CPU. The key: the CPU model and the
    features glibc and NumPy dispatch on, NumPy's and PyBullet's versions. Results recorded with
    one key are reproduced bit for bit only under the same key (the tests' fixtures,
    ``readme.json``).
    """
    model, flags = _cpuinfo()
    model = model or "unknown CPU"
    features = ",".join(f for f in ("fma", "avx2", "avx512f") if f in flags)
    return (
        f"{platform.machine()} {model} [{features}] numpy {np.__version__} "
        f"pybullet {importlib.metadata.version('pybullet')}"
    )


def _cpuinfo() -> tuple[str | None, set[str]]:
    """The first CPU's model name and feature flags from Linux's /proc/cpuinfo (None, {} else)."""
    model: str | None = None
    flags: set[str] = set()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and model is None:
                    model = value.strip()
                elif key.strip() == "flags" and not flags:
                    flags = set(value.split())
    except OSError:
        pass
    return model, flags


def _cpu_model() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo), else what the platform module says."""
    return _cpuinfo()[0] or platform.processor() or "unknown"


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
        repo_dir: Where to ask git for the commit and whether the code differs from it; see
            :func:`git_commit` and :func:`git_dirty`.
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
        "git_dirty": git_dirty(repo_dir),
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
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks.

    Raises:
        TypeError: ``path`` is not a path (an int would be read as a file descriptor).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike, got {type(path).__name__} {path!r}")
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def recorded_checksums(
    manifest: Mapping[str, Any], key: str, where: str | os.PathLike[str]
) -> dict[str, str] | None:
    """The checksums a manifest records under ``extra[key]``, or ``None`` if it records none.

    Args:
        manifest: A manifest, e.g. from :func:`read_manifest`.
        key: :data:`PART_CHECKSUMS`, :data:`FILE_CHECKSUMS` or :data:`REPORT_CHECKSUMS`.
        where: The manifest's path, for error messages.

    Returns:
        ``{path relative to the run folder: hex sha256}``; ``None`` if ``extra`` has no ``key``
        (a folder written before the key existed).

    Raises:
        ValueError: If ``extra`` is not an object, or ``extra[key]`` is not an object of
            relative paths to 64-digit hex strings.
    """
    extra = manifest.get("extra", {})
    if not isinstance(extra, Mapping):
        raise ValueError(f"{where}: field 'extra' must be a JSON object, got {_kind(extra)}")
    if key not in extra:
        return None
    recorded = extra[key]
    if not isinstance(recorded, Mapping):
        raise ValueError(
            f"{where}: field 'extra.{key}' must be a JSON object of relative paths to SHA-256 "
            f"checksums, got {_kind(recorded)}"
        )
    for relative, digest in recorded.items():
        if not (isinstance(digest, str) and _SHA256.fullmatch(digest)):
            raise ValueError(
                f"{where}: field 'extra.{key}' holds {digest!r} for {relative!r}; a checksum "
                "is 64 hex digits"
            )
    return dict(recorded)


_SHA256 = re.compile(r"[0-9a-f]{64}")
_MAX_MANIFEST_BYTES = 64 << 20  # a suite's manifest lists hundreds of files in a few 10 kB


def _kind(value: Any) -> str:
    return "null" if value is None else type(value).__name__


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
    manifest = folder / MANIFEST_NAME
    if not isinstance(recorded, Mapping):
        raise ValueError(f"{manifest}: the checksums are not a mapping")
    for relative, expected in sorted(recorded.items()):
        if not isinstance(expected, str):
            raise ValueError(f"{manifest}: the checksum of {relative!r} is not a str")
        try:
            path = run_file_path(folder, relative)
            actual = run_file_sha256(folder, path)
        except UnsafeRunFileError as err:
            raise UnsafeRunFileError(
                f"{manifest} lists {relative!r}, which is refused: {err}"
            ) from None
        except FileNotFoundError:
            raise ValueError(
                f"{folder / relative} is listed in the manifest but missing; the run folder is "
                "incomplete"
            ) from None
        check_sha256(path, expected, actual=actual)


def check_sha256(
    path: str | os.PathLike[str],
    expected: str,
    data: bytes | None = None,
    *,
    actual: str | None = None,
) -> None:
    """Refuse a file whose SHA-256 is not the ``expected`` one the manifest records.

    Args:
        path: The file.
        expected: Its recorded hex SHA-256.
        data: Its bytes, if already read (then they are hashed, not the file).
        actual: Its SHA-256, if already computed.

    Raises:
        ValueError: If it differs; the message names the file.
    """
    if actual is None:
        actual = file_sha256(path) if data is None else hashlib.sha256(data).hexdigest()
    if actual != expected:
        raise ValueError(
            f"{path} has changed since it was written (sha256 {actual[:12]}..., the "
            f"manifest records {expected[:12]}...): the file was edited, truncated or "
            "corrupted; restore it or start a new run folder"
        )


def update_file_checksums(
    run_folder: str | os.PathLike[str],
    changes: Mapping[str, str | None],
    *,
    key: str = FILE_CHECKSUMS,
) -> None:
    """Set (or, with ``None``, remove) entries of the manifest's :data:`FILE_CHECKSUMS`.

    For files written after the run's session finished (``tooldesign retest``): the manifest
    is read, changed and rewritten atomically.

    Args:
        run_folder: The run folder; it must hold a manifest.
        changes: ``{path relative to the run folder: sha256 or None}``.
        key: The record to change: :data:`FILE_CHECKSUMS` (the default) or
            :data:`REPORT_CHECKSUMS` (created if the manifest has none).

    Raises:
        FileNotFoundError: If there is no manifest.
        ValueError: If it cannot be read or its checksums are malformed, or a session of another
            process is writing the folder (its manifest would overwrite the change).
    """
    # A session of another process rewrites the manifest from its own view: wait for it to end.
    with holding(run_folder):
        manifest = read_manifest(run_folder)
        where = Path(run_folder) / MANIFEST_NAME
        if key not in (FILE_CHECKSUMS, REPORT_CHECKSUMS):
            raise ValueError(f"key must be {FILE_CHECKSUMS!r} or {REPORT_CHECKSUMS!r}, got {key!r}")
        recorded = recorded_checksums(manifest, key, where) or {}
        for relative, digest in changes.items():
            run_file_path(run_folder, relative)  # a relative path inside the folder, or refused
            if digest is None:
                recorded.pop(relative, None)
            else:
                recorded[relative] = digest
        checksums = dict(sorted(recorded.items()))
        manifest["extra"] = {**manifest.get("extra", {}), key: checksums}
        write_manifest(run_folder, manifest)


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
        ValueError: If it is not UTF-8 text holding a JSON object.
    """
    path = Path(run_folder) / MANIFEST_NAME
    try:
        raw = read_run_file(run_folder, MANIFEST_NAME, max_bytes=_MAX_MANIFEST_BYTES)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path} does not exist") from None
    except (NotADirectoryError, IsADirectoryError) as err:
        raise FileNotFoundError(f"{path} does not exist ({err})") from None
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as err:
        raise ValueError(f"{path} is not UTF-8 text ({err.reason} at byte {err.start})") from err
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not valid JSON: {err}") from err
    except RecursionError as err:
        raise ValueError(f"{path} is nested too deeply to be a manifest") from err
    if not isinstance(data, dict):
        raise ValueError(f"{path} must hold a JSON object, got {type(data).__name__}")
    return data
