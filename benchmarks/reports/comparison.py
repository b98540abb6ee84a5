"""Figures and tables made from the stored results of a run folder alone.

:func:`make_report` reads the evaluation log of a run folder (see :mod:`benchmarks.storage`)
and writes, under ``run_folder/report/``:

- ``convergence-<suite>[-<variant>].png``: mean best-so-far F per iteration per optimizer with
  a shaded 95% interval of the mean across seeds (the paper's optimizer comparison);
- ``summary.csv`` / ``summary.md``: final F and normalised AUC per optimizer with intervals;
- ``pairwise.csv`` / ``pairwise.md``: pairwise Mann-Whitney U tests, Holm-corrected, with A12.

The same data give the same CSV and Markdown bytes (and, with the same matplotlib, the same PNG
bytes: no timestamps or software tags are written). Every file is written atomically.

Plots draw on a ``matplotlib.figure.Figure`` rendered by the Agg canvas, never through
``pyplot``, so no global backend is switched and no window opens. The plotting functions take
an ``ax`` so that other suites can compose them into their own figures.
"""

from __future__ import annotations

import io
import math
import numbers
import os
import re
import zlib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from benchmarks.reports.markdown import markdown_table as _markdown
from benchmarks.reports.stats import (
    INTERVAL_NAMES,
    best_so_far_curves,
    check_interval,
    mann_whitney_holm,
    mean_interval,
    run_metrics,
)
from benchmarks.reports.success import (
    SuccessRate,
    has_standing,
    run_successes,
    scene_of_manifest,
    success_cell,
    success_criterion,
    success_rate,
    success_sentence,
    task_of_manifest,
    task_tolerance,
)
from benchmarks.storage import ResultStore, atomic_write_bytes, atomic_write_text
from benchmarks.storage.table import csv_text

if TYPE_CHECKING:
    from tooldesign_env.specs import SceneSpec
    from tooldesign_env.tasks import TaskDefinition

__all__ = [
    "DPI",
    "FIGSIZE",
    "MIN_INTERVAL_VALUES",
    "beyond_noise_cell",
    "check_noise_floor",
    "convergence_table",
    "figure_png_bytes",
    "interval_bounds",
    "make_report",
    "new_figure",
    "no_interval_note",
    "optimizer_colors",
    "pairwise_table",
    "percent_cell",
    "plot_convergence",
    "summary_table",
    "with_notice",
]

FIGSIZE: tuple[float, float] = (6.4, 4.0)
"""Figure size in inches of every report figure."""

DPI = 150
"""Resolution of every report PNG in dots per inch."""

REPORT_DIR = "report"
GROUP_KEYS: tuple[str, ...] = ("suite", "variant")
"""A report has one figure and one block of tables per (suite, variant)."""

# The paper draws CMA-ES in blue; fixed colours keep an optimizer recognisable across figures.
_KNOWN_COLORS: dict[str, str] = {
    "cmaes": "tab:blue",
    "bo": "tab:orange",
    "pso": "tab:green",
    "random": "tab:red",
    "random_search": "tab:red",
}
_SPARE_COLORS: tuple[str, ...] = (
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:gray",
    "tab:olive",
    "tab:cyan",
)
_KNOWN_ORDER: tuple[str, ...] = tuple(_KNOWN_COLORS)
_METRICS: tuple[str, ...] = ("final_free_energy", "auc")


# --- ordering, colours, seeds ------------------------------------------------------------------


def _optimizer_order(names: Iterable[str]) -> list[str]:
    unique = set(names)
    known = [n for n in _KNOWN_ORDER if n in unique]
    return known + sorted(unique - set(known))


def optimizer_colors(names: Iterable[str]) -> dict[str, str]:
    """Fixed colours: the paper's optimizers get theirs, others the spare colours by name.

    Args:
        names: Optimizer names.

    Returns:
        Name to matplotlib colour, in report order (known optimizers first, then by name).
    """
    colors, spare = {}, 0
    for name in _optimizer_order(names):
        if name in _KNOWN_COLORS:
            colors[name] = _KNOWN_COLORS[name]
        else:
            colors[name] = _SPARE_COLORS[spare % len(_SPARE_COLORS)]
            spare += 1
    return colors


