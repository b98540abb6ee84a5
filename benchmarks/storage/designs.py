"""The layout of design files: a design run's folder, and a suite's per-run design files.

Layout (names percent-encoded as in part paths)::

    run_folder/designs/variant=<v>/optimizer=<o>/seed=<n>.json        the run's best design,
                                                                       its test, its counts
    run_folder/designs/variant=<v>/optimizer=<o>/seed=<n>.paths.json  box paths (optional)

A design file is written last, atomically: its presence marks the run as complete. The suite
runner records the SHA-256 of both files in the manifest (``extra.file_sha256``), and
``tooldesign retest`` that of each retest file (:func:`write_retest`): :func:`read_designs` and
:func:`read_retests` refuse a recorded file that was edited, truncated or removed. Files the
manifest does not list (a folder written before these checksums were recorded) are read
unchecked, but their contents are still checked.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import urllib.parse
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

from benchmarks.storage.atomic import atomic_write_text
from benchmarks.storage.manifest import (
    FILE_CHECKSUMS,
    MANIFEST_NAME,
    check_sha256,
    read_manifest,
    recorded_checksums,
    update_file_checksums,
    verify_checksums,
)
from benchmarks.storage.runfiles import (
    UnsafeRunFileError,
    check_write_folder,
    list_run_files,
    read_run_file,
)
from tooldesign_env.schema import METRICS, STANDING_COLUMNS

__all__ = [
    "INVALID_IN_SCENE",
    "RETEST_DIR",
    "read_retests",
    "retest_outcome",
    "retest_path",
    "short_repr",
    "write_recorded",
    "write_retest",
    "DESIGN_RUN_FILES",
    "DESIGNS_DIR",
    "DESIGN_VERSION",
    "design_path",
    "finite_number",
    "paths_path",
    "read_design_run_files",
    "read_designs",
]

DESIGN_RUN_FILES: dict[str, str] = {
    "card": "design.json",
    "stl": "tool.stl",
    "obj": "tool.obj",
    "urdf": "tool.urdf",
    "evaluations": "evaluations.csv",
    "robustness": "robustness.json",
    "robustness_png": "robustness.png",
    "fig3a": "fig3a_tool_curves.png",
    "fig3b": "fig3b_free_energy.png",
    "fig3c": "fig3c_box_paths.png",
    "fig3d": "fig3d_final_tool.png",
    "fig3": "figure3.png",
    "box_paths": "box_paths.json",
    "video": "rollout.gif",
    "html": "report.html",
}

"""Files of a finished ``tooldesign design`` run folder, besides ``manifest.json`` and ``parts/``.

