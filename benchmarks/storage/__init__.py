"""The run-folder layer: every file a run keeps, written atomically and resumable.

A run folder (of ``tooldesign design``, ``tooldesign bench`` or ``tooldesign retest``) holds::

    manifest.json                  config, package versions, git commit, host, times, checksums
                                   (extra.part_sha256: the parts; extra.file_sha256: the design,
                                   retest and consolidated files)
    parts/suite=<s>/variant=<v>/optimizer=<o>/seed=<n>/iteration=<nnnnnn>.csv
    evaluations.parquet | .csv     the parts consolidated at the end
    designs/...                    a suite's final designs (see :mod:`benchmarks.storage.designs`)

Modules, lowest first: :mod:`~benchmarks.storage.atomic` (atomic writes),
:mod:`~benchmarks.storage.runfiles` (the one safe way to read a run folder's files: regular files
inside it only, no link followed; and to refuse writing through a linked folder),
:mod:`~benchmarks.storage.manifest` (``manifest.json``, JSON, checksums),
:mod:`~benchmarks.storage.table` (the evaluation table and its part files),
:mod:`~benchmarks.storage.designs` (a suite's design files),
:mod:`~benchmarks.storage.configdiff` (the compact diff a refused resume shows) and
:mod:`~benchmarks.storage.session` (start or resume a run folder; used by the designer, the
suite runner and the rl suite alike). The columns are named in
:mod:`tooldesign_env.schema`; the files are documented in ``docs/results-format.md``.
"""

from __future__ import annotations

from benchmarks.storage.atomic import atomic_write_bytes, atomic_write_text, check_file_target
from benchmarks.storage.configdiff import FieldChange, config_changes, describe_changes
from benchmarks.storage.designs import (
    DESIGN_RUN_FILES,
    DESIGN_VERSION,
    DESIGNS_DIR,
    INVALID_IN_SCENE,
    RETEST_DIR,
    design_path,
    finite_number,
    paths_path,
    read_design_run_files,
    read_designs,
    read_retests,
    retest_outcome,
    retest_path,
    short_repr,
    write_recorded,
    write_retest,
)
from benchmarks.storage.manifest import (
    FILE_CHECKSUMS,
    MANIFEST_NAME,
    MANIFEST_VERSION,
    REPORT_CHECKSUMS,
    build_manifest,
    file_sha256,
    git_commit,
    git_dirty,
    host_info,
    json_ready,
    json_text,
    package_versions,
    platform_id,
    read_manifest,
    recorded_checksums,
    update_file_checksums,
    verify_checksums,
    write_manifest,
)
from benchmarks.storage.runfiles import (
    MAX_RUN_FILE_BYTES,
    UnsafeRunFileError,
    check_write_folder,
    list_run_files,
    read_run_file,
    refuse_links,
    run_file_path,
    run_file_sha256,
)
from benchmarks.storage.session import (
    PART_CHECKSUMS,
    ResumeError,
    RunSession,
    SettingsChanged,
    check_out_dir,
    with_added_fields,
)
from benchmarks.storage.table import (
    CONSOLIDATED_STEM,
    PARTS_DIR,
    EmptyStoreError,
    Format,
    ResultStore,
    Unit,
    csv_text,
    part_checksums,
    resolve_format,
    status_counts,
    timing_totals,
    validate_evaluations,
)

__all__ = [
    "MAX_RUN_FILE_BYTES",
    "UnsafeRunFileError",
    "check_write_folder",
    "list_run_files",
    "read_run_file",
    "refuse_links",
    "run_file_path",
    "run_file_sha256",
    "FILE_CHECKSUMS",
    "REPORT_CHECKSUMS",
    "FieldChange",
    "config_changes",
    "describe_changes",
    "INVALID_IN_SCENE",
    "RETEST_DIR",
    "read_retests",
    "retest_outcome",
    "recorded_checksums",
    "retest_path",
    "short_repr",
    "update_file_checksums",
    "write_recorded",
    "write_retest",
    "DESIGN_RUN_FILES",
    "CONSOLIDATED_STEM",
    "DESIGNS_DIR",
    "DESIGN_VERSION",
    "MANIFEST_NAME",
    "MANIFEST_VERSION",
    "PARTS_DIR",
    "PART_CHECKSUMS",
    "EmptyStoreError",
    "Format",
    "ResultStore",
    "ResumeError",
    "RunSession",
    "SettingsChanged",
    "Unit",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_file_target",
    "csv_text",
    "build_manifest",
    "check_out_dir",
    "with_added_fields",
    "design_path",
    "finite_number",
    "file_sha256",
    "git_commit",
    "git_dirty",
    "host_info",
    "platform_id",
    "json_ready",
    "json_text",
    "package_versions",
    "part_checksums",
    "paths_path",
    "read_design_run_files",
    "read_designs",
    "read_manifest",
    "resolve_format",
    "status_counts",
    "timing_totals",
    "validate_evaluations",
    "verify_checksums",
    "write_manifest",
]