def _rng(seed: int, *labels: Any) -> np.random.Generator:
    # One stream per table cell keyed by its labels (crc32 is stable across processes, unlike
    # hash()), so adding an optimizer does not change the intervals of the others.
    key = zlib.crc32("\x1f".join(map(str, labels)).encode("utf-8"))
    return np.random.default_rng([seed, key])


def _groups(frame: pd.DataFrame) -> list[tuple[tuple[Any, ...], pd.DataFrame]]:
    keys = [k for k in GROUP_KEYS if k in frame.columns]
    if not keys:
        return [((), frame)]
    return [
        (key if isinstance(key, tuple) else (key,), part)
        for key, part in frame.groupby(keys, sort=True)
    ]


# --- tables ------------------------------------------------------------------------------------


def convergence_table(
    evaluations: pd.DataFrame,
    *,
    level: float = 0.95,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
) -> pd.DataFrame:
    """Mean best-so-far F across seeds per iteration per optimizer, with its interval.

    Args:
        evaluations: The evaluation log (see ``docs/results-format.md``).
        level: Coverage of the interval.
        n_boot: Bootstrap resamples per cell (``interval="bootstrap"``).
        seed: Root seed of the bootstrap (``interval="bootstrap"``).
        interval: The interval of a mean, one of :data:`~benchmarks.reports.stats.INTERVALS`.

    Returns:
        One row per (suite, variant, optimizer, iteration) with ``evaluations`` (mean over
        seeds of evaluations so far), ``n_seeds`` (seeds with a finite best F there), ``mean``,
        ``low`` and ``high`` (F).
    """
    curves = best_so_far_curves(evaluations)
    keys = [k for k in (*GROUP_KEYS, "optimizer") if k in curves.columns]
    rows = []
    for key, cell in curves.groupby(keys + ["iteration"], sort=True):
        ci = mean_interval(
            cell["best_so_far"],
            interval=interval,
            level=level,
            n_boot=n_boot,
            rng=_rng(seed, "convergence", *key),
        )
        rows.append(
            {
                **dict(zip([*keys, "iteration"], key, strict=True)),
                "evaluations": float(cell["evaluations"].mean()),
                "n_seeds": ci.n,
                "mean": ci.estimate,
                "low": ci.low,
                "high": ci.high,
            }
        )
    columns = [*keys, "iteration", "evaluations", "n_seeds", "mean", "low", "high"]
    return pd.DataFrame(rows, columns=columns)


def summary_table(
    evaluations: pd.DataFrame,
    *,
    level: float = 0.95,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
    tolerance: float | TaskDefinition | None = None,
    scene: SceneSpec | None = None,
) -> pd.DataFrame:
    """Final best F, normalised AUC and success rate per optimizer over its runs (seeds).

    Args:
        evaluations: The evaluation log.
        level: Coverage of the intervals.
        n_boot: Bootstrap resamples per interval (``interval="bootstrap"``).
        seed: Root seed of the bootstrap (``interval="bootstrap"``).
        interval: The interval of a mean, one of :data:`~benchmarks.reports.stats.INTERVALS`.
        tolerance: What success is judged by: the runs' task (its whole test where the log
            stores ``final_height`` and ``final_tilt``, its radius alone where not), a bare
            radius in m, or None for the push task.
        scene: The runs' scene (the task's with the run's ``scene`` overrides,
            :func:`~benchmarks.reports.success.scene_of_manifest`); None is the task's own.

    Returns:
        One row per (suite, variant, optimizer) in report order with ``runs``,
        ``iterations_min``/``iterations_max`` (stored iterations per run), and for ``m`` in
        ``final_free_energy``, ``auc``: ``m`` (mean), ``m_low``, ``m_high`` and ``m_excluded``
        (runs without a finite value); then ``successes`` (runs whose final design succeeded,
        :func:`~benchmarks.reports.success.run_successes`), ``success_runs`` (runs whose
        outcome is known), ``success_rate`` and its Wilson interval ``success_low``,
        ``success_high`` (NaN when no run's outcome is known).
    """
    criterion = success_criterion() if tolerance is None else tolerance
    outcomes = run_successes(evaluations, criterion, scene=scene)
    metrics = run_metrics(best_so_far_curves(evaluations))
    group_names = [k for k in GROUP_KEYS if k in metrics.columns]
    rows = []
    for group_key, group in _groups(metrics):
        group_cols = dict(zip(group_names, group_key, strict=True))
        for name in _optimizer_order(group["optimizer"]):
            runs = group[group["optimizer"] == name]
            row: dict[str, Any] = {**group_cols, "optimizer": name, "runs": len(runs)}
            row["iterations_min"] = int(runs["iterations"].min())
            row["iterations_max"] = int(runs["iterations"].max())
            for metric in _METRICS:
                ci = mean_interval(
                    runs[metric],
                    interval=interval,
                    level=level,
                    n_boot=n_boot,
                    rng=_rng(seed, "summary", *group_key, name, metric),
                )
                row.update(
                    {
                        metric: ci.estimate,
                        f"{metric}_low": ci.low,
                        f"{metric}_high": ci.high,
                        f"{metric}_excluded": ci.n_excluded,
                    }
                )
            mine = outcomes[outcomes["optimizer"] == name]
            for column, value in zip(group_names, group_key, strict=True):
                mine = mine[mine[column] == value]
            rate = success_rate(mine["success"], level)
            row.update(
                {
                    "successes": rate.successes,
                    "success_runs": rate.n,
                    "success_rate": rate.rate,
                    "success_low": rate.low,
                    "success_high": rate.high,
                }
            )
            rows.append(row)
    return pd.DataFrame(rows)