``box_paths.json`` holds the box paths the figures draw (the best design of each iteration, and
the robustness test's), rounded to :data:`~tooldesign_env.schema.PATH_DECIMALS`; ``rollout.gif``
is written unless the video is turned off.
"""

DESIGNS_DIR = "designs"
"""Folder of the per-run design files in a run folder."""

DESIGN_VERSION = 1
"""``format_version`` of a design file."""


def _q(name: str) -> str:
    return urllib.parse.quote(name, safe="")


def design_path(
    run_folder: str | os.PathLike[str], *, variant: str, optimizer: str, seed: int
) -> Path:
    """The design file of a run: ``designs/variant=<v>/optimizer=<o>/seed=<n>.json``."""
    return (
        Path(run_folder)
        / DESIGNS_DIR
        / f"variant={_q(variant)}"
        / f"optimizer={_q(optimizer)}"
        / f"seed={int(seed)}.json"
    )


def paths_path(design_file: str | os.PathLike[str]) -> Path:
    """The box-path file next to a design file (``seed=<n>.paths.json``)."""
    path = Path(design_file)
    return path.with_name(path.name.removesuffix(".json") + ".paths.json")


class _Files:
    """The checksums the manifest of a run folder records for some of its files.

    Args:
        run_folder: The run folder.
        under: A folder (the files below it) or the names of files directly in the run folder.
    """

    def __init__(self, run_folder: Path, under: str | Collection[str]) -> None:
        self.folder = run_folder
        self.recorded: dict[str, str] = {}
        manifest = run_folder / MANIFEST_NAME
        if manifest.is_file():
            listed = recorded_checksums(read_manifest(run_folder), FILE_CHECKSUMS, manifest)
            if isinstance(under, str):
                prefix = under + "/"
                self.recorded = {k: v for k, v in (listed or {}).items() if k.startswith(prefix)}
            else:
                self.recorded = {k: v for k, v in (listed or {}).items() if k in under}
        # Missing and moved files first: a file the manifest lists must be there.
        verify_checksums(run_folder, self.recorded)

    def load(self, path: Path, what: str) -> Any:
        """The JSON of ``path``, checked against its recorded SHA-256 if it has one."""
        try:
            data = read_run_file(self.folder, path)
        except UnsafeRunFileError:
            raise
        except OSError as err:
            raise ValueError(f"{path}: not a readable {what}: {err.strerror or err}") from err
        expected = self.recorded.get(path.relative_to(self.folder).as_posix())
        if expected is not None:
            check_sha256(path, expected, data)
        try:
            return json.loads(data.decode("utf-8"), parse_constant=_refuse_constant)
        except UnicodeDecodeError as err:
            raise ValueError(
                f"{path}: not a valid {what}: not UTF-8 text ({err.reason} at byte {err.start})"
            ) from err
        except (ValueError, RecursionError) as err:
            raise ValueError(f"{path}: not a valid {what}: {err}") from err


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"it holds {name}, which JSON has not (a value that is not finite is null)")


def finite_number(value: Any) -> bool:
    """Whether a JSON value is a finite number (a bool is not)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_design(record: Any, path: Path, folder: Path) -> dict[str, Any]:
    """``record`` if it is a design file of the run its path names; ValueError otherwise."""

    def bad(field: str, allowed: str, value: Any) -> ValueError:
        got = "nothing" if value is None and field not in record else short_repr(value)
        return ValueError(f"{path}: field {field!r} must be {allowed}, got {got}")

    if not isinstance(record, dict):
        kind = "null" if record is None else type(record).__name__
        raise ValueError(f"{path}: not a valid design file: it must hold a JSON object, got {kind}")
    version = record.get("format_version", DESIGN_VERSION)
    if version != DESIGN_VERSION or isinstance(version, bool):
        raise bad("format_version", f"{DESIGN_VERSION} (this version's design files)", version)
    for field in ("variant", "optimizer"):
        if not isinstance(record.get(field), str):
            raise bad(field, "a string", record.get(field))
    seed = record.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise bad("seed", "an integer >= 0", seed)
    expected = design_path(
        folder, variant=record["variant"], optimizer=record["optimizer"], seed=seed
    )
    if expected != path:
        raise ValueError(
            f"{path}: holds the design of variant {record['variant']!r}, optimizer "
            f"{record['optimizer']!r}, seed {seed}, which belongs in {expected}"
        )
    goal = record.get("goal")
    if not (isinstance(goal, list) and len(goal) == 3 and all(finite_number(v) for v in goal)):
        raise bad("goal", "a list of 3 finite numbers (m)", goal)
    if not finite_number(record.get("goal_precision")):
        raise bad("goal_precision", "a finite number", record.get("goal_precision"))
    coefficients = record.get("coefficients")
    if coefficients is not None and not (
        isinstance(coefficients, list) and all(finite_number(v) for v in coefficients)
    ):
        raise bad("coefficients", "a list of finite numbers or null", coefficients)
    for field in (*METRICS, *STANDING_COLUMNS, "test_time"):
        value = record.get(field)
        if value is not None and not finite_number(value):
            raise bad(field, "a finite number or null", value)
    if record.get("status") is not None and not isinstance(record["status"], str):
        raise bad("status", "a string or null", record["status"])
    if record.get("test") is not None and not isinstance(record["test"], dict):
        raise bad("test", "a JSON object or null", record["test"])
    return record


def _listed(root: Path, under: str) -> list[Path]:
    """The ``seed=*.json`` files below ``root/under``; a link or FIFO among them is refused.

    A link in a design folder is not a design: reading it could read any file of the machine,
    and leaving it out silently would drop a run from the reports.
    """
    files, left_out = list_run_files(root, under=under)
    for relative, kind in left_out.items():
        name = relative.rpartition("/")[2]
        if name.startswith("seed=") and name.endswith(".json"):
            raise UnsafeRunFileError(
                f"{root / relative} is {kind}, not a regular file; a run folder's files are read "
                "only if they are regular files inside it"
            )
    return [
        root / relative
        for relative in files
        if (name := relative.rpartition("/")[2]).startswith("seed=") and name.endswith(".json")
    ]


def _run_folder(run_folder: str | os.PathLike[str]) -> Path:
    """``run_folder`` as a Path, refused if it is not an existing folder (as ResultStore does).

    A typo'd run folder must not read as a folder without designs or retests.
    """
    if not isinstance(run_folder, (str, os.PathLike)):
        raise TypeError(f"run_folder must be a path, got {type(run_folder).__name__}")
    root = Path(run_folder)
    if not root.exists():
        raise FileNotFoundError(f"run folder {root} does not exist")
    if not root.is_dir():
        raise NotADirectoryError(f"run folder {root} is not a folder")
    return root


def read_designs(run_folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The design files of a run folder, in a fixed order (variant, optimizer, seed).

    Args:
        run_folder: A suite run folder.

    Returns:
        One dict per finished run (the JSON of its design file); ``paths`` is added, loaded from
        its paths file, when there is one. Empty if the folder has no ``designs/`` (no run
        has finished yet).

    Raises:
        TypeError: If ``run_folder`` is not a path.
        FileNotFoundError: If ``run_folder`` does not exist.
        NotADirectoryError: If it is a file.
        ValueError: If a design or paths file the manifest records is missing or changed
            (its SHA-256 differs), or a file is not UTF-8 JSON of the expected form (a design
            file: an object whose ``variant``, ``optimizer`` and ``seed`` name its path, with
            its goal and numbers); the message names the file and the field.
    """
    root = _run_folder(run_folder)
    folder = root / DESIGNS_DIR
    if not folder.is_dir():
        return []
    files = _Files(root, DESIGNS_DIR)
    records = []
    for path in _listed(root, DESIGNS_DIR):
        if path.name.endswith(".paths.json"):
            continue
        record = _check_design(files.load(path, "design file"), path, root)
        extra = paths_path(path)
        if os.path.lexists(extra):
            paths = files.load(extra, "box-path file")
            if not isinstance(paths, dict):
                raise ValueError(
                    f"{extra}: not a valid box-path file: it must hold a JSON object, got "
                    f"{'null' if paths is None else type(paths).__name__}"
                )
            record["paths"] = paths
        records.append(record)
    records.sort(key=lambda r: (r["variant"], r["optimizer"], r["seed"]))
    return records


def _kind_of(value: Any) -> str:
    return "null" if value is None else type(value).__name__


def short_repr(value: Any) -> str:
    """``repr(value)`` cut to 80 characters, for an error message."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


class _Form:
    """Checks of one JSON file's fields; each error names the file and the field."""

    def __init__(self, path: Path, record: Any, what: str) -> None:
        if not isinstance(record, dict):
            raise ValueError(
                f"{path}: not a valid {what}: it must hold a JSON object, got {_kind_of(record)}"
            )
        self.path, self.record = path, record

    def bad(self, field: str, allowed: str, value: Any) -> ValueError:
        name = field.split(".")[-1].split("[")[0]
        got = "nothing" if name not in self.record else short_repr(value)
        return ValueError(f"{self.path}: field {field!r} must be {allowed}, got {got}")

    def number(self, field: str, *, null: bool = False) -> None:
        value = self.record.get(field)
        if not (finite_number(value) or (null and value is None and field in self.record)):
            raise self.bad(field, "a finite number" + (" or null" if null else ""), value)

    def numbers(self, field: str) -> None:
        value = self.record.get(field)
        if not (isinstance(value, list) and all(finite_number(v) for v in value)):
            raise self.bad(field, "a list of finite numbers", value)

    def paths(self, field: str, *, one: bool = False) -> None:
        """A box path ((T, 3) positions in m, null where not finite), or a list of them."""
        value = self.record.get(field)
        items = [value] if one else value
        allowed = "a box path" if one else "a list of box paths"
        allowed += " ([[x, y, z], ...] in m)"
        if not isinstance(items, list):
            raise self.bad(field, allowed, value)
        for i, path in enumerate(items):
            where = field if one else f"{field}[{i}]"
            if not isinstance(path, list):
                raise self.bad(where, "a box path ([[x, y, z], ...] in m)", path)
            for t, point in enumerate(path):
                if not (
                    isinstance(point, list)
                    and len(point) == 3
                    and all(v is None or finite_number(v) for v in point)
                ):
                    raise ValueError(
                        f"{self.path}: field '{where}[{t}]' must be a point [x, y, z] of finite "
                        f"numbers (m) or null, got {short_repr(point)}"
                    )


def _check_card(form: _Form) -> None:
    form.numbers("coefficients")
    if not form.record["coefficients"]:
        raise form.bad("coefficients", "a non-empty list of finite numbers", [])
    form.number("free_energy", null=True)


def _check_robustness(form: _Form) -> None:
    error = form.record.get("error", "")
    if not isinstance(error, str):
        raise form.bad("error", 'a string ("" if the tool was tested)', error)
    if not error:
        form.number("robustness")


def _check_box_paths(form: _Form, tested: bool) -> None:
    iterations = form.record.get("iterations")
    if not (
        isinstance(iterations, list)
        and all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in iterations)
    ):
        raise form.bad("iterations", "a list of iterations (integers >= 0)", iterations)
    form.paths("iteration_bests")
    if len(form.record["iteration_bests"]) != len(iterations):
        raise ValueError(
            f"{form.path}: field 'iteration_bests' must hold one path per iteration of field "
            f"'iterations' ({len(iterations)}), got {len(form.record['iteration_bests'])}"
        )
    if not tested:  # the figures draw the robustness test's paths only when it was run
        return
    form.number("nominal_mass")
    form.numbers("masses")
    form.paths("nominal", one=True)
    form.paths("perturbed")
    if len(form.record["perturbed"]) != len(form.record["masses"]):
        raise ValueError(
            f"{form.path}: field 'perturbed' must hold one path per mass of field 'masses' "
            f"({len(form.record['masses'])}), got {len(form.record['perturbed'])}"
        )


def read_design_run_files(run_folder: str | os.PathLike[str]) -> dict[str, dict[str, Any]]:
    """``design.json``, ``robustness.json`` and ``box_paths.json`` of a design run, checked.

    Each file is read as the suite's design files are: its SHA-256 is compared with the one
    the manifest records for it, if any, and it must be UTF-8 JSON (no ``NaN`` literal) of the
    form the report draws.

    Args:
        run_folder: A finished ``tooldesign design`` run folder.

    Returns:
        ``{"card": ..., "robustness": ..., "box_paths": ...}``, the files' JSON objects.

    Raises:
        TypeError: If ``run_folder`` is not a path.
        FileNotFoundError: If the folder, or one of the files (the run is not finished), is
            missing.
        NotADirectoryError: If ``run_folder`` is a file.
        ValueError: If a file differs from its recorded checksum, is not UTF-8 JSON, or a field
            the report reads has the wrong form; the message names the file and the field.
    """
    root = _run_folder(run_folder)
    keys = ("card", "robustness", "box_paths")
    for key in keys:
        if not (root / DESIGN_RUN_FILES[key]).is_file():
            raise FileNotFoundError(
                f"{root / DESIGN_RUN_FILES[key]} is missing: {root} is not a finished design run"
            )
    files = _Files(root, [DESIGN_RUN_FILES[key] for key in keys])
    what = {"card": "design card", "robustness": "robustness file", "box_paths": "box-path file"}
    forms = {}
    for key in keys:
        path = root / DESIGN_RUN_FILES[key]
        forms[key] = _Form(path, files.load(path, what[key]), what[key])
    _check_card(forms["card"])
    _check_robustness(forms["robustness"])
    _check_box_paths(forms["box_paths"], tested=not forms["robustness"].record.get("error"))
    return {key: form.record for key, form in forms.items()}


RETEST_DIR = "retest"
"""Folder of the retest files in a run folder."""

INVALID_IN_SCENE = "the design is invalid in a nudged scene"
"""How a retest's ``error`` begins (after the exception's type) when the design itself failed:
it cannot be built or overlaps the box in one of the nudged scenes."""


def retest_outcome(record: Mapping[str, Any]) -> str:
    """What a retest file says happened: ``"ok"``, ``"invalid"`` or ``"failed"``.

    ``"invalid"``: the design was invalid in a nudged scene (:data:`INVALID_IN_SCENE`), an
    outcome of the design, the largest change a nudge can make. ``"failed"``: the retest broke
    for another reason (a worker that died, an error of the code): no outcome of the design,
    and ``tooldesign retest`` tries it again.
    """
    error = str(record.get("error") or "")
    if not error:
        return "ok"
    return "invalid" if INVALID_IN_SCENE in error else "failed"


def retest_path(run_folder: Path, design_file: Path) -> Path:
    """The retest file of a design file: ``retest/`` mirrors ``designs/``."""
    return run_folder / RETEST_DIR / design_file.relative_to(run_folder / DESIGNS_DIR)


def write_retest(run_folder: str | os.PathLike[str], target: Path, text: str) -> Path:
    """Write a retest file atomically and record its SHA-256 in the run folder's manifest.

    Args:
        run_folder: The suite run folder (it holds ``manifest.json``).
        target: The retest file, from :func:`retest_path`.
        text: Its JSON text.

    Returns:
        ``target``.
    """
    return write_recorded(run_folder, target, text)


def write_recorded(run_folder: str | os.PathLike[str], target: Path, text: str) -> Path:
    """Write a file of a run folder atomically and record its SHA-256 in the manifest.

    For a folder no session is writing (a session keeps its own records: use
    ``RunSession.record_file``). The old record is removed first, so a kill between the writes
    leaves the file unrecorded (read unchecked), never recorded with the checksum of the file
    it replaced.

    Args:
        run_folder: The run folder (it holds ``manifest.json``).
        target: The file, inside ``run_folder``.
        text: Its text, written as UTF-8.

    Returns:
        ``target``.
    """
    folder = Path(run_folder)
    relative = target.relative_to(folder).as_posix()
    check_write_folder(folder, target.parent)  # never through a linked retest/ or designs/
    update_file_checksums(folder, {relative: None})
    atomic_write_text(target, text)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()
    update_file_checksums(folder, {relative: digest})
    return target


def _check_retest(record: Any, path: Path) -> dict[str, Any]:
    """``record`` if it has the form the retest reports read; ValueError otherwise."""
    if not isinstance(record, dict):
        kind = "null" if record is None else type(record).__name__
        raise ValueError(f"{path}: not a valid retest file: it must hold a JSON object, got {kind}")
    for field in ("noise", "stress"):
        rows = record.get(field)
        if rows is None:
            continue
        if not (isinstance(rows, list) and all(isinstance(r, Mapping) for r in rows)):
            raise ValueError(f"{path}: field {field!r} must be a list of JSON objects")
        needed = METRICS if field == "noise" else ("change", "value")
        for i, row in enumerate(rows):
            missing = [k for k in needed if k not in row]
            if missing:
                raise ValueError(f"{path}: field '{field}[{i}]' has no {', '.join(missing)}")
            if field == "stress" and not isinstance(row["change"], str):
                raise ValueError(f"{path}: field 'stress[{i}].change' must be a string")
            for key, value in row.items():
                if key != "change" and not (value is None or finite_number(value)):
                    raise ValueError(
                        f"{path}: field '{field}[{i}].{key}' must be a finite number or null, "
                        f"got {value!r}"
                    )
    return record


def read_retests(run_folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Every retest file of a run folder (empty if it was not retested), in a fixed order.

    Raises:
        TypeError: If ``run_folder`` is not a path.
        FileNotFoundError: If ``run_folder`` does not exist.
        NotADirectoryError: If it is a file.
        ValueError: If a retest file the manifest records is missing or changed, or a file
            is not UTF-8 JSON of the expected form; the message names the file.
    """
    root = _run_folder(run_folder)
    folder = root / RETEST_DIR
    if not folder.is_dir():
        return []
    files = _Files(root, RETEST_DIR)
    out = []
    for path in _listed(root, RETEST_DIR):
        out.append(_check_retest(files.load(path, "retest file"), path))
    return out
