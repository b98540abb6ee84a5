"""The break-even study's report, from its stored evaluations alone (``docs/rl.md``).

Measures (as the benchmark protocol defines them in :mod:`benchmarks.protocol.measures` and
:mod:`benchmarks.protocol.statistics`; the two formulas used here, the expected best of random
designs and the paired comparison, are the protocol's own code, which lives in
:mod:`benchmarks.reports.measures`, below the protocol in the layers of docs/architecture.md):

- **Best so far** b(t): the lowest F among a run's first t evaluations. A zero-shot design is
  one evaluation: its b(t) is its F at every budget (the rest of the budget is unused).
- **Normalized regret** at budget t: ``(b(t) - F_ref) / (F_random(t) - F_ref)`` per task, with
  F_ref the lowest F any method of the study found at the task and F_random(t) the expected best
  of t random designs, computed exactly from the study's random designs at the task
  (:func:`expected_best_of_random`). 0 is the best design known,
  1 is as good as random sampling with the same budget. Where F_random(t) equals F_ref (the
  random pool's best is the reference and t draws it surely) the regret is undefined (NaN) and
  left out.
- **Intervals**: a method's score on a task is its mean over replicates; its mean over tasks
  has a 95 % Student t interval over tasks (:func:`benchmarks.reports.stats.t_interval`).
- **The noise floor of a task** (:func:`task_floors`): as the benchmark protocol sets a
  cell's (``compute_cell`` of :mod:`benchmarks.protocol.references`), the larger of the range
  of F of the task's reference design over nudged scenes (the study's floor unit:
  :func:`benchmarks.rl.breakeven.noise_floors`; the design is the best of the task's cold
  CMA-ES runs) and the least floor ``floor_fraction * |F_ref|`` (``floor_min_fraction``, the
  project's median relative floor). A task without a measured range gets the least floor.
- **The verdict, warm against cold** (:func:`warm_cold_table`, issue 36's question): per pair
  (task, replicate; warm and cold share the CMA-ES seed), the best F so far at the budget,
  warm-started minus cold CMA-ES, in floors of the task, averaged over a task's replicates.
  The one-sided Wilcoxon signed-rank test over the tasks (the independent units) of "warm's F
  is lower by more than one floor" (the task means plus 1 are below 0), Holm-corrected over
  every warm-started method at every budget as one family.
  Warm beats cold where Holm p < :data:`ALPHA`. Effect size: the mean over tasks with its
  95 % t interval (over tasks), and the median over pairs. Tasks and training seeds are
  crossed (replicate k's designer, trained once, designs at every task), so the test is of the
  study's trained designers on new tasks; beside it, ``replicates_beyond`` counts the
  replicates whose mean over tasks is below -1 floor, the check of agreement across training
  seeds. The mirror test, for harm: the one-sided test that warm's F is higher than cold's by
  more than one floor (the task means - 1 above 0), Holm over the same rows;
  ``worse_than_cold`` where its Holm p < :data:`ALPHA`, ``replicates_worse`` the replicates
  whose mean is above +1 floor. Up to cold CMA-ES's population size (``size.popsize`` of the
  study's config) cold CMA-ES has not updated yet (its first generation: draws from its
  starting Gaussian), so the words tell wins before its first update from wins after it
  adapts. :func:`verdict_test_text`, :func:`verdict_markdown` and :func:`verdict_sentence`
  word it for this report and for docs/rl.md alike.
- **Paired tests of every pair** at each budget (secondary, not the verdict): the two-sided
  Wilcoxon signed-rank test of the per-task differences of normalized regret, Holm-corrected
  over the pairs of that budget only (:func:`benchmarks.reports.measures.paired_table`, the
  code of ``benchmarks.protocol.statistics.paired_comparisons``; alpha 0.05).
- **Amortization**: for each budget B of cold CMA-ES, every method is read on B's scale: its
  best so far at any budget b, per task, normalized by ``F_random(B) - F_ref`` (one scale, so
  a lower F is a lower value). q_B is cold CMA-ES's mean on it at B; the smallest budget b at
  which a learned method's mean is <= q_B is what it needs; the method spends T training
  episodes once, then b per goal, against B per goal for cold CMA-ES, so it pays for itself
  after ``ceil(T / (B - b))`` goals (never if b >= B or q_B is not reached). Beside it, the
  range across training seeds: each replicate's mean over the same tasks against the same q_B,
  its own b and goals. :func:`amortization_cell` and :func:`amortization_sentence` word it
  (the sentence sets apart the budgets B up to cold CMA-ES's population size).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from benchmarks.reports.comparison import REPORT_DIR
from benchmarks.reports.markdown import markdown_table
from benchmarks.reports.measures import COMPARISON_COLUMNS, expected_best_of_random, paired_table
from benchmarks.reports.plots import new_figure_grid, save_png
from benchmarks.reports.stats import holm_bonferroni, t_interval
from benchmarks.storage import atomic_write_text, json_text
from benchmarks.storage.table import csv_text

__all__ = [
    "AFTER_FIRST_UPDATE",
    "ALPHA",
    "AMORTIZATION_COLUMNS",
    "amortization_cell",
    "amortization_sentence",
    "before_first_update",
    "study_popsize",
    "worse_than_cold_value",
    "COMPARISON_COLUMNS",
    "expected_best_of_random",
    "paired_table",
    "amortization_table",
    "comparison_table",
    "make_breakeven_report",
    "regret_curves",
    "regret_table",
    "results_rows",
    "score_row",
    "study_references",
    "noise_floor_fraction",
    "task_floors",
    "warm_cold_table",
    "TASK_FLOOR_COLUMNS",
    "TESTED",
    "WARM_COLD_COLUMNS",
    "VERDICT_HEADER",
    "beats_cold_value",
    "verdict_markdown",
    "verdict_row",
    "verdict_sentence",
    "verdict_test_text",
]

#: Family-wise level of the paired tests (issue 36: Holm p < 0.05).
ALPHA = 0.05

#: The variants of evaluations at a task in the task's scene: the ones scored (training
#: episodes are at random tasks; ``floor`` rows are in nudged scenes, the noise floor's).
TESTED: tuple[str, ...] = ("zero-shot", "cold", "warm")


def _study_budgets(folder: Path) -> tuple[list[int], list[str], dict[str, Any]]:
    from benchmarks.storage import read_manifest

    config = read_manifest(folder)["config"]
    return list(config["size"]["budgets"]), list(config["methods"]), config


def _references(log: pd.DataFrame) -> tuple[pd.Series, dict[str, np.ndarray]]:
    """F_ref per task (lowest finite F of any method there) and the random pool per task."""
    tested = log[log["variant"].isin(TESTED) & np.isfinite(log["free_energy"])]
    f_ref = tested.groupby("task")["free_energy"].min()
    random = tested[tested["method"] == "random"]
    pools = {task: g["free_energy"].to_numpy() for task, g in random.groupby("task")}
    return f_ref, pools


def study_references(log: pd.DataFrame) -> tuple[pd.Series, dict[str, np.ndarray]]:
    """The study's scale per task: F_ref (its lowest F there) and its random designs' F.

    Args:
        log: :func:`benchmarks.rl.breakeven.load_breakeven`'s frame.
    """
    return _references(log)


def regret_curves(
    log: pd.DataFrame,
    max_budget: int | None = None,
    *,
    references: tuple[pd.Series, dict[str, np.ndarray]] | None = None,
) -> pd.DataFrame:
    """Best so far and normalized regret of every tested run at every budget 1..max.

    Args:
        log: :func:`benchmarks.rl.breakeven.load_breakeven`'s frame.
        max_budget: The largest budget (default: the longest run's length).
        references: F_ref and the random pool per task (:func:`study_references` of the
            study); default: the log's own. A method scored later against a committed study
            passes the study's, so that it does not move the reference.

    Returns:
        One row per (method, task, replicate, evaluation): ``best`` (F) and ``regret``.

    Raises:
        ValueError: a log without tested runs or random designs (nothing to normalize by).
    """
    tested = log[log["variant"].isin(TESTED)]
    if tested.empty:
        raise ValueError("the log holds no evaluation at a task (only training episodes)")
    f_ref, pools = _references(log) if references is None else references
    if not pools:
        raise ValueError("the log holds no random designs: the regret has no scale")
    runs = tested[tested["variant"] != "zero-shot"]
    longest = int(runs["evaluation"].max()) if len(runs) else 1
    top = longest if max_budget is None else int(max_budget)
    budgets = np.arange(1, top + 1)
    frames = []
    for (method, task, replicate), run in tested.groupby(["method", "task", "replicate"]):
        run = run.sort_values("evaluation")
        if (run["variant"] == "zero-shot").all():
            best = np.full(top, float(run["free_energy"].iloc[0]))
        else:
            values = run["free_energy"].to_numpy(dtype=np.float64)
            values = np.where(np.isnan(values), np.inf, values)
            running = np.minimum.accumulate(values)
            best = running[np.minimum(budgets, len(running)) - 1]
        frames.append(
            pd.DataFrame(
                {
                    "method": method,
                    "task": task,
                    "replicate": int(replicate),
                    "evaluation": budgets,
                    "best": best,
                }
            )
        )
    curves = pd.concat(frames, ignore_index=True)
    regret = np.full(len(curves), np.nan)
    for task, rows in curves.groupby("task").groups.items():
        pool = pools.get(str(task))
        if pool is None or task not in f_ref.index:
            continue
        usable = budgets[budgets <= len(pool)]
        f_random = dict(zip(usable.tolist(), expected_best_of_random(pool, usable), strict=True))
        ref = float(f_ref[task])
        index = np.asarray(rows)
        t = curves.loc[index, "evaluation"].to_numpy()
        scale = np.array([f_random.get(int(v), np.nan) - ref for v in t])
        best = curves.loc[index, "best"].to_numpy()
        with np.errstate(divide="ignore", invalid="ignore"):
            regret[index] = np.where(scale > 0, (best - ref) / scale, np.nan)
    curves["regret"] = np.where(np.isfinite(regret), regret, np.nan)
    return curves


def _task_means(curves: pd.DataFrame) -> pd.DataFrame:
    return curves.groupby(["method", "evaluation", "task"])["regret"].mean().reset_index()


def _order(methods: Iterable[str], known: Sequence[str]) -> list[str]:
    present = list(dict.fromkeys(methods))
    return [m for m in known if m in present] + sorted(m for m in present if m not in known)


def regret_table(
    curves: pd.DataFrame, budgets: Sequence[int], methods: Sequence[str] = ()
) -> pd.DataFrame:
    """Mean normalized regret over tasks with its 95 % t interval, per method and budget.

    Returns:
        ``method``, ``budget``, ``mean``, ``ci_low``, ``ci_high``, ``tasks`` (with a regret).
    """
    means = _task_means(curves)
    rows = []
    for method in _order(means["method"], methods):
        for budget in budgets:
            values = means[(means["method"] == method) & (means["evaluation"] == budget)]
            interval = t_interval(values["regret"].to_numpy(dtype=np.float64), 0.95)
            rows.append(
                {
                    "method": method,
                    "budget": int(budget),
                    "mean": interval.estimate,
                    "ci_low": interval.low,
                    "ci_high": interval.high,
                    "tasks": interval.n,
                }
            )
    return pd.DataFrame(rows, columns=["method", "budget", "mean", "ci_low", "ci_high", "tasks"])


def comparison_table(curves: pd.DataFrame, budgets: Sequence[int]) -> pd.DataFrame:
    """Paired Wilcoxon tests of every pair of methods at each budget, Holm over the pairs.

    Returns:
        :data:`COMPARISON_COLUMNS` with ``budget`` first;
        ``mean_diff`` is mean(a - b) of normalized regret over tasks (< 0: a is better).
    """
    tables = []
    for budget in budgets:
        at = curves[curves["evaluation"] == budget]
        means = at.groupby(["task", "method"])["regret"].mean().unstack("method")
        if means.notna().to_numpy().sum() == 0:
            continue
        table = paired_table(means, alpha=ALPHA)
        table.insert(0, "budget", int(budget))
        tables.append(table)
    if not tables:
        return pd.DataFrame(columns=["budget", *COMPARISON_COLUMNS])
    return pd.concat(tables, ignore_index=True)


#: The columns of :func:`warm_cold_table`, one row per warm-started method and budget.
WARM_COLD_COLUMNS: tuple[str, ...] = (
    "method",
    "budget",
    "pairs",
    "tasks",
    "mean_floors",
    "ci_low",
    "ci_high",
    "median_floors",
    "replicates",
    "replicates_beyond",
    "replicates_worse",
    "p",
    "p_holm",
    "beats_cold",
    "p_worse",
    "p_worse_holm",
    "worse_than_cold",
)

#: The columns of :func:`task_floors`, one row per task.
TASK_FLOOR_COLUMNS: tuple[str, ...] = (
    "task",
    "f_ref",
    "noise_range",
    "least_floor",
    "floor",
    "measured",
)


def noise_floor_fraction() -> float:
    """The project's median relative noise floor of F: the equivalence reference's median.

    The smallest floor the benchmark protocol gives a target (``floor_min_fraction`` of
    :mod:`benchmarks.protocol.references`, the same number read the same way): the relative
    range of F over 16 nudged scenes, median over the designs of
    ``benchmarks/suites/equivalence-reference.json``.

    Raises:
        ValueError: The reference has no measured median relative floor.
    """
    from benchmarks.suites.equivalence import median_relative_floor

    return median_relative_floor()


def task_floors(f_ref: pd.Series, floors: pd.DataFrame, *, floor_fraction: float) -> pd.DataFrame:
    """The noise floor of each task, as the protocol's ``compute_cell`` sets a cell's.

    The larger of the measured range of F over nudged scenes
    (:func:`benchmarks.rl.breakeven.noise_floors`) and the least floor
    ``floor_fraction * |F_ref|``; a task without a measured range (no floor unit, or a
    failed one) gets the least floor (``measured`` False).

    Args:
        f_ref: F_ref per task (:func:`study_references`).
        floors: :func:`benchmarks.rl.breakeven.noise_floors` of the study.
        floor_fraction: The least floor as a fraction of |F_ref|, > 0
            (:func:`noise_floor_fraction`).

    Returns:
        :data:`TASK_FLOOR_COLUMNS`, one row per task of ``f_ref``, indexed by task.

    Raises:
        ValueError: ``floor_fraction`` not a number > 0.
    """
    if (
        isinstance(floor_fraction, bool)
        or not isinstance(floor_fraction, (int, float))
        or not (math.isfinite(floor_fraction) and floor_fraction > 0)
    ):
        raise ValueError(f"floor_fraction must be a number > 0, got {floor_fraction!r}")
    measured = floors.set_index("task")["noise_range"] if len(floors) else pd.Series(dtype=float)
    noise = measured.reindex(f_ref.index).astype(float)
    least = floor_fraction * f_ref.abs().astype(float)
    table = pd.DataFrame(
        {
            "task": f_ref.index,
            "f_ref": f_ref.to_numpy(dtype=np.float64),
            "noise_range": noise.to_numpy(),
            "least_floor": least.to_numpy(),
        },
        index=f_ref.index,
    )
    table["floor"] = np.fmax(table["noise_range"], table["least_floor"])
    table["measured"] = np.isfinite(table["noise_range"]).astype(bool)
    return table[list(TASK_FLOOR_COLUMNS)]


def warm_cold_table(
    curves: pd.DataFrame,
    budgets: Sequence[int],
    *,
    floors: pd.Series,
) -> pd.DataFrame:
    """Does each warm-started method beat cold CMA-ES beyond the noise floor: the verdict.

    Pairs: (task, replicate), replicate k of the warm run against replicate k of cold CMA-ES
    (the same CMA-ES seed). Per pair, z = (b_warm - b_cold) / floor_task, the difference of
    best F so far at the budget in noise floors of the task (< 0: warm is better). The unit
    of the test is the task, not the pair: a task's replicates share its goal and mass, so
    they are not independent, and counting them as such would make a win on a few tasks look
    certain. Per task, d = the mean of z over its replicates + 1. The test is one-sided, of
    "beyond the floor" itself: the Wilcoxon signed-rank test over the tasks of d with H1 "d is
    below 0", i.e. warm's F is lower than cold's by more than one floor (p = 1 when every d is
    0); one Holm correction over every row (all warm-started methods at all budgets: one
    family). A row ``beats_cold`` when its Holm p is below :data:`ALPHA`. Effect size: the
    mean of z over tasks with its 95 % t interval over tasks, and the median of z over the
    pairs.

    The tasks and the training seeds are crossed: replicate k's designer, trained once with
    seed k, designs at every task, so the test over tasks is of these trained designers on new
    tasks and leaves out the variance between training seeds (a test over seeds could not pass
    Holm with 5 seeds: its smallest one-sided p is 1 / 32). The check of agreement across
    training seeds is beside it: ``replicates_beyond``, how many of the ``replicates`` have
    their mean of z over tasks below -1 (warm better beyond the floor for that trained
    designer).

    The mirror test, for harm (a warm start that leads CMA-ES astray): the one-sided Wilcoxon
    signed-rank test over the tasks of d' = the task's mean of z - 1 with H1 "d' is above 0",
    i.e. warm's F is higher than cold's by more than one floor (p = 1 when every d' is 0),
    Holm-corrected over the same rows as a family of its own; ``worse_than_cold`` where that
    Holm p is below :data:`ALPHA`, and ``replicates_worse`` counts the replicates whose mean
    of z over tasks is above +1.

    Args:
        curves: :func:`regret_curves` of the study.
        budgets: The budgets to test.
        floors: The noise floor per task in F units, > 0 (:func:`task_floors`' ``floor``).

    Returns:
        :data:`WARM_COLD_COLUMNS`.

    Raises:
        ValueError: a floor that is not a finite number > 0.
    """
    values = floors.to_numpy(dtype=np.float64)
    if not np.all(np.isfinite(values) & (values > 0)):
        raise ValueError(f"floors must be finite numbers > 0, got {floors.to_dict()}")
    methods = sorted(m for m in set(curves["method"]) if str(m).startswith("warm-"))
    keyed = curves.set_index(["method", "evaluation", "task", "replicate"])["best"].sort_index()
    rows: list[dict[str, Any]] = []
    if "cmaes" in set(curves["method"]):
        for method in methods:
            for budget in budgets:
                try:
                    warm = keyed.loc[(method, budget)]
                    cold = keyed.loc[("cmaes", budget)]
                except KeyError:
                    continue
                both = pd.concat({"warm": warm, "cold": cold}, axis=1, join="inner")
                task = both.index.get_level_values("task")
                z = (both["warm"] - both["cold"]) / floors.reindex(task).to_numpy()
                z = z[np.isfinite(z.to_numpy(dtype=np.float64))]
                by_task = z.groupby(level="task").mean().to_numpy(dtype=np.float64)
                by_replicate = z.groupby(level="replicate").mean().to_numpy(dtype=np.float64)
                interval = t_interval(by_task, 0.95)
                d = by_task + 1.0
                row: dict[str, Any] = {
                    "method": method,
                    "budget": int(budget),
                    "pairs": int(z.size),
                    "tasks": int(by_task.size),
                    "mean_floors": interval.estimate,
                    "ci_low": interval.low,
                    "ci_high": interval.high,
                    "median_floors": float(np.median(z)) if z.size else math.nan,
                    "replicates": int(by_replicate.size),
                    "replicates_beyond": int(np.sum(by_replicate < -1.0)),
                    "replicates_worse": int(np.sum(by_replicate > 1.0)),
                    "p": _one_sided(d, "less"),
                    "p_worse": _one_sided(by_task - 1.0, "greater"),
                }
                rows.append(row)
    decided = ("p_holm", "beats_cold", "p_worse_holm", "worse_than_cold")
    table = pd.DataFrame(rows, columns=[c for c in WARM_COLD_COLUMNS if c not in decided])
    table["p_holm"] = holm_bonferroni(table["p"].to_numpy(dtype=np.float64))
    table["beats_cold"] = (table["p_holm"] < ALPHA).astype(bool)
    table["p_worse_holm"] = holm_bonferroni(table["p_worse"].to_numpy(dtype=np.float64))
    table["worse_than_cold"] = (table["p_worse_holm"] < ALPHA).astype(bool)
    return table[list(WARM_COLD_COLUMNS)]


def _one_sided(d: np.ndarray, alternative: str) -> float:
    """The one-sided Wilcoxon signed-rank p of ``d`` (H1: below 0 or above 0) over the tasks.

    NaN with fewer than 2 tasks (not a test); 1 when every d is 0 (no evidence either way).
    """
    from scipy.stats import wilcoxon

    if d.size < 2:
        return math.nan
    if np.all(d == 0):
        return 1.0
    return float(wilcoxon(d, zero_method="zsplit", alternative=alternative).pvalue)


def _training_episodes(log: pd.DataFrame) -> dict[str, float]:
    train = log[log["variant"] == "train"]
    return {str(m): float(g.groupby("replicate").size().mean()) for m, g in train.groupby("method")}


def _training_by_replicate(log: pd.DataFrame) -> dict[tuple[str, int], float]:
    train = log[log["variant"] == "train"]
    sizes = train.groupby(["method", "replicate"]).size()
    return {(str(m), int(r)): float(n) for (m, r), n in sizes.items()}


#: The columns of :func:`amortization_table`, one row per learned method and budget B.
AMORTIZATION_COLUMNS: tuple[str, ...] = (
    "method",
    "reference_budget",
    "target_regret",
    "budget_needed",
    "training_episodes",
    "breakeven_goals",
    "replicates",
    "budget_needed_min",
    "budget_needed_max",
    "goals_min",
    "goals_max",
)


def _task_best(curves: pd.DataFrame) -> pd.Series:
    """Best so far per (method, task, evaluation): the mean over replicates, in F."""
    return curves.groupby(["method", "task", "evaluation"])["best"].mean()


def _scale_at(
    references: tuple[pd.Series, dict[str, np.ndarray]], budget: int
) -> dict[str, tuple[float, float]]:
    """(F_ref, F_random(budget) - F_ref) per task where that scale is defined and > 0."""
    f_ref, pools = references
    out = {}
    for task, pool in pools.items():
        finite = pool[np.isfinite(pool)]
        if task not in f_ref.index or finite.size < budget:
            continue
        ref = float(f_ref[task])
        scale = float(expected_best_of_random(finite, np.array([budget]))[0]) - ref
        if scale > 0:
            out[str(task)] = (ref, scale)
    return out


def _pays_after(
    best: pd.DataFrame,
    ref: np.ndarray,
    scale: np.ndarray,
    target: float,
    budget: int,
    episodes: float,
) -> tuple[float, float]:
    """(b, goals): the smallest budget whose mean over tasks on B's scale is <= the target.

    ``best`` has one row per task (in the order of ``ref`` and ``scale``) and one column per
    budget; b is NaN if no budget reaches the target, goals inf if b is NaN or >= B.
    """
    regret = ((best.to_numpy() - ref[:, None]) / scale[:, None]).mean(0)
    reached = np.flatnonzero(regret <= target)
    needed = float(best.columns[reached[0]]) if reached.size else math.nan
    if math.isnan(needed) or needed >= budget:
        return needed, math.inf
    return needed, float(math.ceil(episodes / (budget - needed)))


def amortization_table(
    curves: pd.DataFrame,
    log: pd.DataFrame,
    budgets: Sequence[int],
    *,
    references: tuple[pd.Series, dict[str, np.ndarray]] | None = None,
) -> pd.DataFrame:
    """After how many goals each learned method's training pays for itself against cold CMA-ES.

    Every comparison with cold CMA-ES at budget B is on one scale: a method's best so far at
    any budget b, per task, is normalized by ``F_random(B) - F_ref`` of that task (not by
    ``F_random(b) - F_ref``, which shrinks with b: a worse F at a small b would then look as
    good as a better F at B). On that scale the order of two F values is their order, so
    reaching cold CMA-ES's quality means a lower mean best F, task by task normalized alike.
    The tasks are those where the scale is defined (> 0) and both methods have a value.

    The pooled numbers read the method's mean over its replicates (training seeds) at each
    task; beside them, the range across the replicates: each replicate r's mean over the same
    tasks against the same target (cold CMA-ES's mean over all its replicates), its own
    smallest budget and the goals it implies with replicate r's training episodes. A learned
    designer is trained once per seed, so the range says how much the break-even moves with
    the training seed.

    Args:
        curves: :func:`regret_curves` of the study.
        log: The study's frame (its training episodes give T).
        budgets: The reference budgets B of cold CMA-ES (B = 1 is skipped: nothing to save).
        references: F_ref and the random pool per task (default: the log's own).

    Returns:
        :data:`AMORTIZATION_COLUMNS`, one row per learned method (zero-shot and
        warm-started) and budget B > 1 of cold CMA-ES: ``target_regret`` (cold CMA-ES's mean
        regret at B, on B's scale), ``budget_needed`` (the smallest per-goal budget b at which
        the method's mean regret on B's scale is <= it; NaN if none), ``training_episodes``
        (mean over replicates), ``breakeven_goals`` (inf: never); ``replicates`` (those with a
        value at every task of the row), ``budget_needed_min`` / ``budget_needed_max`` (the
        smallest and largest b of a replicate; NaN: no replicate reaches the target, and the
        largest NaN if one does not) and ``goals_min`` / ``goals_max`` (the fewest and most
        goals of a replicate; inf: never, for every replicate or for one).
    """
    refs = _references(log) if references is None else references
    best = _task_best(curves)
    by_replicate = curves.groupby(["method", "replicate", "task", "evaluation"])["best"].mean()
    training = _training_episodes(log)
    trained = _training_by_replicate(log)
    methods = set(best.index.get_level_values(0))
    columns = list(AMORTIZATION_COLUMNS)
    if "cmaes" not in methods:
        return pd.DataFrame(columns=columns)
    cold = best["cmaes"].unstack("evaluation")
    rows = []
    for base, episodes in sorted(training.items()):
        for method in (base, f"warm-{base}"):
            if method not in methods:
                continue
            mine = best[method].unstack("evaluation")
            replicates = {
                int(r): frame.droplevel("replicate").unstack("evaluation")
                for r, frame in by_replicate[method].groupby(level="replicate")
            }
            for budget in budgets:
                if budget <= 1 or budget not in cold.columns:
                    continue
                scales = _scale_at(refs, int(budget))
                tasks = [
                    t
                    for t in mine.index
                    if t in scales and t in cold.index and math.isfinite(cold.loc[t, budget])
                ]
                if not tasks:
                    continue
                ref = np.array([scales[t][0] for t in tasks])
                scale = np.array([scales[t][1] for t in tasks])
                target = float(np.mean((cold.loc[tasks, budget].to_numpy() - ref) / scale))
                needed, goals = _pays_after(mine.loc[tasks], ref, scale, target, budget, episodes)
                spread = [
                    _pays_after(
                        frame.loc[tasks],
                        ref,
                        scale,
                        target,
                        budget,
                        trained.get((base, r), episodes),
                    )
                    for r, frame in sorted(replicates.items())
                    if set(tasks) <= set(frame.index)
                ]
                each = np.array([b for b, _ in spread], dtype=np.float64)
                each_goals = np.array([g for _, g in spread], dtype=np.float64)
                reached = each[np.isfinite(each)]
                rows.append(
                    {
                        "method": method,
                        "reference_budget": int(budget),
                        "target_regret": target,
                        "budget_needed": needed,
                        "training_episodes": episodes,
                        "breakeven_goals": goals,
                        "replicates": len(spread),
                        "budget_needed_min": float(reached.min()) if reached.size else math.nan,
                        "budget_needed_max": (
                            float(reached.max())
                            if reached.size and reached.size == each.size
                            else math.nan
                        ),
                        "goals_min": float(each_goals.min()) if spread else math.nan,
                        "goals_max": float(each_goals.max()) if spread else math.nan,
                    }
                )
    return pd.DataFrame(rows, columns=columns)


def study_popsize(config: Mapping[str, Any]) -> int:
    """Cold CMA-ES's population size in a study, from its manifest's config (``size.popsize``).

    Raises:
        ValueError: The config records no whole number >= 1 there.
    """
    size = config.get("size")
    value = size.get("popsize") if isinstance(size, Mapping) else None
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(
            f"the study's config has no CMA-ES population size (size.popsize), got {value!r}"
        )
    return value


def _count(value: Any, never: str) -> str:
    """A whole count of the amortization table, or ``never`` for NaN / inf."""
    return f"{float(value):.0f}" if _finite(value) else never


def _span(low: float, high: float, unit: str, never: str) -> str:
    """A range across training seeds: ``21-86 goals``, ``69 goals``, ``21 goals or never``."""
    if not _finite(low):
        return never
    if not _finite(high):
        return f"{low:.0f} {unit} or {never}"
    return f"{low:.0f} {unit}" if high == low else f"{low:.0f}-{high:.0f} {unit}"


def _seed_span(r: Mapping[str, Any]) -> str:
    """The range across training seeds of a row of :func:`amortization_table`, or ``""``."""
    n = int(r["replicates"]) if _finite(r["replicates"]) else 0
    if n <= 1:
        return ""
    low, high = float(r["budget_needed_min"]), float(r["budget_needed_max"])
    if not _finite(low):
        return f"not reached by any of the {n} training seeds"
    goals_span = _span(float(r["goals_min"]), float(r["goals_max"]), "goals", "never")
    needed_span = _span(low, high, "per goal", "not reached")
    return f"across the {n} training seeds: {goals_span}, {needed_span}"


def amortization_cell(r: Mapping[str, Any]) -> str:
    """A row of :func:`amortization_table` in words: goals until it pays, per-goal budget, range.

    ``37 goals (36 per goal; across the 5 training seeds: 23-49 goals, 18-43 per goal)``
    (a range's upper end is "never" / "not reached" when one seed's is);
    ``never (25 per goal; ...)`` when it needs B or more per goal, ``never (quality not
    reached; ...)`` when no budget of the study reaches cold CMA-ES's. The range is left out
    with one training seed (it is the pooled number).

    Args:
        r: A row of ``amortization.csv`` by column (:data:`AMORTIZATION_COLUMNS`).
    """
    needed, goals = float(r["budget_needed"]), float(r["breakeven_goals"])
    if not _finite(needed):
        text = "never (quality not reached"
    elif not _finite(goals):
        text = f"never ({needed:.0f} per goal"
    else:
        text = f"{goals:.0f} goals ({needed:.0f} per goal"
    spread = _seed_span(r)
    return f"{text}; {spread})" if spread else f"{text})"


def amortization_sentence(amortization: pd.DataFrame, *, popsize: int) -> str:
    """The fewest goals after which each learned method's training pays for itself, in words.

    Against cold CMA-ES after it adapts (B above its population size) first; a method that
    pays for itself only at a budget B up to the population size is named apart, "against
    cold CMA-ES before its first update" (there cold CMA-ES's designs are draws from its
    starting Gaussian). ``breakeven.md`` and ``docs/rl.md`` both print this sentence.

    Args:
        amortization: :func:`amortization_table`, or ``amortization.csv`` read back.
        popsize: Cold CMA-ES's population size in the study (:func:`study_popsize`).

    Raises:
        ValueError: ``popsize`` not a whole number >= 1.
    """
    popsize = _whole(popsize, "popsize", 1)
    if len(amortization) == 0:
        return "The study has no learned method or no budget above 1: nothing to amortize."
    records = amortization.to_dict("records")
    methods = list(dict.fromkeys(str(r["method"]) for r in records))

    def fewest(method: str, early: bool) -> str | None:
        paying = [
            r
            for r in records
            if str(r["method"]) == method
            and (int(r["reference_budget"]) <= popsize) is early
            and _finite(float(r["breakeven_goals"]))
        ]
        if not paying:
            return None
        r = min(paying, key=lambda r: (float(r["breakeven_goals"]), int(r["reference_budget"])))
        return f"{method} after {amortization_cell(r)} at B = {int(r['reference_budget'])}"

    later = any(int(r["reference_budget"]) > popsize for r in records)
    after = {m: fewest(m, False) for m in methods}
    before = {m: fewest(m, True) for m in methods if after[m] is None}
    head = (
        "Fewest goals after which the training pays for itself, against cold CMA-ES after it "
        f"adapts (B > {popsize}, its population size): "
    )
    if not later:
        text = head + "no budget of the study is that large"
    else:
        paid = [w for w in after.values() if w is not None]
        text = head + ("; ".join(paid) if paid else "none")
    early = [w for w in before.values() if w is not None]
    if early:
        text += (
            f"; only against cold CMA-ES before its first update (B <= {popsize}, its first "
            "generation of draws): " + "; ".join(early)
        )
    never = [m for m in methods if after[m] is None and before.get(m) is None]
    if never and len(never) < len(methods):
        text += f"; never at any budget: {_listed(never)}"
    elif never:
        text += "; no learned method pays for itself at any budget"
    return text + "."


#: Below this normalized regret the regret figure's y axis is linear, above it logarithmic.
REGRET_LINEAR_BELOW = 0.01


def _regret_figure(table: pd.DataFrame, curves: pd.DataFrame, path: Path) -> Path:
    """Mean (95 % t interval) and median of normalized regret over tasks, per budget.

    The y axis is symlog (linear below :data:`REGRET_LINEAR_BELOW`, logarithmic above): cold
    and warm CMA-ES differ at regrets of a few hundredths while a zero-shot design can be many
    times worse than random sampling; on a linear axis the latter flattens the former into
    the line at 0, and a clipped axis would hide it.
    """
    figure, axes = new_figure_grid(1, 2, (12.0, 4.6))
    medians = _task_means(curves).groupby(["method", "evaluation"])["regret"].median()
    for ax, kind in zip(axes.ravel(), ("mean", "median"), strict=True):
        for method in dict.fromkeys(table["method"]):
            rows = table[table["method"] == method]
            style = "--" if method in ("random", "cmaes") else "-"
            budgets = rows["budget"].to_numpy()
            if kind == "mean":
                ax.plot(budgets, rows["mean"], style, marker="o", label=method)
                ax.fill_between(budgets, rows["ci_low"], rows["ci_high"], alpha=0.15)
            else:
                values = [medians.get((method, int(b)), math.nan) for b in budgets]
                ax.plot(budgets, values, style, marker="o", label=method)
        ax.set_xscale("log", base=2)
        ax.set_yscale("symlog", linthresh=REGRET_LINEAR_BELOW, linscale=0.5)
        ax.set_ylim(bottom=0.0)
        ax.axhline(1.0, color="grey", linewidth=0.8)
        ax.set_xlabel("evaluations per task (budget)")
        ax.set_ylabel(
            f"normalized regret (0 best known, 1 random; log above {REGRET_LINEAR_BELOW:g})"
        )
        title = "mean over tasks, 95 % t interval" if kind == "mean" else "median over tasks"
        ax.set_title(title, fontsize="medium")
    axes.ravel()[0].legend(fontsize="small", ncol=2)
    return save_png(figure, path)


def _amortization_figure(table: pd.DataFrame, path: Path) -> Path:
    """One panel per budget B of cold CMA-ES: total episodes against goals, to its quality."""
    budgets = sorted(set(table["reference_budget"])) if len(table) else []
    ncols = min(3, max(1, len(budgets)))
    nrows = max(1, -(-len(budgets) // ncols))
    figure, axes = new_figure_grid(nrows, ncols, (4.2 * ncols, 3.4 * nrows))
    for ax in axes.ravel()[len(budgets) :]:
        ax.set_visible(False)
    finite = table["breakeven_goals"][np.isfinite(table["breakeven_goals"])] if len(table) else []
    top = max(10.0, 2.0 * float(np.max(finite))) if len(finite) else 1000.0
    goals = np.unique(np.geomspace(1, top, 200).round())
    for ax, budget in zip(axes.ravel(), budgets, strict=False):
        rows = table[table["reference_budget"] == budget]
        ax.plot(goals, goals * budget, "k--", label=f"cold CMA-ES ({budget} per goal)")
        for _, row in rows.iterrows():
            if math.isnan(row["budget_needed"]):
                continue  # never reaches cold CMA-ES's quality at any budget of the study
            total = row["training_episodes"] + goals * row["budget_needed"]
            ax.plot(goals, total, label=f"{row['method']} ({row['budget_needed']:.0f} per goal)")
            if math.isfinite(row["breakeven_goals"]):
                g = float(row["breakeven_goals"])
                ax.plot([g], [g * budget], "o", color=ax.lines[-1].get_color())
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"quality of cold CMA-ES at B = {budget}", fontsize="medium")
        ax.set_xlabel("goals designed for")
        ax.set_ylabel("episodes in total (training included)")
        ax.legend(fontsize="x-small")
    if not budgets:
        axes[0, 0].set_title("no budget above 1: nothing to amortize")
    return save_png(figure, path)


def _cell(mean: float, low: float, high: float) -> str:
    if not math.isfinite(mean):
        return "n/a"
    if not (math.isfinite(low) and math.isfinite(high)) or low == high:
        return f"{mean:.3f}"
    return f"{mean:.3f} [{low:.3f}, {high:.3f}]"


def results_rows(table: pd.DataFrame) -> list[list[str]]:
    """The results table's rows: a method, then mean [95 % interval] per budget."""
    budgets = sorted(set(table["budget"]))
    rows = []
    for method in dict.fromkeys(table["method"]):
        mine = table[table["method"] == method].set_index("budget")
        rows.append(
            [
                str(method),
                *(
                    _cell(*(float(mine.loc[b, k]) for k in ("mean", "ci_low", "ci_high")))
                    if b in mine.index
                    else ""
                    for b in budgets
                ),
            ]
        )
    return rows


def score_row(name: str, table: pd.DataFrame) -> str:
    """One Markdown row of the results table, for a method scored by ``tooldesign rl score``."""
    rows = results_rows(table.assign(method=name))
    return "| " + " | ".join(rows[0]) + " |"


def _failed_counts(log: pd.DataFrame) -> dict[str, int]:
    """Failed evaluations (an error in the simulation) per ``"<variant> <method>"``."""
    failed = log[log["status"] == "failed"]
    counts = failed.groupby(["variant", "method"], sort=True).size()
    return {f"{variant} {method}": int(n) for (variant, method), n in counts.items()}


def _failed_sentence(failed: dict[str, int]) -> str:
    """The page's line on failed evaluations: a study that went on past errors says so."""
    if not failed:
        return "No evaluation failed."
    total = sum(failed.values())
    where = ", ".join(f"{name} {n}" for name, n in failed.items())
    return (
        f"**{total} evaluation(s) failed** (an error in the simulation; each is counted as an "
        f"unusable design at its task, against its method; messages in `failures/`): {where}. "
        "Many failures of one method are a fault to fix before its rows are read."
    )


def _pair_row(r: Any) -> list[Any]:
    """A row of the secondary table: one pair of methods at one budget (Holm per budget)."""
    interval = f"[{r.ci_low:.3f}, {r.ci_high:.3f}]" if math.isfinite(r.ci_low) else "n/a"
    p_holm = f"{r.p_holm:.3g}" if math.isfinite(r.p_holm) else "n/a"
    diff = f"{r.mean_diff:.3f}" if math.isfinite(r.mean_diff) else "n/a"
    return [int(r.budget), r.a, r.b, int(r.n), diff, interval, p_holm]


#: The verdict table's header, one row per warm-started method and budget (:func:`verdict_row`).
VERDICT_HEADER: tuple[str, ...] = (
    "budget",
    "warm-started",
    "pairs (tasks)",
    "mean warm - cold (floors)",
    "95 % interval",
    "median (floors)",
    "training seeds better / worse beyond",
    "p better (Holm)",
    "p worse (Holm)",
    "warm beats cold",
    "warm worse than cold",
)


def _finite(value: Any) -> bool:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        return False
    return math.isfinite(float(value))


def _decision(value: Any, column: str) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, str) and value in ("True", "False"):
        return value == "True"
    raise ValueError(f"{column} must be True or False, got {value!r}")


def beats_cold_value(value: Any) -> bool:
    """A stored ``beats_cold`` decision: a boolean, or ``"True"``/``"False"`` as read from CSV.

    Raises:
        ValueError: Anything else (an empty cell, NaN, a number, another word): a table that
            is not the report's must not be read as a decision.
    """
    return _decision(value, "beats_cold")


def worse_than_cold_value(value: Any) -> bool:
    """A stored ``worse_than_cold`` decision, read as :func:`beats_cold_value` reads its own.

    Raises:
        ValueError: Anything but a boolean or ``"True"``/``"False"``.
    """
    return _decision(value, "worse_than_cold")


def _whole(value: Any, name: str, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise ValueError(f"{name} must be a whole number >= {least}, got {value!r}")
    return int(value)


def verdict_row(r: Mapping[str, Any]) -> list[str]:
    """A row of the verdict table (:data:`VERDICT_HEADER`), from a row of :func:`warm_cold_table`.

    Args:
        r: A row of ``warm_vs_cold.csv`` by column (:data:`WARM_COLD_COLUMNS`).

    Raises:
        ValueError: Its ``beats_cold`` or ``worse_than_cold`` is not a decision
            (:func:`beats_cold_value`).
    """
    low, high = r["ci_low"], r["ci_high"]
    interval = (
        f"[{low:.2f}, {high:.2f}]" if _finite(low) and _finite(high) and low != high else "n/a"
    )

    def number(key: str, spec: str) -> str:
        return format(r[key], spec) if _finite(r[key]) else "n/a"

    return [
        str(int(r["budget"])),
        str(r["method"]),
        f"{int(r['pairs'])} ({int(r['tasks'])})",
        number("mean_floors", ".2f"),
        interval,
        number("median_floors", ".2f"),
        f"{int(r['replicates_beyond'])} / {int(r['replicates_worse'])} of {int(r['replicates'])}",
        number("p_holm", ".3g"),
        number("p_worse_holm", ".3g"),
        "yes" if beats_cold_value(r["beats_cold"]) else "no",
        "yes" if worse_than_cold_value(r["worse_than_cold"]) else "no",
    ]


def verdict_markdown(verdict: pd.DataFrame) -> list[str]:
    """The verdict table's lines, by budget then method (:data:`VERDICT_HEADER`)."""
    rows = verdict.sort_values(["budget", "method"], kind="stable").to_dict("records")
    return markdown_table(VERDICT_HEADER, [verdict_row(r) for r in rows])


def _listed(items: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    if len(items) <= 1:
        return "".join(items)
    return f"{', '.join(items[:-1])} and {items[-1]}"


def _at(budgets: Iterable[int]) -> str:
    """``budget 4`` or ``budgets 1, 2 and 4``."""
    ordered = sorted(set(budgets))
    return f"budget{'s' if len(ordered) > 1 else ''} {_listed([str(b) for b in ordered])}"


def before_first_update(popsize: int) -> str:
    """How the verdict and the amortization name budgets up to cold CMA-ES's population size.

    Up to ``popsize`` evaluations, cold CMA-ES has not updated its search distribution: its
    designs are draws from its starting Gaussian (its first generation).

    Raises:
        ValueError: ``popsize`` not a whole number >= 1.
    """
    popsize = _whole(popsize, "popsize", 1)
    return f"before cold CMA-ES's first update (its first generation of {popsize} draws)"


#: How the verdict names budgets above cold CMA-ES's population size.
AFTER_FIRST_UPDATE = "after cold CMA-ES adapts"


def verdict_test_text(replicates: int, tests: int, *, popsize: int) -> str:
    """What the verdict's test is, in words: ``breakeven.md`` and ``docs/rl.md`` say it alike.

    Args:
        replicates: The study's replicates (training seeds), >= 1.
        tests: The tests of the family (rows of :func:`warm_cold_table` with a p), >= 0.
        popsize: Cold CMA-ES's population size in the study (its config's ``size.popsize``).

    Raises:
        ValueError: ``replicates`` or ``popsize`` < 1, or ``tests`` < 0.
    """
    replicates = _whole(replicates, "replicates", 1)
    tests = _whole(tests, "tests", 0)
    popsize = _whole(popsize, "popsize", 1)
    seeds = f"{replicates} training seed{'s' if replicates > 1 else ''}"
    text = (
        "Per pair (task, replicate: the warm-started and the cold CMA-ES run share the CMA-ES "
        "seed), best F so far at the budget, warm minus cold, in noise floors of the task (< 0: "
        "warm is better). The unit of the test is the task (a task's replicates share its goal "
        "and mass): the one-sided Wilcoxon signed-rank test over the tasks, each the mean of its "
        "pairs, that warm's F is lower than cold's by more than one floor (the task means + 1 "
        "below 0), Holm-corrected over every row of the table (one family); warm beats cold "
        f"where Holm p < {ALPHA:g}. The mirror test, for harm: the one-sided Wilcoxon test over "
        "the tasks that warm's F is higher than cold's by more than one floor (the task means - 1 "
        "above 0), Holm-corrected over the same rows as a family of its own; warm is worse than "
        f"cold where that Holm p < {ALPHA:g}. A row of fewer than 2 tasks is not tested. The "
        "tasks are new, the designers are not drawn anew for each: replicate k's designer, "
        "trained once with seed k, designs at every task, so the verdict is about the study's "
        f"trained designers ({seeds}) on new tasks and leaves out the variance between training "
        'seeds. The check of agreement across training seeds is beside it: "training seeds '
        'better / worse beyond", how many replicates have their mean over tasks below -1 floor '
        "(warm better beyond the floor for that trained designer) and above +1 floor (worse "
        "beyond it)"
    )
    smallest = 0.5**replicates
    if tests and smallest * tests >= ALPHA:
        text += (
            f"; a test over the {seeds} could not pass the family's correction (its smallest "
            f"one-sided p, 1 / 2^{replicates} = {smallest:.3g}, times the {tests} tests is not "
            f"below {ALPHA:g})"
        )
    return (
        text + ". Effect size: the mean over tasks with its 95 % t interval over tasks, and the "
        f"median over the pairs. Up to {popsize} evaluations (the study's CMA-ES population "
        "size) cold CMA-ES has not updated yet: its designs are draws from its starting "
        "Gaussian, so at those budgets warm is compared with a baseline that has not adapted; "
        "at budget 1 the warm run is its zero-shot design (its first evaluation)."
    )


def _seeds_count(rows: Sequence[Mapping[str, Any]], key: str) -> str:
    """``5 of 5`` or ``5 of 5 and 4 of 5``: a count of training seeds per row."""
    return _listed([f"{int(r[key])} of {int(r['replicates'])}" for r in rows])


def _with_seeds(methods: Sequence[str], rows: Sequence[Mapping[str, Any]]) -> str:
    """``a and b, each with 5 of 5 training seeds beyond the floor`` (or the counts in order)."""
    counts = [f"{int(r['replicates_beyond'])} of {int(r['replicates'])}" for r in rows]
    if len(set(counts)) == 1:
        each = "each with" if len(methods) > 1 else "with"
        return f"{_listed(methods)}, {each} {counts[0]} training seeds beyond the floor"
    return (
        f"{_listed(methods)}, with {_listed(counts)} training seeds beyond the floor respectively"
    )


def _harm(method: str, budget: int, r: Mapping[str, Any]) -> str:
    """``warm-ppo at 16 (+2.87 floors; 4 of 5 training seeds worse beyond the floor)``."""
    return (
        f"{method} at {budget} ({float(r['mean_floors']):+.2f} floors; "
        f"{_seeds_count([r], 'replicates_worse')} training seeds worse beyond the floor)"
    )


def _worse_words(tested: Mapping[tuple[str, int], Mapping[str, Any]]) -> str:
    """The mirror test's sentence: the rows where warm is worse beyond the floor, or none.

    Without one, it names the rows whose mean is more than one floor on cold's side all the
    same: harm that the test over tasks does not establish is still shown.
    """
    rows = sorted(((b, m), r) for (m, b), r in tested.items() if _finite(r["p_worse_holm"]))
    if not rows:
        return ""
    worse = [_harm(m, b, r) for (b, m), r in rows if worse_than_cold_value(r["worse_than_cold"])]
    if worse:
        return (
            "Warm-started CMA-ES is worse than cold CMA-ES beyond the noise floor (the mirror "
            f"test, Holm p < {ALPHA:g}): {_listed(worse)}."
        )
    words = (
        "No warm-started designer is worse than cold CMA-ES beyond the noise floor at any budget "
        f"tested (the mirror test: Holm p >= {ALPHA:g} in "
        + (f"all {len(rows)} tests" if len(rows) > 1 else "its one test")
        + ")"
    )
    above = [
        _harm(m, b, r)
        for (b, m), r in rows
        if _finite(r["mean_floors"]) and float(r["mean_floors"]) > 1.0
    ]
    if above:
        words += (
            "; warm's mean over tasks is more than one floor above cold's, without a significant "
            f"test, for {_listed(above)}"
        )
    return words + "."


def verdict_sentence(
    verdict: pd.DataFrame, *, budgets: Iterable[int], methods: Iterable[str], popsize: int
) -> str:
    """Which budgets a warm-started designer beats cold CMA-ES at, in words, from the table.

    The wins are grouped by budget and told apart by cold CMA-ES's state: at budgets up to its
    population size it has not updated yet (:func:`before_first_update`), above it it has
    (:data:`AFTER_FIRST_UPDATE`). A second sentence names the rows where warm is worse than
    cold beyond the floor (the mirror test), or says that none is, and names the rows whose
    mean is more than one floor on cold's side without a significant test.

    Only a row with a finite Holm p is a test; every (warm-started method, budget) of the study
    without one is named apart as not tested. ``breakeven.md`` and ``docs/rl.md`` both print
    these words.

    Args:
        verdict: :func:`warm_cold_table`, or ``warm_vs_cold.csv`` read back.
        budgets: The study's budgets (its config's), tested or not.
        methods: The study's methods (its config's): its cold CMA-ES (``cmaes``) and its
            warm-started ones (``warm-*``).
        popsize: Cold CMA-ES's population size in the study (its config's ``size.popsize``).

    Raises:
        ValueError: A ``beats_cold`` or ``worse_than_cold`` that is not a decision
            (:func:`beats_cold_value`), or ``popsize`` not a whole number >= 1.
    """
    before = before_first_update(popsize)
    methods = [str(m) for m in methods]
    decisions = [beats_cold_value(v) for v in verdict["beats_cold"]]
    if "cmaes" not in methods:
        return (
            "**Verdict:** the study has no cold CMA-ES run (method `cmaes`) to compare the "
            "warm-started designers with: it does not say whether one beats cold CMA-ES."
        )
    warm = sorted({m for m in methods if m.startswith("warm-")} | set(map(str, verdict["method"])))
    if not warm:
        return (
            "**Verdict:** the study has no warm-started designer (a `warm-` method) to compare "
            "with cold CMA-ES: it does not say whether one beats it."
        )
    study = sorted({int(b) for b in budgets} | {int(b) for b in verdict["budget"]})
    rows = {
        (str(r["method"]), int(r["budget"])): (r, won)
        for r, won in zip(verdict.to_dict("records"), decisions, strict=True)
    }
    tested = {key: v for key, v in rows.items() if _finite(v[0]["p_holm"])}
    untested = [(m, b) for m in warm for b in study if (m, b) not in tested]
    won_by_budget: dict[int, list[str]] = {}
    for (m, b), (_, decision) in sorted(tested.items(), key=lambda item: (item[0][1], item[0][0])):
        if decision:
            won_by_budget.setdefault(b, []).append(m)
    tested_budgets = {b for _, b in tested}
    if won_by_budget:
        parts = []
        for label, early in ((before, True), (AFTER_FIRST_UPDATE, False)):
            phase = sorted(b for b in tested_budgets if (b <= popsize) is early)
            if not phase:
                continue
            won = [b for b in phase if b in won_by_budget]
            lost = [b for b in phase if b not in won_by_budget]
            if not won:
                parts.append(f"{label}, at {_at(lost)} none of the designers tested does")
                continue
            details = "; ".join(
                f"at {b}{', where the warm run is its zero-shot design' if b == 1 else ''}: "
                + _with_seeds(won_by_budget[b], [tested[(m, b)][0] for m in won_by_budget[b]])
                for b in won
            )
            text = f"{label}, at {_at(won)} ({details})"
            if lost:
                text += f", while at {_at(lost)} none of the designers tested does"
            parts.append(text)
        words = (
            "**Verdict:** warm-started CMA-ES beats cold CMA-ES beyond the noise floor (Holm p "
            f"< {ALPHA:g}, over the tasks, for the study's trained designers) " + "; ".join(parts)
        )
        if set(won_by_budget) == set(study):
            words += "; that is every budget of the study"
    elif tested:
        p_min, method, budget = min((float(r["p_holm"]), m, b) for (m, b), (r, _) in tested.items())
        if len(tested) > 1:
            which = f"in all {len(tested)} tests; the smallest, {p_min:.3g}, is {method}'s"
        else:
            which = f"in its one test ({p_min:.3g}, {method}'s)"
        words = (
            "**Verdict:** no warm-started designer beats cold CMA-ES beyond the noise floor at "
            f"any budget tested ({_listed([str(b) for b in sorted(tested_budgets)])}): Holm p >= "
            f"{ALPHA:g} {which} at budget {budget}"
        )
    else:
        words = (
            "**Verdict:** no test was made, so the study does not say whether a warm-started "
            "designer beats cold CMA-ES"
        )
    if untested:
        by_method: dict[str, list[int]] = {}
        for m, b in untested:
            by_method.setdefault(m, []).append(b)
        words += "; not tested (fewer than 2 tasks with both runs): " + "; ".join(
            f"{m} at {_listed([str(b) for b in bs])}" for m, bs in by_method.items()
        )
    harm = _worse_words({key: r for key, (r, _) in tested.items()})
    return f"{words}. {harm}" if harm else f"{words}."


def make_breakeven_report(
    run_folder: str | os.PathLike[str],
    *,
    out_dir: str | os.PathLike[str] | None = None,
    floor_fraction: float | None = None,
) -> list[Path]:
    """Write the study's report from its stored files: tables, tests, amortization, figures.

    Args:
        run_folder: A break-even run folder (:func:`benchmarks.rl.breakeven.run_breakeven`).
        out_dir: Where to write (default ``<run_folder>/report``).
        floor_fraction: The least noise floor as a fraction of |F_ref| (default:
            :func:`noise_floor_fraction`, the project's median relative floor); each task's
            floor is the larger of it and the task's measured range (:func:`task_floors`).

    Returns:
        The files written: ``breakeven.md``, ``regret.csv``, ``noise_floors.csv`` (each task's
        floor), ``warm_vs_cold.csv`` (the verdict), ``comparisons.csv`` (every pair,
        secondary), ``amortization.csv``, ``regret.png``, ``amortization.png`` and ``summary.json``.

    Raises:
        ValueError: not a break-even run folder, or nothing to report.
    """
    from benchmarks.rl.breakeven import load_breakeven, noise_floors

    folder = Path(run_folder)
    log = load_breakeven(folder)
    budgets, methods, config = _study_budgets(folder)
    curves = regret_curves(log, max(budgets))
    table = regret_table(curves, budgets, methods)
    tests = comparison_table(curves, budgets)
    references = study_references(log)
    amortization = amortization_table(curves, log, budgets, references=references)
    fraction = noise_floor_fraction() if floor_fraction is None else floor_fraction
    floors = task_floors(references[0], noise_floors(log), floor_fraction=fraction)
    verdict = warm_cold_table(curves, budgets, floors=floors["floor"])
    target = Path(out_dir) if out_dir is not None else folder / REPORT_DIR
    target.mkdir(parents=True, exist_ok=True)
    written = [
        atomic_write_text(target / "regret.csv", csv_text(table)),
        atomic_write_text(target / "noise_floors.csv", csv_text(floors.reset_index(drop=True))),
        atomic_write_text(target / "warm_vs_cold.csv", csv_text(verdict)),
        atomic_write_text(target / "comparisons.csv", csv_text(tests)),
        atomic_write_text(target / "amortization.csv", csv_text(amortization)),
        _regret_figure(table, curves, target / "regret.png"),
        _amortization_figure(amortization, target / "amortization.png"),
    ]
    tasks = config["tasks"]
    replicates = int(config["size"]["replicates"])
    popsize = study_popsize(config)
    tests_made = int(np.isfinite(verdict["p_holm"].to_numpy(dtype=np.float64)).sum())
    scenes = config["size"].get("floor_scenes", "no")
    measured = int((floors["noise_range"] > floors["least_floor"]).sum())
    failed = _failed_counts(log)
    page = [
        f"# Break-even study ({config['size']['name']})",
        "",
        f"{len(tasks)} tasks ({sum(t['set'] == 'held-out' for t in tasks)} held-out instances "
        f"of the protocol, the rest fresh), {config['size']['replicates']} replicate(s), "
        f"budgets {', '.join(map(str, budgets))}; {len(log):,} evaluations in "
        "`evaluations.parquet`.",
        "",
        _failed_sentence(failed),
        "",
        "## Normalized regret (mean over tasks, 95 % t interval)",
        "",
        *markdown_table(["method", *(str(b) for b in budgets)], results_rows(table)),
        "",
        "![normalized regret](regret.png)",
        "",
        "## Does warm-started CMA-ES beat cold CMA-ES?",
        "",
        f"The noise floor of a task is the larger of the range of F of the task's reference "
        f"design (the best of its cold CMA-ES runs) over {scenes} nudged scenes and "
        f"{fraction:.4g} x |F_ref| (the project's median relative floor), as the benchmark "
        f"protocol sets a cell's ({measured} of {len(floors)} tasks measured above it; "
        "`noise_floors.csv`). " + verdict_test_text(replicates, tests_made, popsize=popsize),
        "",
        *verdict_markdown(verdict),
        "",
        f"{verdict_sentence(verdict, budgets=budgets, methods=methods, popsize=popsize)} "
        "Table: `warm_vs_cold.csv`.",
        "",
        "## Secondary: every pair of methods, each budget apart",
        "",
        "Not the verdict: normalized regret, the Wilcoxon signed-rank test over tasks, Holm "
        "over the pairs of one budget only (no correction across budgets, no noise floor). "
        "mean a - b < 0: a is better. Table: `comparisons.csv`.",
        "",
        *markdown_table(
            ["budget", "a", "b", "tasks", "mean a - b", "95 % interval", "p (Holm, per budget)"],
            [_pair_row(r) for r in tests.itertuples()],
        ),
        "",
        "## Amortization (against cold CMA-ES)",
        "",
        "The target is cold CMA-ES's mean regret at B over all its replicates; the budget "
        "needed and the goals are the method's mean over its replicates (training seeds), and "
        "beside them the range of each training seed's own (its mean over the same tasks "
        "against the same target). Table: `amortization.csv`.",
        "",
        *markdown_table(
            [
                "method",
                "cold budget B",
                "target regret",
                "budget needed",
                "training",
                "goals",
                "across training seeds",
            ],
            [
                [
                    r["method"],
                    int(r["reference_budget"]),
                    f"{r['target_regret']:.3f}",
                    _count(r["budget_needed"], "not reached"),
                    f"{r['training_episodes']:.0f}",
                    _count(r["breakeven_goals"], "never"),
                    _seed_span(r),
                ]
                for r in amortization.to_dict("records")
            ],
        ),
        "",
        amortization_sentence(amortization, popsize=popsize),
        "",
        "![amortization](amortization.png)",
        "",
    ]
    summary = {
        "size": config["size"]["name"],
        "evaluations": len(log),
        "noise_floor_fraction": fraction,
        "failed": failed,
        "noise_floors": cast("list[dict[str, Any]]", floors.to_dict("records")),
        "regret": cast("list[dict[str, Any]]", table.to_dict("records")),
        "warm_vs_cold": cast("list[dict[str, Any]]", verdict.to_dict("records")),
        "amortization": cast("list[dict[str, Any]]", amortization.to_dict("records")),
    }
    written.append(atomic_write_text(target / "summary.json", json_text(summary)))
    written.append(atomic_write_text(target / "breakeven.md", "\n".join(page)))
    return written