def check_noise_floor(
    noise_floor: float | Mapping[str, float] | None,
) -> float | Mapping[str, float] | None:
    """``noise_floor`` checked: None, a number or a number per variant, each finite and >= 0.

    NaN means "not measured" (what :func:`benchmarks.reports.retest.noise_floor` gives when no
    design was retested), as does a variant missing from a mapping.

    Raises:
        ValueError: If a floor is negative, infinite or not a number; the message names the
            variant.
    """

    def check(value: Any, label: str) -> None:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ValueError(
                f"{label} must be a finite number >= 0 (NaN: not measured), got {value!r}"
            )
        number = float(value)
        if math.isnan(number):
            return
        if not (math.isfinite(number) and number >= 0):
            raise ValueError(
                f"{label} must be a finite number >= 0 (NaN: not measured), got {value!r}"
            )

    if noise_floor is None:
        return None
    if isinstance(noise_floor, Mapping):
        for variant, value in noise_floor.items():
            check(value, f"noise_floor of variant {str(variant)!r}")
        return noise_floor
    if isinstance(noise_floor, numbers.Real) and not isinstance(noise_floor, bool):
        check(noise_floor, "noise_floor")
        return noise_floor
    raise ValueError(f"noise_floor must be a number, one per variant or None, got {noise_floor!r}")


def _floor_of(noise_floor: float | Mapping[str, float] | None, variant: Any) -> float | None:
    """The noise floor of F for one variant; None if it was not measured (missing or NaN)."""
    if noise_floor is None:
        return None
    value = (
        noise_floor.get(str(variant)) if isinstance(noise_floor, Mapping) else float(noise_floor)
    )
    return None if value is None or math.isnan(value) else float(value)


