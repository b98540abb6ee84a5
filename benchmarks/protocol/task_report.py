"""The protocol report's task axis: a section per task and one pooled over tasks.

:func:`~benchmarks.protocol.report.make_protocol_report` writes the first task's sections
(push's, when it is run) as it always did, and, when a run has more than one task, appends what
this module writes::

    report/
        ecdf_<task>.png           ECDF of each task other than the first, all its degrees
        ecdf_tasks.png            ECDF pooled over every task and degree
        task_comparisons.csv, task_ranks.csv, task_power.csv
                                  the statistics per task and pooled ("all tasks"), column task;
                                  task_comparisons.csv with the final-F difference beyond the
                                  noise floor and told_apart, as comparisons.csv

and in ``report.md`` the AUC per task, then per task its AUC, references, public and held-out
scores and statistics, then the statistics of all tasks pooled. Per task the unit is an
instance and pooled over tasks a (task, instance) pair, each with its d blocks averaged (its
final F too, and its noise floor the mean of its blocks'): a score is an ECDF area in [0, 1] on
every task, so tasks whose F differ in scale pool without weighting one over another.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.protocol.suite import ProtocolConfig

__all__ = ["POOLED_TASKS", "task_sections"]

#: The ``task`` label of the statistics pooled over every task.
POOLED_TASKS = "all tasks"


REFERENCE_SUCCESS_NOTE = (
    "F_ref succeeds: whether the reference design's box ends within the task's tolerance of "
    "the goal, from its stored final distance (the references store no height or tilt). The "
    "straight tool and random sampling are stored as F only (`f_straight`, `random_pool`), so "
    "their success is not stored and not shown."
)


def references_shown(table: pd.DataFrame, task: str) -> pd.DataFrame:
    """The references table as report.md shows it: with ``F_ref succeeds`` after its distance.

    ``yes``/``no`` from ``final distance (m)`` and ``task``'s tolerance (the distance part of
    its test: the references store no height or tilt), ``n/a`` where no distance is stored.
    references.csv keeps its columns; the column is the page's.
    """
    from tooldesign_env.tasks import get_task

    tolerance = get_task(task).tolerance
    out = table.copy()
    if "final distance (m)" not in out.columns:
        return out
    distance = out["final distance (m)"].astype(float)
    flag = ["n/a" if not np.isfinite(d) else ("yes" if d <= tolerance else "no") for d in distance]
    out.insert(out.columns.get_loc("final distance (m)") + 1, "F_ref succeeds", flag)
    return out


def _statistics(
    frame: pd.DataFrame,
    label: str,
    unit: str,
    alpha: float,
    md_table: Callable[..., str],
    floors: dict[str, float],
) -> tuple[list[str], list[pd.DataFrame]]:
    """The markdown and the (comparisons, ranks, power) tables of one group of runs.

    ``floors``: each block's noise floor (its reference's), by the block's label in ``frame``.
    """
    from benchmarks.protocol.effects import compare_with_floor, separation_sentence
    from benchmarks.protocol.statistics import min_instances, power_analysis, rank_stability

    frame = frame.dropna(subset=["score"])
    if frame["optimizer"].nunique() < 2 or frame["instance"].nunique() < 2:
        return ["Fewer than two optimizers or instances: no comparison.", ""], []
    table, in_f = compare_with_floor(frame, floors, alpha=alpha)
    pairs = len(table)
    floor = min_instances(alpha, max(1, pairs))
    blocks = int(frame["instance"].nunique())
    rank = rank_stability(frame, resamples=500).reset_index(names="optimizer")
    power = power_analysis(frame, alpha=alpha)
    if blocks < floor:
        verdict = (
            f"**This section cannot separate any pair**: with {blocks} {unit}, fewer than the "
            f"{floor} the Wilcoxon-Holm comparison of {pairs} pair(s) at alpha = {alpha:g} needs "
            "(docs/protocol.md, Statistics)."
        )
    else:
        verdict = (
            f"With {blocks} {unit} (at least {floor} are needed for any pair to be significant "
            f"at Holm alpha = {alpha:g} over {pairs} pair(s)), a pair can be told apart; the "
            "power table says how large a difference must be."
        )
    lines = [
        verdict,
        "",
        separation_sentence(table, in_f, group=label, alpha=alpha, unit=unit),
        "",
        "Paired comparisons (Wilcoxon signed-rank, Holm-corrected; mean_diff with a 95 % "
        f"Student t interval over {unit}; f_diff, the final-F difference a - b, with its t "
        f"interval, floor (the median over {unit} of their noise floors) and beyond_floor; "
        "told_apart = "
        f"p_holm < {alpha:g} AND beyond_floor; docs/protocol.md, Statistics):",
        "",
        md_table(table),
        "",
        "Ranking and its stability:",
        "",
        md_table(rank),
        "",
        "Power (score):",
        "",
        md_table(power),
        "",
        "Power (final F):",
        "",
        md_table(in_f),
        "",
    ]
    tagged = [t.assign(task=label) for t in (table, rank, power)]
    return lines, tagged


def _floors(references: pd.DataFrame) -> dict[str, float]:
    """Each instance's noise floor: the mean of its (instance, d) blocks' floors.

    The statistics average an instance's d blocks (:func:`cluster_runs`), its final F too, so
    its floor is the mean of its blocks' floors
    (:func:`~benchmarks.protocol.effects.instance_floors`, as the report's pooled section).
    """
    from benchmarks.protocol.effects import instance_floors

    return instance_floors(references)


def _in_task_order(table: pd.DataFrame, tasks: tuple[str, ...]) -> pd.DataFrame:
    """Rows ordered as the run's tasks are (push first), not alphabetically."""
    order = {task: k for k, task in enumerate(tasks)}
    return table.sort_values("task", key=lambda s: s.map(order), kind="stable")


def task_sections(
    config: ProtocolConfig,
    times: pd.DataFrame,
    scores: pd.DataFrame,
    references: pd.DataFrame,
    out: Path,
    alpha: float,
    *,
    md_table: Callable[..., str],
    auc_table: Callable[[pd.DataFrame, str], pd.DataFrame],
    ecdf_figure: Callable[[pd.DataFrame, str, Path], Any],
) -> tuple[list[str], list[Path]]:
    """The report's sections per task and pooled over tasks, and the files they need.

    The report's own table and figure makers are passed in (this module sits beside
    :mod:`~benchmarks.protocol.report`, which calls it, and does not import it).

    Args:
        config: The run's config (more than one task).
        times: Runtimes of every task (``measure_runs``, with its ``task`` column).
        scores: Per-run scores of every task.
        references: The references table of every task (with ``task``).
        out: The report folder (checked by the caller).
        alpha: Family-wise level of the comparisons.
        md_table: A frame as a markdown table (``floatfmt`` keyword).
        auc_table: The AUC table of scores grouped by a column.
        ecdf_figure: Draws the ECDF of runtimes with a title into a PNG.

    Returns:
        The markdown lines, and the files written.
    """
    from benchmarks.protocol.statistics import cluster_runs, held_out_gap
    from benchmarks.storage import atomic_write_text
    from tooldesign_env.tasks import get_task

    written: list[Path] = []
    sections = [
        "# Tasks",
        "",
        f"Tasks {', '.join(config.tasks)}. Each task's instances are its own committed set "
        f"(v{config.instance_version}); a task other than push runs at d = "
        f"{', '.join(map(str, config.task_degrees))} on {len(config.task_instances)} "
        f"instance{'s' if len(config.task_instances) != 1 else ''} of its set. Scores are ECDF "
        "areas (0 to 1), comparable across tasks.",
        "",
        "## Area under the ECDF per task (mean over instances, each instance's d blocks "
        "averaged, 95 % Student t interval over instances)",
        "",
        md_table(_in_task_order(auc_table(scores, "task"), config.tasks)),
        "",
    ]
    tables: list[list[pd.DataFrame]] = [[], [], []]
    figures = []
    for task in config.tasks[1:]:
        mine = scores[scores["task"] == task]
        definition = get_task(task)
        refs = references[references["task"] == task].drop(columns="task")
        sections += [
            f"## Task {task}",
            "",
            f"{definition.title[:1].upper()}{definition.title[1:]} "
            f"(success radius {definition.tolerance:g} m; docs/tasks.md).",
            "",
            md_table(auc_table(mine, "degree")),
            "",
            "References (F_random at the full budget):",
            "",
            md_table(references_shown(refs, task), ".6g"),
            "",
            REFERENCE_SUCCESS_NOTE,
            "",
            "Public and held-out instances: held-out minus public mean score per optimizer, "
            "with a 95 % Welch t interval over instances (as push's, above):",
            "",
            md_table(held_out_gap(mine)),
            "",
        ]
        # An instance's d blocks are not independent: the instance (blocks averaged) is the unit.
        blocks = cluster_runs(mine)
        lines, tagged = _statistics(
            blocks, task, "instances (d blocks averaged)", alpha, md_table, _floors(refs)
        )
        sections += [f"### Statistics, task {task}", "", *lines]
        for k, table in enumerate(tagged):
            tables[k].append(table)
        path = out / f"ecdf_{task}.png"
        ecdf_figure(times[times["task"] == task], f"task {task}", path)
        written.append(path)
        figures.append(path.name)
    # Each task's instances are its own set (labels "hook/i01"): a task's instance with its d
    # blocks averaged is the unit.
    pooled = cluster_runs(scores)
    lines, tagged = _statistics(
        pooled,
        POOLED_TASKS,
        "(task, instance) units (d blocks averaged)",
        alpha,
        md_table,
        _floors(references),
    )
    sections += ["## Statistics, all tasks pooled (units: task x instance)", "", *lines]
    for k, table in enumerate(tagged):
        tables[k].append(table)
    path = out / "ecdf_tasks.png"
    ecdf_figure(times, "all tasks and dimensions", path)
    written.append(path)
    figures.append(path.name)
    for name, parts in zip(
        ("task_comparisons.csv", "task_ranks.csv", "task_power.csv"), tables, strict=True
    ):
        if parts:
            written.append(atomic_write_text(out / name, pd.concat(parts).to_csv(index=False)))
    sections += ["## Task ECDFs", ""] + [f"![{f}]({f})" for f in figures] + [""]
    return sections, written
