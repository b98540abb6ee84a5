"""What a suite's report concludes, apart from its last digits: its verdicts and rankings.

Test 3 of the equivalence rule (``docs/performance.md``, "The equivalence rule"): after a change
to the simulation or the objective, the smoke suites' verdicts and rankings must not change,
though their numbers may move within the noise. Read from a run folder's report tables alone
(nothing is simulated):

- ``pairwise``: per pair of optimizers, variant and metric of ``pairwise.csv``, whether the
  difference is significant and whether it is beyond the noise floor;
- ``ranking``: per variant with two optimizers or more in ``summary.csv``, the optimizers in
  order of their mean final F and of their mean area under the curve (lower first);
- ``best``: every ``*_best`` mark of a table (Table I's best variant per metric);
- ``shown``: which seed's design a figure shows per variant (``tool-shapes.csv``, the
  ``shown`` column of ``mass-perturbation.csv``): the lowest-F design, a ranking of seeds.

Command: ``tooldesign equivalence verdicts BEFORE AFTER``.
"""

from __future__ import annotations

import functools
import io
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["compare_verdicts", "read_report_tables", "verdicts"]

Table = Sequence[Mapping[str, Any]]


def _name(key: str) -> str:
    return key.rsplit("/", 1)[-1]


def _number(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _sort_key(metric: str, row: Mapping[str, Any]) -> tuple[bool, float]:
    number = _number(row.get(metric))
    return math.isnan(number), number


def _group(row: Mapping[str, Any]) -> str:
    """The row's variant (and optimizer, where a table has one row per optimizer)."""
    variant = str(row.get("variant") or "-")
    optimizer = row.get("optimizer")
    return f"{variant}/{optimizer}" if optimizer not in (None, "") else variant


def verdicts(tables: Mapping[str, Table]) -> dict[str, dict[str, str]]:
    """The verdicts and rankings of one suite run (see the module docstring).

    Args:
        tables: Report tables by file name (``"pairwise.csv"``; a path ending in it, such as
            ``"report/pairwise.csv"``, is read by its name), each a list of rows (column ->
            value, as read from the CSV: strings). Other files are ignored.

    Returns:
        ``{"pairwise": {...}, "ranking": {...}, "best": {...}, "shown": {...}}``, each a
        mapping of a readable key to a string value.
    """
    by_name = {_name(k): v for k, v in tables.items() if _name(k).endswith(".csv")}
    out: dict[str, dict[str, str]] = {"pairwise": {}, "ranking": {}, "best": {}, "shown": {}}
    for row in by_name.get("pairwise.csv", []):
        key = f"{row.get('variant') or '-'} {row.get('metric')}: {row.get('a')} vs {row.get('b')}"
        out["pairwise"][key] = (
            f"significant={row.get('significant', '')} beyond_noise={row.get('beyond_noise', '')}"
        )
    summary = by_name.get("summary.csv", [])
    variants: dict[str, list[Mapping[str, Any]]] = {}
    for row in summary:
        variants.setdefault(str(row.get("variant") or "-"), []).append(row)
    for variant, rows in variants.items():
        if len({r.get("optimizer") for r in rows}) < 2:
            continue
        for metric in ("final_free_energy", "auc"):
            # NaN (no value) last; ties keep the table's order.
            ordered = sorted(rows, key=functools.partial(_sort_key, metric))
            out["ranking"][f"{variant} {metric}"] = " < ".join(str(r["optimizer"]) for r in ordered)
    for name, table in sorted(by_name.items()):
        for row in table:
            for column, value in row.items():
                if str(column).endswith("_best"):
                    out["best"][f"{name} {_group(row)} {column}"] = str(value)
    for row in by_name.get("tool-shapes.csv", []):
        out["shown"][f"tool-shapes.csv {row.get('variant') or '-'}"] = str(row.get("seed"))
    for row in by_name.get("mass-perturbation.csv", []):
        if str(row.get("shown")) == "True":
            out["shown"][f"mass-perturbation.csv {row.get('variant') or '-'}"] = str(
                row.get("seed")
            )
    return out


def compare_verdicts(
    before: Mapping[str, Mapping[str, str]], after: Mapping[str, Mapping[str, str]]
) -> list[str]:
    """The differences between two runs' :func:`verdicts`, one line each; empty if none."""
    lines = []
    for kind in sorted(set(before) | set(after)):
        old, new = before.get(kind, {}), after.get(kind, {})
        for key in sorted(set(old) | set(new)):
            if old.get(key) != new.get(key):
                lines.append(
                    f"{kind} {key}: {old.get(key, '(absent)')} -> {new.get(key, '(absent)')}"
                )
    return lines


def read_report_tables(folder: str | os.PathLike[str]) -> dict[str, list[dict[str, str]]]:
    """The report tables (``report/*.csv``) of a suite run folder, as rows of strings.

    Read through the run folder's gate: regular files inside the folder only (a link, a FIFO
    or a linked ``report/`` is refused or left out, never followed or opened), and a table that
    differs from the checksum the manifest records for it, or that it does not record, is left
    out with a warning (:func:`benchmarks.storage.runfolder.read_report_file`).

    Raises:
        FileNotFoundError: If the folder has no ``report/`` tables (run ``tooldesign report``).
        benchmarks.storage.UnsafeRunFileError: If ``report/`` is a link.
    """
    import warnings

    import pandas as pd

    from benchmarks.storage import list_run_files
    from benchmarks.storage.runfolder import read_report_file

    root = Path(folder)
    listed, left_out = list_run_files(root, under="report", skip_dir=lambda name: True)
    for relative, kind in left_out.items():
        if relative.endswith(".csv"):
            warnings.warn(
                f"{root / relative} is left out: it is {kind}, not a regular file",
                RuntimeWarning,
                stacklevel=2,
            )
    tables = [relative for relative in listed if relative.endswith(".csv")]
    if not tables:
        raise FileNotFoundError(
            f"{folder} has no report tables (report/*.csv): is it a suite run folder? Its "
            "report is written by `tooldesign report`"
        )
    out = {}
    for relative in tables:
        data = read_report_file(root, relative)
        if data is None:
            continue  # left out, and warned about
        frame = pd.read_csv(io.BytesIO(data), keep_default_na=False, dtype=str)
        out[_name(relative)] = [dict(row) for row in frame.to_dict("records")]
    return out