def pairwise_table(
    evaluations: pd.DataFrame,
    *,
    alpha: float = 0.05,
    noise_floor: float | Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """Pairwise two-sided Mann-Whitney U tests of optimizers on final F and on AUC.

    Each (suite, variant, metric) is one Holm family. ``a12 < 0.5`` means optimizer ``a``
    reached lower (better) values than ``b``.

    Args:
        evaluations: The evaluation log.
        alpha: Family-wise error rate.
        noise_floor: The noise floor of F (``tooldesign retest``): one number, or one per
            variant name; None if unmeasured. A pair whose difference of means is below it is
            not ``significant``, whatever its p. A variant missing from the mapping, or whose
            floor is NaN, has no floor measured: its pairs' ``beyond_noise`` is missing (NA)
            and their significance rests on the tests alone (the markdown says "no floor").

    Returns:
        ``suite``, ``variant``, ``metric``, the columns of
        :func:`benchmarks.reports.stats.mann_whitney_holm`, ``mean_difference`` (mean of ``a`` minus
        mean of ``b`` over their finite values, as the tests take them; units of F) and
        ``beyond_noise`` (|mean_difference| > noise floor, a nullable boolean: NA when no floor
        was measured for the pair's variant), one row per pair.

    Raises:
        ValueError: If a noise floor is negative or infinite (:func:`check_noise_floor`).
    """
    noise_floor = check_noise_floor(noise_floor)
    metrics = run_metrics(best_so_far_curves(evaluations))
    group_names = [k for k in GROUP_KEYS if k in metrics.columns]
    tables = []
    for group_key, group in _groups(metrics):
        for metric in _METRICS:
            samples = {
                name: group.loc[group["optimizer"] == name, metric].to_numpy()
                for name in _optimizer_order(group["optimizer"])
            }
            table = mann_whitney_holm(samples, alpha=alpha)
            # Over the finite values, as the tests (a run with no valid design has no AUC).
            difference = [
                _finite_mean(samples[a]) - _finite_mean(samples[b])
                for a, b in zip(table["a"], table["b"], strict=True)
            ]
            group_values = dict(zip(group_names, group_key, strict=True))
            floor = _floor_of(noise_floor, group_values.get("variant", ""))
            table["mean_difference"] = difference
            table["beyond_noise"] = pd.array(
                [None if floor is None else abs(d) > floor for d in difference], dtype="boolean"
            )
            # No floor measured: significance rests on the tests alone, and the table says so.
            table["significant"] = table["significant"] & table["beyond_noise"].fillna(True)
            table.insert(0, "metric", metric)
            for position, (name, value) in enumerate(zip(group_names, group_key, strict=True)):
                table.insert(position, name, value)
            tables.append(table)
    return pd.concat(tables, ignore_index=True)


def _finite_mean(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.mean(finite)) if finite.size else math.nan


# --- figures -----------------------------------------------------------------------------------


def new_figure(figsize: tuple[float, float] = FIGSIZE) -> tuple[Figure, Axes]:
    """A figure with one axes on the Agg canvas, outside pyplot's global state.

    Args:
        figsize: (width, height) in inches.

    Returns:
        ``(figure, axes)``.
    """
    figure = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    FigureCanvasAgg(figure)
    return figure, figure.add_subplot()


def figure_png_bytes(figure: Figure) -> bytes:
    """Render a figure as PNG bytes at :data:`DPI` with no software tag or timestamp."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI, metadata={"Software": None})
    return buffer.getvalue()


def plot_convergence(
    evaluations: pd.DataFrame,
    ax: Axes | None = None,
    *,
    x: str = "iteration",
    level: float = 0.95,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
    title: str | None = None,
    noise_floor: float | None = None,
) -> Axes:
    """Plot mean best-so-far F per optimizer with its shaded interval across seeds.

    Args:
        evaluations: The evaluation log of one (suite, variant).
        ax: Axes to draw on; a new :func:`new_figure` if ``None``.
        x: ``"iteration"`` or ``"evaluations"`` (mean evaluations so far across seeds).
        level: Coverage of the shaded interval of the mean.
        n_boot: Bootstrap resamples per point (``interval="bootstrap"``).
        seed: Root seed of the bootstrap (``interval="bootstrap"``).
        interval: The interval of a mean, one of :data:`~benchmarks.reports.stats.INTERVALS`.
        title: Axes title; the suite (and variant) if ``None``.
        noise_floor: If given, a grey band of that height above the lowest final mean: final
            values inside it cannot be told apart from the best.

    Returns:
        The axes drawn on.

    Raises:
        ValueError: If ``x`` is unknown or the rows span several (suite, variant) pairs.
    """
    if x not in ("iteration", "evaluations"):
        raise ValueError(f"x must be 'iteration' or 'evaluations', got {x!r}")
    groups = _groups(evaluations)
    if len(groups) != 1:
        labels = [" / ".join(map(str, key)) for key, _ in groups]
        raise ValueError(
            f"plot_convergence draws one (suite, variant); the rows hold {len(groups)}: "
            f"{labels}; select one first"
        )
    table = convergence_table(evaluations, level=level, n_boot=n_boot, seed=seed, interval=interval)
    if ax is None:
        _, ax = new_figure()
    colors = optimizer_colors(table["optimizer"])
    for name, color in colors.items():
        line = table[table["optimizer"] == name]
        runs = int(line["n_seeds"].max())
        ax.plot(line[x], line["mean"], color=color, linewidth=1.8, label=f"{name} (n={runs})")
        ax.fill_between(line[x], line["low"], line["high"], color=color, alpha=0.2, linewidth=0)
    if noise_floor is not None and math.isfinite(noise_floor) and len(table):
        last = table[table["iteration"] == table["iteration"].max()]
        best = float(last["mean"].min())
        ax.axhspan(
            best,
            best + noise_floor,
            color="0.5",
            alpha=0.25,
            linewidth=0,
            label=f"noise floor of F ({noise_floor:.3g})",
        )
    if title is None:
        title = " / ".join(str(k) for k in groups[0][0] if k != "")
    ax.set_title(title)
    ax.set_xlabel("iteration" if x == "iteration" else "evaluations")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("best free energy F so far")
    ax.grid(True, alpha=0.3)
    kind = "t" if interval == "t" else "bootstrap"
    ax.legend(frameon=False, title=f"mean, {level:.0%} {kind} CI")
    return ax


# --- files -------------------------------------------------------------------------------------


def _fmt(value: float, digits: int = 4) -> str:
    return "n/a" if value is None or not np.isfinite(value) else f"{value:.{digits}g}"


MIN_INTERVAL_VALUES = 2
"""Fewest values a Markdown table shows an interval of: one value's interval is a point."""


def no_interval_note(what: str = "values") -> str:
    """The note under a Markdown table that shows an interval as n/a.

    Args:
        what: What the interval is over, plural: ``"runs"``, ``"designs"``, ``"tasks"``.
    """
    return (
        f"An interval of n/a has fewer than {MIN_INTERVAL_VALUES} {what} with a value behind "
        "it: a single value has no spread to resample, and the CSV's bounds for it are that "
        "value itself, not an interval."
    )


def interval_bounds(low: float, high: float, n: int, fmt: Any = None) -> str:
    """An interval as a table cell: ``[low, high]``, or ``[n/a]`` from < 2 values.

    Args:
        low: Lower bound.
        high: Upper bound.
        n: Number of finite values the interval was resampled from.
        fmt: Formats one bound; the report's own number format by default.

    Returns:
        The cell text; ``[n/a]`` when ``n`` < :data:`MIN_INTERVAL_VALUES` (the percentile
        interval of one value is that value twice, which reads as certainty).
    """
    fmt = _fmt if fmt is None else fmt
    return f"[{fmt(low)}, {fmt(high)}]" if n >= MIN_INTERVAL_VALUES else "[n/a]"


def percent_cell(fraction: float, digits: int = 2) -> str:
    """A fraction as a percentage cell, ``"1.23 %"``; ``"n/a"`` if it is NaN or infinite.

    A relative noise is NaN when its base is 0 (every goal-error term is 0 at p^X = 0) or was
    not measured; it must not print as ``nan %``.
    """
    value = float(fraction)
    return f"{100 * value:.{digits}f} %" if math.isfinite(value) else "n/a"


def _interval(row: pd.Series, metric: str) -> str:
    excluded = int(row[f"{metric}_excluded"])
    n = int(row["runs"]) - excluded
    text = f"{_fmt(row[metric])} {interval_bounds(row[f'{metric}_low'], row[f'{metric}_high'], n)}"
    return text + (f" ({excluded} run(s) without a value)" if excluded else "")


def _short_of_values(summary: pd.DataFrame) -> bool:
    """Whether a cell of the summary has fewer values than an interval needs."""
    if summary.empty:
        return False
    return any(
        ((summary["runs"] - summary[f"{metric}_excluded"]) < MIN_INTERVAL_VALUES).any()
        for metric in _METRICS
    )


def _heading(frame: pd.DataFrame) -> str:
    parts = [str(frame[k].iloc[0]) for k in GROUP_KEYS if k in frame.columns]
    return " / ".join(p for p in parts if p) or "results"


def _success_of_row(row: pd.Series, level: float) -> str:
    n = int(row["success_runs"])
    rate = SuccessRate(
        successes=int(row["successes"]),
        n=n,
        unknown=int(row["runs"]) - n,
        rate=float(row["success_rate"]),
        low=float(row["success_low"]),
        high=float(row["success_high"]),
        level=level,
    )
    return success_cell(rate)


def _summary_markdown(
    summary: pd.DataFrame,
    level: float,
    interval: str = "t",
    *,
    task: str = "push",
    tolerance: float | None = None,
    standing: bool = False,
) -> str:
    tolerance = task_tolerance(task) if tolerance is None else tolerance
    lines = [
        "# Optimizer comparison",
        "",
        f"Mean over runs (seeds) with a {level:.0%} {INTERVAL_NAMES[interval]} of the mean.",
        "Final F: best finite free energy after the last stored iteration of a run.",
        "AUC: mean height of the best-so-far curve over iterations (trapezoid, divided by the",
        "number of iteration steps), in units of F; lower means F dropped sooner.",
        success_sentence(task, tolerance, level=level, standing=standing)
        + " A run's final design is the one its final F is of.",
    ]
    for _, group in _groups(summary):
        lines += ["", f"## {_heading(group)}", ""]
        rows = [
            [
                row["optimizer"],
                str(row["runs"]),
                str(row["iterations_max"])
                if row["iterations_min"] == row["iterations_max"]
                else f"{row['iterations_min']}-{row['iterations_max']}",
                _interval(row, "final_free_energy"),
                _success_of_row(row, level),
                _interval(row, "auc"),
            ]
            for _, row in group.iterrows()
        ]
        header = ["optimizer", "runs", "iterations", "final F", "success", "AUC"]
        lines += _markdown(header, rows)
    if _short_of_values(summary):
        lines += ["", no_interval_note("runs")]
    return "\n".join(lines) + "\n"


def _pairwise_markdown(
    pairwise: pd.DataFrame, alpha: float, noise_floor: float | Mapping[str, float] | None
) -> str:
    unmeasured = (
        sorted({str(v) for v in pairwise.loc[pairwise["beyond_noise"].isna(), "variant"]})
        if "variant" in pairwise.columns and len(pairwise)
        else []
    )
    if noise_floor is None or (
        not isinstance(noise_floor, Mapping) and math.isnan(float(noise_floor))
    ):
        floor = (
            "No noise floor was measured (`tooldesign retest` measures it for a suite run "
            "folder): significance rests on the tests alone, and every pair says 'no floor'."
        )
    else:
        if isinstance(noise_floor, Mapping):
            floors = {**dict.fromkeys(unmeasured, math.nan), **noise_floor}
            values = ", ".join(
                f"{k or 'all'}: {'not measured' if math.isnan(v) else _fmt(v)}"
                for k, v in sorted(floors.items())
            )
        else:
            values = _fmt(float(noise_floor))
        floor = (
            f"Noise floor of F: {values} (median range of a final design's F over nudged "
            "scenes, `noise.md`); a pair whose means differ by less is not significant, "
            "whatever its p."
        )
        if unmeasured:
            floor += (
                f" No noise floor was measured for {', '.join(v or 'all' for v in unmeasured)}:"
                " its pairs say 'no floor', and their significance rests on the tests alone."
            )
    lines = [
        "# Pairwise tests",
        "",
        "Two-sided Mann-Whitney U tests over runs, Holm-Bonferroni corrected within each",
        f"table; significant at alpha = {alpha:g}. A12 is the probability that a run of `a`",
        "ends higher than a run of `b`: A12 < 0.5 means `a` is better (lower F).",
        floor,
    ]
    if pairwise.empty:
        return "\n".join(lines + ["", "Fewer than two optimizers: nothing to compare."]) + "\n"
    keys = [k for k in GROUP_KEYS if k in pairwise.columns]
    for key, table in pairwise.groupby(keys + ["metric"], sort=False):
        metric = key[-1] if isinstance(key, tuple) else key
        lines += ["", f"## {_heading(table)}: {metric}", ""]
        rows = [
            [
                row["a"],
                row["b"],
                _fmt(row["U"]),
                _fmt(row["p"], 3),
                _fmt(row["p_holm"], 3),
                _fmt(row["a12"], 3),
                _fmt(row["mean_difference"]),
                beyond_noise_cell(row["beyond_noise"]),
                "yes" if row["significant"] else "no",
                row["note"],
            ]
            for _, row in table.iterrows()
        ]
        header = ["a", "b", "U", "p", "p (Holm)", "A12", "mean a - b", "beyond noise"]
        lines += _markdown([*header, "significant", "note"], rows)
    return "\n".join(lines) + "\n"


def beyond_noise_cell(value: Any) -> str:
    """A ``beyond_noise`` value as a table cell: "yes", "no", or "no floor" when NA or NaN."""
    if value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value)):
        return "no floor"
    if isinstance(value, str):  # read back from a CSV written by an older version
        return {"true": "yes", "false": "no"}.get(value.lower(), "no floor")
    return "yes" if value else "no"


