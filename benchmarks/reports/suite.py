"""The report of a suite run folder, rebuilt from its stored results alone.

:func:`make_suite_report` writes, under ``run_folder/report/``:

- what :func:`benchmarks.reports.comparison.make_report` writes for every run folder: a
  convergence figure
  per (suite, variant), ``summary.csv/md`` (final F and AUC per optimizer with 95% intervals
  of the mean, Student t by default) and ``pairwise.csv/md`` (Mann-Whitney U, Holm, A12);
- ``designs.csv`` / ``designs.md``: one row per run: its design, F and its terms, whether it
  succeeded (:mod:`benchmarks.reports.success`), the shape of the tool (straightness, turning
  angle, tip offset) and its final test;
- the figures the suite asks for (``SuiteConfig.figures``):

  - ``tool-shapes``: ``tool-shapes.png`` (per variant, the lowest-F design's tool above its box
    path, side by side), ``tool-shapes-overlay.png``, ``tool-shapes.csv/md``;
  - ``robustness-table``: ``table1.csv/md``, the paper's Table I: robustness, accuracy and
    control deviation per labelled variant, mean over tasks with a 95% interval, best
    in bold;
  - ``robustness-scatter``: ``robustness-scatter.png`` (robustness against squared goal error,
    one colour per p^X) and ``robustness-by-precision.csv/md`` (per p^X means with intervals and
    Spearman rank correlations with p^X);
  - ``mass-paths``: ``mass-perturbation-<variant>.png`` (the lowest-F design's tool and its box
    paths at the nominal and every altered mass) and ``mass-perturbation.csv/md``.

Nothing is simulated: the box paths and the robustness metrics were stored by the runner, the
tool shapes are pure geometry. The same stored results give the same CSV and Markdown bytes.
"""

from __future__ import annotations

import math
import os
import warnings
import zlib
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from matplotlib import colormaps

from benchmarks.reports import plots
from benchmarks.reports.comparison import (
    MIN_INTERVAL_VALUES,
    REPORT_DIR,
    interval_bounds,
    make_report,
    no_interval_note,
    with_notice,
)
from benchmarks.reports.markdown import markdown_table as _markdown
from benchmarks.reports.retest import make_retest_report, noise_floor
from benchmarks.reports.rl import make_rl_report
from benchmarks.reports.stats import INTERVAL_NAMES, Interval, check_interval, mean_interval
from benchmarks.reports.success import (
    design_succeeded,
    scene_of_config,
    scene_of_manifest,
    success_criterion,
    task_of_manifest,
    task_tolerance,
)
from benchmarks.rl.suite import RL_SUITE_KIND
from benchmarks.storage import (
    MANIFEST_NAME,
    ResultStore,
    atomic_write_text,
    check_write_folder,
    read_designs,
    read_manifest,
    read_retests,
)
from benchmarks.storage.runfolder import record_report_files
from benchmarks.storage.table import csv_text
from benchmarks.suites.config import SUITE_KIND, SuiteConfig, suite_of_manifest
from tooldesign_env.schema import GOAL_COLUMNS, METRICS, ROBUSTNESS_METRICS

if TYPE_CHECKING:
    from tooldesign_env.specs import SceneSpec
    from tooldesign_env.tasks import TaskDefinition

__all__ = [
    "designs_table",
    "make_suite_report",
    "robustness_by_precision",
    "table_one",
    "tool_shape",
]

LEVEL = 0.95
"""Coverage of every interval of the suite reports."""


# --- helpers -----------------------------------------------------------------------------------


def _rng(seed: int, *labels: Any) -> np.random.Generator:
    # One stream per table cell, keyed by its labels (crc32 is stable across processes).
    key = zlib.crc32("\x1f".join(map(str, labels)).encode("utf-8"))
    return np.random.default_rng([seed, key])