def _slug(*names: str) -> str:
    text = "-".join(n for n in names if n)
    slug = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "results"
    # Two names that clean to the same slug must not overwrite each other's figure.
    return slug if slug == text else f"{slug}-{zlib.crc32(text.encode('utf-8')):08x}"


def with_notice(markdown: str, notice: str | None) -> str:
    """A Markdown page led by the notice of an incomplete run (as a quote), if there is one."""
    return markdown if notice is None else f"> **Incomplete run.** {notice}\n\n{markdown}"


def make_report(
    run_folder: str | os.PathLike[str],
    *,
    out_dir: str | os.PathLike[str] | None = None,
    level: float = 0.95,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
    alpha: float = 0.05,
    noise_floor: float | Mapping[str, float] | None = None,
    notice: str | None = None,
    task: str | None = None,
) -> list[Path]:
    """Rebuild the figures and tables of a run folder from its stored results alone.

    Args:
        run_folder: A run folder written by :class:`benchmarks.storage.ResultStore`.
        out_dir: Where to write; ``run_folder/report`` if ``None``.
        level: Coverage of the intervals.
        n_boot: Bootstrap resamples per interval (``interval="bootstrap"``).
        seed: Root seed of the bootstrap; the same seed and data give the same bytes.
        interval: The interval of a mean: ``"t"`` (Student t, the default) or ``"bootstrap"``
            (percentile bootstrap, which covers less than ``level`` with few seeds).
        alpha: Family-wise error rate of the pairwise tests.
        noise_floor: The noise floor of F, one number or one per variant (see
            :func:`pairwise_table`), drawn as a band on the convergence figures; None if it was
            not measured.
        notice: What is missing from an incomplete run; it leads every ``.md`` page, as a
            quote (see :func:`with_notice`). None for a complete run.
        task: The registered task the runs were scored on, whose tolerance says which final
            designs succeeded; None reads it from the folder's manifest (push without one).

    Returns:
        The files written: one ``convergence-*.png`` per (suite, variant), then
        ``summary.csv``, ``summary.md``, ``pairwise.csv`` and ``pairwise.md``.

    Raises:
        FileNotFoundError: If ``run_folder`` does not exist.
        NotADirectoryError: If it is a file.
        benchmarks.storage.EmptyStoreError: If it holds no results.
        TypeError, ValueError: If a stored file breaks the results format (the message names
            the file and column) or an argument is out of range.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    noise_floor = check_noise_floor(noise_floor)
    interval = check_interval(interval)
    evaluations = ResultStore(run_folder).read()
    target = Path(run_folder) / REPORT_DIR if out_dir is None else Path(out_dir)
    written = []
    for key, group in _groups(evaluations):
        figure, ax = new_figure()
        variant = group["variant"].iloc[0] if "variant" in group.columns else ""
        floor = _floor_of(noise_floor, variant)
        plot_convergence(
            group,
            ax,
            level=level,
            n_boot=n_boot,
            seed=seed,
            interval=interval,
            noise_floor=floor,
        )
        png = target / f"convergence-{_slug(*map(str, key))}.png"
        written.append(atomic_write_bytes(png, figure_png_bytes(figure)))

    manifest = _manifest_or_none(run_folder)
    if task is None:
        task = task_of_manifest(manifest)
    # The run's own scene (a suite's scene overrides: a taller box rests higher), as its env's.
    scene = scene_of_manifest(manifest) if task_of_manifest(manifest) == task else None
    summary = summary_table(
        evaluations,
        level=level,
        n_boot=n_boot,
        seed=seed,
        interval=interval,
        tolerance=success_criterion(task),
        scene=scene,
    )
    markdown = _summary_markdown(
        summary,
        level,
        interval,
        task=task,
        tolerance=task_tolerance(task),
        standing=has_standing(evaluations),
    )
    written.append(atomic_write_text(target / "summary.csv", csv_text(summary)))
    written.append(atomic_write_text(target / "summary.md", with_notice(markdown, notice)))
    pairwise = pairwise_table(evaluations, alpha=alpha, noise_floor=noise_floor)
    written.append(atomic_write_text(target / "pairwise.csv", csv_text(pairwise)))
    written.append(
        atomic_write_text(
            target / "pairwise.md",
            with_notice(_pairwise_markdown(pairwise, alpha, noise_floor), notice),
        )
    )
    return written


def _manifest_or_none(run_folder: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The folder's manifest, or None for a bare store (no manifest, or none readable)."""
    from benchmarks.storage import read_manifest

    try:
        return read_manifest(run_folder)
    except (FileNotFoundError, ValueError):
        return None