def _fmt(value: Any, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    value = float(value)
    # Table I's numbers run to 1e5: whole numbers read better than 6.569e+04.
    return f"{value:.0f}" if abs(value) >= 10 ** (digits - 1) else f"{value:.{digits}g}"


def _interval(mean: float, low: float, high: float, n: int) -> str:
    return f"{_fmt(mean)} {interval_bounds(low, high, n, _fmt)}"


def _interval_notes(table: pd.DataFrame, metrics: Iterable[str]) -> list[str]:
    """The note under a table of intervals over tasks when one of them is n/a.

    An interval is n/a when fewer than 2 of its tasks have a value (the ``m_n`` column), not
    when the row has fewer than 2 tasks: a task's metric can be missing.
    """
    if len(table) and any((table[f"{m}_n"] < MIN_INTERVAL_VALUES).any() for m in metrics):
        return ["", no_interval_note("tasks")]
    return []


def _write_table(
    target: Path, stem: str, frame: pd.DataFrame, markdown: str, notice: str | None = None
) -> list[Path]:
    return [
        atomic_write_text(target / f"{stem}.csv", csv_text(frame)),
        atomic_write_text(target / f"{stem}.md", with_notice(markdown, notice)),
    ]


def _variant_name(record: Mapping[str, Any]) -> str:
    label = record.get("label") or ""
    precision = f"p^X = {float(record['goal_precision']):g}"
    return f"{label} ({precision})" if label else precision


def _slug(name: str) -> str:
    cleaned = "".join(c if c.isalnum() or c in "._-" else "_" for c in name) or "default"
    return cleaned if cleaned == name else f"{cleaned}-{zlib.crc32(name.encode()):08x}"


# --- tool shape --------------------------------------------------------------------------------


def tool_shape(coeffs: Sequence[float]) -> dict[str, float]:
    """How bent a tool is, from its centreline (pure geometry, tool frame).

    Args:
        coeffs: The design ``(c1, ..., cn)``.

    Returns:
        ``straightness``: distance from the curve's start to its tip over the arc length L0
        (1 for a straight tool, smaller the more it bends); ``turning_angle``: total absolute
        turn of the centreline from the handle to the tip in degrees (a hook that wraps a box
        turns 90 degrees or more); ``tip_offset``: the tip's y in the tool frame in m (sideways
        reach; the sign says which side); ``min_radius_of_curvature`` in m (inf if straight).
    """
    from tooldesign_env import ToolSpec, make_tool

    values = np.asarray(coeffs, dtype=np.float64)
    spec = ToolSpec(degree=len(values)) if len(values) != ToolSpec().degree else ToolSpec()
    geometry = make_tool(values, spec)
    line = np.asarray(geometry.centerline)
    curve = line[1:]
    directions = np.diff(line, axis=0)
    headings = np.unwrap(np.arctan2(directions[:, 1], directions[:, 0]))
    return {
        "straightness": float(np.linalg.norm(curve[-1] - curve[0]) / spec.arc_length),
        "turning_angle": float(np.degrees(np.sum(np.abs(np.diff(headings))))),
        "tip_offset": float(curve[-1, 1]),
        "min_radius_of_curvature": float(geometry.min_radius_of_curvature),
    }


# --- the designs table -------------------------------------------------------------------------

_TEST_FIELDS = (
    "robustness",
    "accuracy",
    "control_deviation",
    "squared_goal_error",
    "nominal_final_distance",
)


def designs_table(
    designs: Sequence[Mapping[str, Any]],
    *,
    tolerance: float | TaskDefinition | None = None,
    scene: SceneSpec | None = None,
) -> pd.DataFrame:
    """One row per run: keys, task, design, F and its terms, success, tool shape, final test.

    Args:
        designs: Design records from :func:`benchmarks.suites.runner.read_designs`.
        tolerance: What success is judged by: the run's task (its whole test where a record
            stores the box's ``final_height`` and ``final_tilt``, its radius alone where not),
            a bare radius in m, or None for the push task.
        scene: The runs' scene (the task's with the suite's ``scene`` overrides,
            :func:`~benchmarks.reports.success.scene_of_manifest`); None is the task's own.

    Returns:
        The table, in the records' order; missing values are NaN. ``success`` is True when
        the design was usable and the task's test holds (within its radius, and standing
        where the height and tilt are stored; :func:`~benchmarks.reports.success.
        design_succeeded`), False when not, and None (an empty CSV cell) when no final
        distance was stored.

    Raises:
        TypeError: ``designs`` is not a sequence of mappings.
    """
    if isinstance(designs, (str, bytes, Mapping)) or not isinstance(designs, Sequence):
        raise TypeError(f"designs must be a sequence of design records, got {designs!r:.80}")
    if not all(isinstance(record, Mapping) for record in designs):
        raise TypeError("designs must be a sequence of design records (mappings)")
    criterion = success_criterion() if tolerance is None else tolerance
    rows = []
    for record in designs:
        row: dict[str, Any] = {
            k: record.get(k) for k in ("suite", "variant", "label", "optimizer", "seed")
        }
        row["task_index"] = record.get("task_index")
        for axis, value in zip(GOAL_COLUMNS, record["goal"], strict=True):
            row[axis] = float(value)
        row["goal_precision"] = float(record["goal_precision"])
        coeffs = record.get("coefficients") or []
        for i, value in enumerate(coeffs, start=1):
            row[f"c{i}"] = float(value)
        for name in METRICS:
            row[name] = _float(record.get(name))
        row["status"] = record.get("status") or "failed"
        row["success"] = design_succeeded(
            row["status"],
            row["final_distance"],
            criterion,
            record.get("final_height"),
            record.get("final_tilt"),
            scene=scene,
        )
        shape = tool_shape(coeffs) if coeffs else {}
        for name in ("straightness", "turning_angle", "tip_offset", "min_radius_of_curvature"):
            row[name] = _float(shape.get(name))
        test = record.get("test") or {}
        for name in _TEST_FIELDS:
            row[name] = _float(test.get(name))
        row["test_error"] = test.get("error", "")
        rows.append(row)
    return pd.DataFrame(rows)


def _float(value: Any) -> float:
    return math.nan if value is None else float(value)


def _success_word(value: Any) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    return "yes" if value else "no"


def _designs_markdown(table: pd.DataFrame, task: str = "push", *, standing: bool = False) -> str:
    tolerance = task_tolerance(task)
    if standing:  # the records store the box's final height and tilt
        said = [
            f"Success: the design was usable and left the box standing within {tolerance:g} m",
            f"of the goal (the {task} task's test: tolerance, resting height and tilt; the",
            "distance alone for a record stored without height and tilt); n/a where no final",
            "distance was stored. The success rate per optimizer, with its Wilson interval, is in",
            "`summary.md`.",
        ]
    else:  # folders stored before: the text their reports always had
        said = [
            f"Success: the design was usable and its final distance is within {tolerance:g} m (the",
            f"{task} task's tolerance); n/a where no final distance was stored. The success rate",
            "per optimizer, with its Wilson interval, is in `summary.md`.",
        ]
    lines = [
        "# Designs",
        "",
        "One row per run: the run's design is its lowest-F valid evaluation (status ok); a run",
        "without one shows its lowest-penalty invalid design (status invalid: F is the env's",
        "penalty, the design was not tested), or nothing when every evaluation failed (status",
        "failed). Straightness is the tip's distance from the curve start over the arc length",
        "(1 = straight); the turning angle is the centreline's total absolute turn in degrees.",
        "Robustness (m) is -sum_i sum_t |X(m_i, t) - X(m, t)| over the altered box masses; the",
        "squared goal error (m^2) is sum_t |X(m, t) - X^g|^2 at the nominal mass.",
        *said,
        "",
    ]
    # The status column is always there: a table of invalid designs alone must say so.
    header = ["variant", "optimizer", "seed", "status", "C", "F", "final dist. (m)", "success"]
    header += ["straightness"]
    header += ["turn (deg)", "robustness (m)", "sq. goal error (m^2)"]
    coefficient_columns = [c for c in table.columns if c.startswith("c") and c[1:].isdigit()]
    rows = []
    for _, row in table.iterrows():
        coeffs = ", ".join(_fmt(row[c], 3) for c in coefficient_columns)
        rows.append(
            [
                row["variant"] or "-",
                row["optimizer"],
                str(row["seed"]),
                row["status"],
                f"({coeffs})",
                _fmt(row["free_energy"]),
                _fmt(row["final_distance"], 3),
                _success_word(row["success"]),
                _fmt(row["straightness"], 3),
                _fmt(row["turning_angle"], 3),
                _fmt(row["robustness"]),
                _fmt(row["squared_goal_error"]),
            ]
        )
    return "\n".join(lines + _markdown(header, rows)) + "\n"


def _chosen(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    need: Callable[[Mapping[str, Any]], bool],
) -> list[tuple[Any, Mapping[str, Any]]]:
    """Per variant (in config order), its lowest-F record that ``need`` accepts."""
    chosen = []
    for variant in config.variants:
        candidates = [
            d
            for d in designs
            if d["variant"] == variant.name and d.get("status") == "ok" and need(d)
        ]
        if candidates:
            best = min(candidates, key=lambda d: (float(d["free_energy"]), d["seed"]))
            chosen.append((variant, best))
    return chosen


# --- tool shapes (precision sweep) -------------------------------------------------------------


def _has_nominal_path(record: Mapping[str, Any]) -> bool:
    return bool((record.get("paths") or {}).get("nominal"))


def _tool_shapes(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    target: Path,
    seed: int,
    interval: str,
    *,
    notice: str | None = None,
) -> list[Path]:
    from tooldesign_env import make_tool

    chosen = _chosen(designs, config, _has_nominal_path)
    if not chosen:
        return []
    colors = plots.sequential_colors(len(chosen))
    n = len(chosen)
    lines = [np.asarray(make_tool(r["coefficients"]).centerline) for _, r in chosen]
    paths = [np.asarray(r["paths"]["nominal"])[:, :2] for _, r in chosen]
    goals = [np.asarray(r["goal"])[:2][None, :] for _, r in chosen]
    tool_points, path_points = np.concatenate(lines), np.concatenate(paths + goals)
    # Panels keep one scale per row; the figure is as tall as the rows' data need.
    panel = 2.3
    height = sum(panel * _aspect(points) for points in (tool_points, path_points)) + 1.5
    figure, axes = plots.new_figure_grid(2, n, figsize=(2.7 * n, height))
    for column, ((_, record), color) in enumerate(zip(chosen, colors, strict=True)):
        title = f"{_variant_name(record)}\nF = {_fmt(record['free_energy'])}"
        # The markers are named once, in the first column's legends.
        key = column == 0
        plots.plot_tool_shapes(axes[0, column], [record["coefficients"]], colors=[color], key=key)
        axes[0, column].set_title(title, fontsize="small")
        path = np.asarray(record["paths"]["nominal"], dtype=np.float64)
        plots.plot_box_paths(axes[1, column], [path], record["goal"], colors=[color], key=key)
        final = np.linalg.norm(path[-1] - np.asarray(record["goal"])) if len(path) else math.nan
        axes[1, column].set_title(f"box ends {_fmt(final, 3)} m from goal", fontsize="small")
    # One scale for every tool and every path, so shapes compare at a glance.
    _share_limits(axes[0], tool_points)
    _share_limits(axes[1], path_points)
    written = [plots.save_png(figure, target / "tool-shapes.png")]

    figure, grid = plots.new_figure_grid(1, 2, figsize=(11.0, 4.5))
    left, right = grid[0]
    labels = [_variant_name(r) for _, r in chosen]
    plots.plot_tool_shapes(left, [r["coefficients"] for _, r in chosen], labels, colors=colors)
    left.set_title("tools (tool frame)")
    plots.plot_box_paths(
        right,
        [np.asarray(r["paths"]["nominal"]) for _, r in chosen],
        chosen[0][1]["goal"],
        labels,
        colors=colors,
    )
    right.set_title("box paths (top view)")
    written.append(plots.save_png(figure, target / "tool-shapes-overlay.png"))

    table = designs_table([r for _, r in chosen])
    table = table.drop(columns=list(ROBUSTNESS_METRICS), errors="ignore")
    everything = designs_table([d for d in designs if d.get("status") == "ok"])
    written += _write_table(
        target, "tool-shapes", table, _tool_shapes_markdown(table, everything, config), notice
    )
    return written


def _limits(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    low, high = points.min(axis=0), points.max(axis=0)
    margin = 0.08 * max(float(np.max(high - low)), 0.1)
    return low - margin, high + margin


def _aspect(points: np.ndarray) -> float:
    low, high = _limits(points)
    return float((high[1] - low[1]) / (high[0] - low[0]))


def _share_limits(axes: Iterable[Any], points: np.ndarray) -> None:
    low, high = _limits(points)
    margin = 0.0
    for ax in axes:
        # Equal axes by resizing the box, not the limits, so every panel keeps one scale.
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlim(low[0] - margin, high[0] + margin)
        ax.set_ylim(low[1] - margin, high[1] + margin)


def _tool_shapes_markdown(
    shown: pd.DataFrame, everything: pd.DataFrame, config: SuiteConfig
) -> str:
    lines = [
        "# Tool shapes by goal precision",
        "",
        "The design shown per p^X is the lowest-F design over its seeds. Straightness is the",
        "tip's distance from the curve start over L0 (1 = straight); the turning angle is the",
        "centreline's total absolute turn in degrees; the final distance is the box's distance",
        "from the goal at the end, in m.",
        "",
        "## Shown designs",
        "",
    ]
    header = ["p^X", "seed", "C", "F", "goal error", "confidence", "final dist. (m)"]
    header += ["straightness", "turn (deg)", "tip y (m)"]
    coefficient_columns = [c for c in shown.columns if c.startswith("c") and c[1:].isdigit()]
    rows = [
        [
            _fmt(row["goal_precision"]),
            str(row["seed"]),
            "(" + ", ".join(_fmt(row[c], 3) for c in coefficient_columns) + ")",
            _fmt(row["free_energy"]),
            _fmt(row["goal_error"]),
            _fmt(row["confidence"]),
            _fmt(row["final_distance"], 3),
            _fmt(row["straightness"], 3),
            _fmt(row["turning_angle"], 3),
            _fmt(row["tip_offset"], 3),
        ]
        for _, row in shown.iterrows()
    ]
    lines += _markdown(header, rows)
    lines += ["", "## Every seed: mean [min, max] per p^X", ""]
    header = ["p^X", "runs", "final dist. (m)", "straightness", "turn (deg)"]
    rows = []
    for variant in config.variants:
        part = everything[everything["variant"] == variant.name] if len(everything) else everything
        if not len(part):
            continue

        def span(column: str, part: pd.DataFrame = part) -> str:
            values = part[column].to_numpy(dtype=np.float64)
            return f"{_fmt(values.mean(), 3)} [{_fmt(values.min(), 3)}, {_fmt(values.max(), 3)}]"

        rows.append(
            [
                _fmt(part["goal_precision"].iloc[0]),
                str(len(part)),
                span("final_distance"),
                span("straightness"),
                span("turning_angle"),
            ]
        )
    lines += _markdown(header, rows)
    lines += [
        "",
        "Spearman rank correlation of p^X with each quantity over every seed's design (rho < 0:",
        "it falls as p^X grows):",
        "",
    ]
    rows = [
        [row["metric"], _fmt(row["rho"], 3), _fmt(row["p"], 3), str(row["n"])]
        for _, row in _spearman(everything, SHAPE_METRICS).iterrows()
    ]
    lines += _markdown(["quantity", "rho", "p", "designs"], rows)
    return "\n".join(lines) + "\n"


SHAPE_METRICS: tuple[str, ...] = ("turning_angle", "straightness", "tip_offset", "final_distance")
"""Quantities of the tool-shapes report correlated with p^X."""


def _spearman(table: pd.DataFrame, metrics: Sequence[str]) -> pd.DataFrame:
    """Spearman rho of p^X with each metric over the rows of ``table`` (NaN if undefined)."""
    from scipy import stats as sps

    rows = []
    for metric in metrics:
        part = table[np.isfinite(table[metric])] if len(table) else table
        if len(part) >= 3 and part["goal_precision"].nunique() > 1 and part[metric].nunique() > 1:
            result = sps.spearmanr(part["goal_precision"], part[metric])
            rho, p = float(result.statistic), float(result.pvalue)
        else:
            rho = p = math.nan
        rows.append({"metric": metric, "rho": rho, "p": p, "n": int(len(part))})
    return pd.DataFrame(rows, columns=["metric", "rho", "p", "n"])


# --- Table I and the robustness scatter --------------------------------------------------------

_TABLE_ONE = (
    ("robustness", "robustness (m) ↑", max),
    ("accuracy", "accuracy (m) ↑", max),
    ("control_deviation", "control deviation (N m) ↓", min),
)


def _ci_columns(metric: str, ci: Interval) -> dict[str, Any]:
    """A metric's mean, interval and count of finite values, as a table row's columns."""
    return {
        metric: ci.estimate,
        f"{metric}_low": ci.low,
        f"{metric}_high": ci.high,
        f"{metric}_n": ci.n,
    }


def _tested(designs: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    table = designs_table(designs)
    if not len(table):
        return table
    return table[np.isfinite(table["robustness"].to_numpy(dtype=np.float64))]


def table_one(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    *,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
) -> pd.DataFrame:
    """The paper's Table I: per labelled variant, the three metrics over tasks.

    Variants with a ``label`` (the paper's "pure confidence", "free energy", "pure
    performance") are the rows; if no variant has a label, every variant is a row.

    Args:
        designs: Design records with robustness tests.
        config: The suite (its variants give the rows and their order).
        n_boot: Bootstrap resamples per interval (``interval="bootstrap"``).
        seed: Root seed of the bootstrap (``interval="bootstrap"``).
        interval: The interval of a mean, one of :data:`~benchmarks.reports.stats.INTERVALS`.

    Returns:
        One row per variant (per variant and optimizer, with an ``optimizer`` column, when the
        suite has several optimizers: their designs are not pooled): ``variant``, ``label``,
        ``goal_precision``, ``tasks`` and, per metric m, ``m`` (mean over tasks), ``m_low``,
        ``m_high``, ``m_n`` (the tasks with a finite value, which the mean and interval are of)
        and ``m_best`` (whether the mean is the best of the table: highest robustness and
        accuracy, lowest control deviation).
    """
    tested = _tested(designs)
    variants = [v for v in config.variants if v.label] or list(config.variants)
    # One optimizer: its designs are the tasks'. Several: a row per optimizer, never pooled,
    # since their designs are not repeats of one another.
    optimizers = [o.column for o in config.optimizers] if len(config.optimizers) > 1 else [None]
    rows = []
    for variant in variants:
        for optimizer in optimizers:
            part = tested[tested["variant"] == variant.name] if len(tested) else tested
            if optimizer is not None and len(part):
                part = part[part["optimizer"] == optimizer]
            row: dict[str, Any] = {
                "variant": variant.name,
                "label": variant.label,
                **({} if optimizer is None else {"optimizer": optimizer}),
                "goal_precision": variant.goal_precision
                if variant.goal_precision is not None
                else config.goal_precision,
                "tasks": int(len(part)),
            }
            for metric, _, _ in _TABLE_ONE:
                values = part[metric].to_numpy(dtype=np.float64) if len(part) else np.array([])
                key = variant.name if optimizer is None else f"{variant.name}/{optimizer}"
                ci = mean_interval(
                    values,
                    interval=interval,
                    level=LEVEL,
                    n_boot=n_boot,
                    rng=_rng(seed, metric, key),
                )
                row.update(_ci_columns(metric, ci))
            rows.append(row)
    table = pd.DataFrame(rows)
    for metric, _, pick in _TABLE_ONE:
        finite = table[metric][np.isfinite(table[metric])]
        best = pick(finite) if len(finite) else math.nan
        table[f"{metric}_best"] = table[metric] == best
    return table


def _table_one_markdown(table: pd.DataFrame, interval: str = "t") -> str:
    lines = [
        "# Table I: robustness, accuracy and control deviation under box-mass changes",
        "",
        f"Mean over tasks (random goals) with a {LEVEL:.0%} {INTERVAL_NAMES[interval]} of the",
        "mean; the best mean of each column is in bold. Robustness = -sum_i sum_t",
        "|X(m_i, t) - X(m, t)| (m), accuracy = -sum_i sum_t |X(m_i, t) - X^g| (m), control",
        "deviation = sum_i sum_t |U(m_i, t) - U(m, t)| (N m), over the altered masses m_i and",
        "the control steps t.",
        "",
    ]
    split = "optimizer" in table.columns  # several optimizers: a row each, never pooled
    header = ["objective", *(["optimizer"] if split else []), "p^X", "tasks"]
    header += [title for _, title, _ in _TABLE_ONE]
    rows = []
    for _, row in table.iterrows():
        cells = [row["label"] or row["variant"], *([row["optimizer"]] if split else [])]
        cells += [_fmt(row["goal_precision"]), str(row["tasks"])]
        for metric, _, _ in _TABLE_ONE:
            mean = _fmt(row[metric])
            mean = f"**{mean}**" if row[f"{metric}_best"] else mean
            bounds = interval_bounds(
                row[f"{metric}_low"], row[f"{metric}_high"], int(row[f"{metric}_n"]), _fmt
            )
            cells.append(f"{mean} {bounds}")
        rows.append(cells)
    notes = _interval_notes(table, [metric for metric, _, _ in _TABLE_ONE])
    return "\n".join(lines + _markdown(header, rows) + notes) + "\n"


_BY_PRECISION = ("robustness", "squared_goal_error", "nominal_final_distance")


def robustness_by_precision(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    *,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per p^X: robustness and goal error over tasks; and their rank correlations with p^X.

    Args:
        designs: Design records with robustness tests.
        config: The suite (its variants give the rows).
        n_boot: Bootstrap resamples per interval (``interval="bootstrap"``).
        seed: Root seed of the bootstrap (``interval="bootstrap"``).
        interval: The interval of a mean, one of :data:`~benchmarks.reports.stats.INTERVALS`.

    Returns:
        ``(per_precision, correlations)``: one row per variant (per variant and optimizer, with
        an ``optimizer`` column, when the suite has several) with ``tasks`` and, for
        ``robustness``, ``squared_goal_error``, ``nominal_final_distance``, the mean, ``_low``,
        ``_high`` and ``_n`` (the tasks with a finite value); and one row per metric with the
        Spearman ``rho`` between p^X and the metric over all tested designs, its two-sided
        ``p`` and ``n``.
    """
    tested = _tested(designs)
    metrics = _BY_PRECISION
    # As in Table I: several optimizers' designs are not repeats of one task, never pooled.
    optimizers = [o.column for o in config.optimizers] if len(config.optimizers) > 1 else [None]
    rows = []
    for variant in config.variants:
        for optimizer in optimizers:
            part = tested[tested["variant"] == variant.name] if len(tested) else tested
            if optimizer is not None and len(part):
                part = part[part["optimizer"] == optimizer]
            if not len(part):
                continue
            row: dict[str, Any] = {
                "variant": variant.name,
                "label": variant.label,
                **({} if optimizer is None else {"optimizer": optimizer}),
                "goal_precision": float(part["goal_precision"].iloc[0]),
                "tasks": int(len(part)),
            }
            key = variant.name if optimizer is None else f"{variant.name}/{optimizer}"
            for metric in metrics:
                ci = mean_interval(
                    part[metric].to_numpy(dtype=np.float64),
                    interval=interval,
                    level=LEVEL,
                    n_boot=n_boot,
                    rng=_rng(seed, "by-precision", metric, key),
                )
                row.update(_ci_columns(metric, ci))
            rows.append(row)
    return pd.DataFrame(rows), _spearman(tested, metrics)


def _by_precision_markdown(
    table: pd.DataFrame, correlations: pd.DataFrame, interval: str = "t"
) -> str:
    lines = [
        "# Robustness and goal error by goal precision",
        "",
        f"Mean over tasks with a {LEVEL:.0%} {INTERVAL_NAMES[interval]}. Squared goal error:",
        "sum_t |X(m, t) - X^g|^2 at the nominal mass (m^2, summed over control steps); final",
        "distance: |X(m, T) - X^g| (m).",
        "",
    ]
    split = "optimizer" in table.columns  # several optimizers: a row each, never pooled
    header = ["p^X", "objective", *(["optimizer"] if split else []), "tasks"]
    header += ["robustness (m)", "squared goal error (m^2)", "final distance (m)"]
    rows = [
        [
            _fmt(row["goal_precision"]),
            row["label"] or "-",
            *([row["optimizer"]] if split else []),
            str(row["tasks"]),
            *(
                _interval(row[m], row[f"{m}_low"], row[f"{m}_high"], int(row[f"{m}_n"]))
                for m in _BY_PRECISION
            ),
        ]
        for _, row in table.iterrows()
    ]
    lines += _markdown(header, rows) + _interval_notes(table, _BY_PRECISION)
    lines += [
        "",
        "Spearman rank correlation of p^X with each metric over all tested designs (rho > 0:",
        "the metric grows with p^X):",
        "",
    ]
    rows = [
        [row["metric"], _fmt(row["rho"], 3), _fmt(row["p"], 3), str(row["n"])]
        for _, row in correlations.iterrows()
    ]
    lines += _markdown(["metric", "rho", "p", "designs"], rows)
    return "\n".join(lines) + "\n"


def _robustness_table(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    target: Path,
    seed: int,
    interval: str,
    *,
    notice: str | None = None,
) -> list[Path]:
    table = table_one(designs, config, seed=seed, interval=interval)
    return _write_table(target, "table1", table, _table_one_markdown(table, interval), notice)


def _robustness_scatter(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    target: Path,
    seed: int,
    interval: str,
    *,
    notice: str | None = None,
) -> list[Path]:
    tested = _tested(designs)
    figure, ax = plots.new_figure(figsize=(6.4, 4.4))
    variants = (
        [v for v in config.variants if v.name in set(tested["variant"])] if len(tested) else []
    )
    colors = plots.sequential_colors(len(variants), "viridis")
    for variant, color in zip(variants, colors, strict=True):
        part = tested[tested["variant"] == variant.name]
        precision = float(part["goal_precision"].iloc[0])
        name = f"p^X = {precision:g}" + (f" ({variant.label})" if variant.label else "")
        ax.scatter(part["squared_goal_error"], part["robustness"], color=color, s=22, label=name)
        ax.scatter(
            [part["squared_goal_error"].mean()],
            [part["robustness"].mean()],
            color=color,
            s=110,
            marker="D",
            edgecolors="black",
            linewidths=0.8,
        )
    ax.set_xlabel("squared goal error sum_t |X(m, t) - X^g|^2 (m^2)")
    ax.set_ylabel("robustness (m), higher is better")
    ax.set_title("robustness vs goal error (diamonds: means per p^X)")
    ax.grid(True, alpha=0.3)
    if variants:
        ax.legend(frameon=False, fontsize="small")
    written = [plots.save_png(figure, target / "robustness-scatter.png")]
    table, correlations = robustness_by_precision(designs, config, seed=seed, interval=interval)
    markdown = _by_precision_markdown(table, correlations, interval)
    written += _write_table(target, "robustness-by-precision", table, markdown, notice)
    return written


# --- mass perturbation -------------------------------------------------------------------------


def _has_mass_paths(record: Mapping[str, Any]) -> bool:
    paths = record.get("paths") or {}
    return bool(paths.get("nominal")) and bool(paths.get("perturbed"))


def _mass_paths(
    designs: Sequence[Mapping[str, Any]],
    config: SuiteConfig,
    target: Path,
    seed: int,
    interval: str,
    *,
    notice: str | None = None,
) -> list[Path]:
    written = []
    chosen = _chosen(designs, config, _has_mass_paths)
    for variant, record in chosen:
        paths = record["paths"]
        masses = [float(m) for m in paths["masses"]]
        figure, grid = plots.new_figure_grid(1, 2, figsize=(11.0, 4.6))
        left, right = grid[0]
        plots.plot_tool_shapes(left, [record["coefficients"]], colors=["black"], linewidth=3.0)
        left.set_title(f"tool: {_variant_name(record)}, seed {record['seed']}", fontsize="small")
        # Heavier is redder, as in the paper; the nominal mass is black.
        heat = colormaps["YlOrRd"](np.linspace(0.35, 1.0, len(masses)))
        colors = ["black", *[tuple(float(v) for v in c) for c in heat]]
        labels = [f"m = {float(paths['nominal_mass']):g} kg (nominal)"]
        labels += [f"m = {m:g} kg" for m in masses]
        trajectories = [np.asarray(paths["nominal"]), *map(np.asarray, paths["perturbed"])]
        plots.plot_box_paths(right, trajectories, record["goal"], labels, colors=colors)
        robustness = (record.get("test") or {}).get("robustness")
        right.set_title(f"box paths under box-mass changes: robustness {_fmt(robustness)} m")
        written.append(
            plots.save_png(figure, target / f"mass-perturbation-{_slug(variant.name)}.png")
        )

    rows = []
    shown = {id(r) for _, r in chosen}
    criterion = success_criterion(config.task_name)
    scene = scene_of_config(config.to_json())
    for record in designs:
        if not _has_mass_paths(record):
            continue
        paths = record["paths"]
        goal = np.asarray(record["goal"], dtype=np.float64)
        test = record.get("test") or {}
        row: dict[str, Any] = {
            "variant": record["variant"],
            "label": record.get("label", ""),
            "goal_precision": float(record["goal_precision"]),
            "seed": record["seed"],
            "shown": id(record) in shown,
            "free_energy": _float(record.get("free_energy")),
        }
        for name in ROBUSTNESS_METRICS:
            row[name] = _float(test.get(name))
        row[f"final_distance_m{float(paths['nominal_mass']):g}"] = float(
            np.linalg.norm(np.asarray(paths["nominal"])[-1] - goal)
        )
        for mass, path in zip(paths["masses"], paths["perturbed"], strict=True):
            row[f"final_distance_m{float(mass):g}"] = float(
                np.linalg.norm(np.asarray(path)[-1] - goal)
            )
        for mass, path in zip(
            [paths["nominal_mass"], *paths["masses"]],
            [paths["nominal"], *paths["perturbed"]],
            strict=True,
        ):
            end = np.asarray(path, dtype=np.float64)[-1]
            # The path's end gives the distance and the centre's height; the tilt is not stored
            # with the paths, so it is not checked (TaskDefinition.succeeded with no tilt).
            row[f"success_m{float(mass):g}"] = bool(
                criterion.succeeded(
                    float(np.linalg.norm(end - goal)), float(end[2]), scene, final_tilt=None
                )
            )
        rows.append(row)
    table = pd.DataFrame(rows)
    markdown = _mass_markdown(table, config.task_name, criterion.tolerance)
    written += _write_table(target, "mass-perturbation", table, markdown, notice)
    return written


def _true(value: Any) -> bool:
    """A stored flag that is True (a NaN, where a run lacks that mass, is not)."""
    return bool(pd.notna(value) and bool(value))


def _mass_markdown(table: pd.DataFrame, task: str = "push", tolerance: float = 0.1) -> str:
    lines = [
        "# Box paths under box-mass changes",
        "",
        "Per run: robustness (m), accuracy (m), control deviation (N m) of its design and the",
        "box's final distance from the goal (m) at each box mass; `*` marks the design shown in",
        "the figure of its p^X (the lowest F over seeds). Succeeds at: the box masses at which",
        f"the box ends within {tolerance:g} m of the goal (the {task} task's tolerance) with its",
        "centre at its resting height, from the end of the stored box path (the tilt is not",
        "stored with the paths and is not checked); `success_m<mass>` in the CSV.",
        "",
    ]
    if not len(table):
        return "\n".join(lines + ["No run has stored box paths."]) + "\n"
    distances = [c for c in table.columns if c.startswith("final_distance_m")]
    successes = [c for c in table.columns if c.startswith("success_m")]
    header = ["p^X", "seed", "F", "robustness", "accuracy", "control dev."]
    header += [f"final dist. {c.removeprefix('final_distance_m')} kg" for c in distances]
    header += [f"succeeds at (of {len(successes)} masses)"]
    rows = []
    for _, row in table.iterrows():
        cells = [
            _fmt(row["goal_precision"]) + (f" ({row['label']})" if row["label"] else ""),
            f"{row['seed']}{' *' if row['shown'] else ''}",
            _fmt(row["free_energy"]),
            _fmt(row["robustness"]),
            _fmt(row["accuracy"]),
            _fmt(row["control_deviation"]),
        ]
        cells += [_fmt(row[c], 3) for c in distances]
        hits = [c.removeprefix("success_m") for c in successes if _true(row[c])]
        cells.append(f"{', '.join(hits)} kg" if hits else "none")
        rows.append(cells)
    return "\n".join(lines + _markdown(header, rows)) + "\n"


_FIGURES: dict[str, Callable[..., list[Path]]] = {
    "tool-shapes": _tool_shapes,
    "robustness-table": _robustness_table,
    "robustness-scatter": _robustness_scatter,
    "mass-paths": _mass_paths,
}


# --- the report --------------------------------------------------------------------------------


def _kind(folder: Path) -> str | None:
    """``extra.kind`` of the folder's manifest, or None without a readable one."""
    try:
        extra = read_manifest(folder).get("extra")
    except (FileNotFoundError, ValueError):
        return None
    return extra.get("kind") if isinstance(extra, dict) else None


def make_suite_report(
    run_folder: str | os.PathLike[str],
    *,
    out_dir: str | os.PathLike[str] | None = None,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
) -> list[Path]:
    """Rebuild every report of a run folder from its stored results alone.

    An rl suite's folder (:func:`benchmarks.rl.run_rl_suite`) gets its own report,
    :func:`benchmarks.reports.rl.make_rl_report`, and a break-even study's folder
    (:func:`benchmarks.rl.run_breakeven`)
    :func:`benchmarks.reports.breakeven.make_breakeven_report`.

    Args:
        run_folder: A suite run folder (:func:`benchmarks.suites.runner.run_suite` or
            :func:`benchmarks.rl.run_rl_suite`); a design run folder or a bare store gets the
            generic report of :func:`make_report` only.
        out_dir: Where to write; ``run_folder/report`` if ``None``.
        n_boot: Bootstrap resamples per interval (``interval="bootstrap"``).
        seed: Root seed of the bootstraps; the same results and seed give the same bytes.
        interval: The interval of a mean: ``"t"`` (Student t, the default) or ``"bootstrap"``
            (percentile bootstrap, which covers less than 95 % with few seeds).

    Returns:
        The files written.

    Raises:
        FileNotFoundError: If ``run_folder`` does not exist.
        NotADirectoryError: If it is a file.
        benchmarks.storage.EmptyStoreError: If it holds no evaluations.
        ValueError: If a stored file is malformed, or differs from the checksum the manifest
            records for it (:meth:`benchmarks.storage.ResultStore.verify`); then nothing is
            written.
    """
    interval = check_interval(interval)
    folder = Path(run_folder)
    if not folder.exists():
        raise FileNotFoundError(f"run folder {folder} does not exist")
    if not folder.is_dir():
        raise NotADirectoryError(f"run folder {folder} is not a folder")
    # Every recorded checksum and every design and retest file first: a folder that was
    # tampered with is refused before a report file is written.
    ResultStore(folder).verify()
    target = folder / REPORT_DIR if out_dir is None else Path(out_dir)
    check_write_folder(folder, target)  # a report/ linked to another folder is not written
    if _kind(folder) == RL_SUITE_KIND:
        written = make_rl_report(folder, out_dir=out_dir)
    elif _kind(folder) == "rl-breakeven":  # benchmarks.rl.breakeven.BREAKEVEN_KIND
        from benchmarks.reports.breakeven import make_breakeven_report

        written = make_breakeven_report(folder, out_dir=out_dir)
    else:
        written = _checked_suite_report(folder, target, n_boot=n_boot, seed=seed, interval=interval)
    # A reader shows a report file only while it is as written here (html, reproduce).
    record_report_files(folder, written)
    return written


def _checked_suite_report(
    folder: Path, target: Path, *, n_boot: int, seed: int, interval: str
) -> list[Path]:
    """The report of a suite folder (or a design run's, or a bare store's) that was checked."""
    designs, retests = read_designs(folder), read_retests(folder)
    notice = _incomplete_notice(folder, designs, retests)
    if notice is not None:
        # Every page says so first (each written once, with it): its comparisons may cover
        # unequal budgets.
        warnings.warn(notice, RuntimeWarning, stacklevel=2)
    return _suite_report(
        folder,
        target,
        designs,
        retests,
        n_boot=n_boot,
        seed=seed,
        interval=interval,
        notice=notice,
    )


def _incomplete_notice(
    folder: Path, designs: Sequence[Mapping[str, Any]], retests: Sequence[Mapping[str, Any]]
) -> str | None:
    """What is missing from a suite folder: runs not finished, designs not retested; or None.

    None for a bare store (no manifest): it is no suite folder, and its report says so.
    """
    if not (folder / MANIFEST_NAME).exists():
        return None
    manifest = read_manifest(folder)
    extra = manifest.get("extra")
    if not isinstance(extra, dict) or extra.get("kind") != SUITE_KIND:
        return None
    notices = []
    planned = extra.get("runs")
    done = len(designs)
    finished = manifest.get("end_time") is not None
    if not finished or (isinstance(planned, int) and done < planned):
        runs = f"{done} of {planned} runs" if isinstance(planned, int) else f"{done} runs"
        notices.append(
            f"{runs} finished when this report was made (the run was interrupted or is still "
            "going), so optimizers and variants may be compared over unequal budgets. Resume "
            "the run with the command that started it, then run tooldesign report again."
        )
    testable = [d for d in designs if d.get("status") == "ok" and d.get("coefficients")]
    if retests and len(retests) < len(testable):
        notices.append(
            f"The retest covers {len(retests)} of the {len(testable)} final designs, so the "
            "noise floor and the stress test come from those alone. Run tooldesign retest on "
            "the folder again to complete it (it resumes), then tooldesign report."
        )
    return " ".join(notices) or None


def _suite_report(
    folder: Path,
    target: Path,
    designs: Sequence[Mapping[str, Any]],
    retests: Sequence[Mapping[str, Any]],
    *,
    n_boot: int,
    seed: int,
    interval: str,
    notice: str | None,
) -> list[Path]:
    floors = {
        str(v): noise_floor([r for r in retests if r.get("variant") == v])["free_energy"]
        for v in {r.get("variant") for r in retests}
    }
    written = make_report(
        folder,
        out_dir=target,
        n_boot=n_boot,
        seed=seed,
        interval=interval,
        noise_floor=floors or None,
        notice=notice,
    )
    try:
        task = task_of_manifest(read_manifest(folder))
    except (FileNotFoundError, ValueError, TypeError):
        task = None  # not a suite folder: the push task's tolerance, as before
    written += make_retest_report(
        retests, target, n_boot=n_boot, seed=seed, interval=interval, notice=notice, task=task
    )
    try:
        config = suite_of_manifest(read_manifest(folder))
    except (FileNotFoundError, ValueError, TypeError):
        return written  # not a suite folder: the generic report is all there is
    if not designs:
        return written
    manifest = read_manifest(folder)
    task = task_of_manifest(manifest)
    table = designs_table(
        designs, tolerance=success_criterion(task), scene=scene_of_manifest(manifest)
    )
    standing = any(record.get("final_height") is not None for record in designs)
    markdown = _designs_markdown(table, task, standing=standing)
    written += _write_table(target, "designs", table, markdown, notice)
    for figure in config.figures:
        written += _FIGURES[figure](designs, config, target, seed, interval, notice=notice)
    return written
