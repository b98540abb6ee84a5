"""Write docs/reproduction.md: the paper's claims next to the committed results, with their noise.

One command rebuilds every suite's report from its stored results (nothing is simulated) and
then the page, whose every number is read from those files::

    tooldesign reproduce [--results docs/results] [--out docs/reproduction.md] [--protocol DIR]

The results are made by ``tooldesign bench SUITE --size full --out docs/results/SUITE`` and
``tooldesign retest docs/results/SUITE`` for the suites of :data:`SUITES`; claim (a) is judged
again under the benchmark protocol from ``docs/results/protocol-full`` (:data:`PROTOCOL_FOLDER`)
by :mod:`benchmarks.protocol.claims`, a layer above this module, which hands the page its
section (:class:`ClaimSection`). A claim's verdict
follows one rule everywhere: a difference counts when its 95 % interval (or its Holm-corrected
test) excludes zero AND it is larger than the noise floor of the quantity (its median range over
scenes whose box starts at most 0.1 mm and 1e-4 rad away, which move the box's final position by
millimetres: see :func:`motion_figures`); a rank correlation counts when p < 0.05.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats as sstats

from benchmarks.reports.comparison import (
    MIN_INTERVAL_VALUES,
    beyond_noise_cell,
    interval_bounds,
    no_interval_note,
    percent_cell,
)
from benchmarks.reports.retest import (
    MISSING_METRIC_NOTE,
    STRESS_METRICS,
    design_means,
    noise_floor,
    short_intervals,
    stress_repeats,
    stress_table,
    unmeasured_noise,
)
from benchmarks.reports.stats import t_interval
from benchmarks.reports.success import (
    SuccessRate,
    success_cell,
    success_sentence,
    task_tolerance,
)
from benchmarks.reports.suite import designs_table
from benchmarks.storage import (
    read_designs,
    read_manifest,
    read_retests,
    read_run_file,
    with_added_fields,
)
from benchmarks.storage.runfolder import read_report_file
from benchmarks.suites.config import ADDED_FIELDS
from tooldesign_env.schema import ROBUSTNESS_METRICS

__all__ = [
    "PROTOCOL_FOLDER",
    "SUITES",
    "ClaimSection",
    "motion_figures",
    "protocol_not_tested",
    "reproduction_page",
]

SUITES = ("optimizers", "precision-sweep", "mass-perturbation", "robustness", "robust-design")

#: The protocol run folder under the results that claim (a) is judged under again
#: (``tooldesign bench protocol --size full --out docs/results/protocol-full``, docs/protocol.md).
PROTOCOL_FOLDER = "protocol-full"

#: The first cells of claim (a)'s two rows in the summary table: the 10-seed suite's judgement
#: and the protocol's, each labelled with what it rests on.
CLAIM_A_ROW = "| (a) CMA-ES lowers F fastest, 10 seeds of the `optimizers` suite (one goal, d = 3)"
PROTOCOL_ROW = "| (a) CMA-ES lowers F fastest, under the benchmark protocol"
PROTOCOL_HEADING = "## (a) under the benchmark protocol"


@dataclasses.dataclass(frozen=True, kw_only=True)
class ClaimSection:
    """A claim judged from results this module does not read (the protocol's run folder).

    :mod:`benchmarks.protocol.claims` makes the one of claim (a) under the protocol; the page
    shows it as a row of its summary table and a section.

    Attributes:
        cell: The summary table's "here" cell: what the results show, in short.
        verdict: The verdict cell, opening with the page's words (``**holds**``, ...).
        lines: The section's Markdown lines, its heading first.
        made_by: Commands for "How the results were made" (none when nothing was run).
    """

    cell: str
    verdict: str
    lines: tuple[str, ...]
    made_by: tuple[str, ...] = ()


def protocol_not_tested(reason: str) -> ClaimSection:
    """Claim (a) under the protocol, not tested: ``reason`` says why; the section says how.

    Args:
        reason: Why it was not judged, a clause (``"no protocol run folder ..."``).
    """
    command = (
        f"tooldesign bench protocol --size full --with-references --out docs/results/"
        f"{PROTOCOL_FOLDER}"
    )
    return ClaimSection(
        cell="no protocol run",
        verdict=f"**not tested**: {reason}",
        lines=(
            PROTOCOL_HEADING,
            "",
            f"**Not tested**: {reason}. The benchmark protocol's `full` run of the built-in "
            "optimizers (its instances, dimensions, seeds and budgets: [The benchmark protocol]"
            f"(protocol.md#sizes)) is made by `{command}` (hours on 2 cores; run it again "
            "after an interruption, it resumes). `tooldesign reproduce` then judges the claim "
            "here from its report, per dimension and pooled, by the rule of [The benchmark "
            "protocol](protocol.md#claim-a-on-the-reproduction-page); `tooldesign reproduce "
            "--protocol DIR` judges it from another protocol run folder (a `quick` one, say).",
        ),
    )


#: The folder under the results that holds the suites of :data:`SUITES` run with the paper's
#: square tool section (``section_shape = "square"``, the default before the round one,
#: docs/model.md), one folder each as at the top. Reported when present.
SQUARE = "square"


def _where(folder: Path) -> str:
    """A suite folder's path under docs/results (``optimizers`` or ``square/optimizers``)."""
    return f"{SQUARE}/{folder.name}" if folder.parent.name == SQUARE else folder.name


def _fmt(value: float, digits: int = 4) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{value:.{digits}g}"


def _suite_file(folder: Path, relative: str) -> bytes | None:
    """A file of a suite folder (a regular file inside it, no link followed), None if absent.

    A report file (``report/summary.csv``) is used only as ``tooldesign report`` wrote it: one
    that differs from the checksum the manifest records, or that it does not record, is
    refused (after the warning of :func:`benchmarks.storage.runfolder.read_report_file`), as
    the claims it feeds cannot be made without it.
    """
    if not os.path.lexists(folder / relative):
        return None
    if relative.startswith("report/"):
        data = read_report_file(folder, relative)
        if data is None:
            raise ValueError(
                f"{folder / relative} is not as tooldesign report wrote it (see the warning), "
                f"and the page needs it: run tooldesign report {folder}, or reproduce without "
                "--skip-reports"
            )
        return data
    return read_run_file(folder, relative)


def _suite_json(folder: Path, relative: str) -> Any:
    data = _suite_file(folder, relative)
    return None if data is None else json.loads(data.decode("utf-8"))


def _read_csv(folder: Path, relative: str) -> pd.DataFrame:
    data = _suite_file(folder, relative)
    return pd.DataFrame() if data is None else pd.read_csv(io.BytesIO(data))


def _spearman(x: Any, y: Any) -> tuple[float, float, int]:
    a, b = np.asarray(x, float), np.asarray(y, float)
    keep = np.isfinite(a) & np.isfinite(b)
    if keep.sum() < 3:
        return math.nan, math.nan, int(keep.sum())
    result = sstats.spearmanr(a[keep], b[keep])
    return float(result.statistic), float(result.pvalue), int(keep.sum())


def _paired_difference(
    a: pd.DataFrame, b: pd.DataFrame, metric: str
) -> tuple[float, float, float, int]:
    """Mean over shared goals of a's metric minus b's, with a 95 % paired t interval.

    The objectives of the robustness suite are run on the same goals, so each goal gives one
    paired difference (per optimizer, when a suite has several: their designs are not repeats
    of one another); a goal that either side lacks (a design that failed its retest, a missing
    metric) is left out of both, and a side with several designs for one goal (variants that
    share a label) enters with their mean. Returns ``(mean, low, high, n)`` with n the pairs;
    fewer than 2 give no interval (NaN bounds), no spread gives a zero-width one.
    """
    keys = ["goal_key", "optimizer"]
    sides = [side.groupby(keys, as_index=False)[metric].mean() for side in (a, b)]
    pairs = sides[0].merge(sides[1], on=keys, suffixes=("_a", "_b"))
    ci = t_interval((pairs[f"{metric}_a"] - pairs[f"{metric}_b"]).to_numpy(dtype=np.float64))
    if ci.n < MIN_INTERVAL_VALUES:
        # One pair has no spread: an interval would claim a certainty that one goal cannot give.
        return ci.estimate, math.nan, math.nan, ci.n
    return ci.estimate, ci.low, ci.high, ci.n


def _verdict_difference(low: float, high: float, diff: float, floor: float) -> bool:
    return (low > 0 or high < 0) and abs(diff) > (floor if math.isfinite(floor) else 0.0)


def _comparison_noise(
    pure: float, other: float, label: str, first: str = "pure confidence"
) -> tuple[float, str]:
    """The noise a difference of claim (c) must exceed: the larger of the two rows' noise.

    A row whose noise was not measured (NaN) does not count (``max(nan, x)`` would depend on
    the order of its arguments); the second value says which was missing, for the table, or
    is empty. With neither measured the noise is 0: the interval alone decides.
    """
    known = [v for v in (pure, other) if math.isfinite(v)]
    missing = [name for name, v in ((first, pure), (label, other)) if not math.isfinite(v)]
    if len(missing) == 2:
        return 0.0, "noise not measured"
    note = f"noise of {missing[0]} not measured" if missing else ""
    return float(max(known)), note


def _success_of_summary_row(row: pd.Series) -> str:
    """The success cell of a ``summary.csv`` row; n/a for a summary written without one."""
    if "success_runs" not in row.index or not math.isfinite(float(row["success_runs"])):
        return "n/a"
    n = int(row["success_runs"])
    return success_cell(
        SuccessRate(
            successes=int(row["successes"]),
            n=n,
            unknown=int(row["runs"]) - n,
            rate=float(row["success_rate"]),
            low=float(row["success_low"]),
            high=float(row["success_high"]),
        )
    )


def _claim_a(folder: Path) -> tuple[str, str, list[str]]:
    summary = _read_csv(folder, "report/summary.csv")
    pairwise = _read_csv(folder, "report/pairwise.csv")
    floor = noise_floor(read_retests(folder))
    runs = int(summary["runs"].max()) if len(summary) else 0
    lines = [
        "## (a) CMA-ES lowers F fastest: 10 seeds of the `optimizers` suite",
        "",
        f"{len(summary)} optimizers, {runs} seeds each, on the suite's one goal "
        f"(`docs/results/{_where(folder)}/report/summary.md`, `pairwise.md`, "
        f"`convergence-{folder.name}.png`). Noise floor of F over the {int(floor['designs'])} "
        f"final designs: {_fmt(floor['free_energy'])} "
        f"({percent_cell(floor['free_energy_relative'])}, median range over nudged scenes, "
        "`noise.md`).",
        "",
        "| optimizer | final F [95 % CI] | success [95 % Wilson CI] | AUC [95 % CI] |",
        "|---|---|---|---|",
    ]
    short = False
    for _, row in summary.iterrows():
        cells = [str(row["optimizer"])]
        for metric in ("final_free_energy", "auc"):
            n = int(row["runs"]) - int(row[f"{metric}_excluded"])
            short |= n < MIN_INTERVAL_VALUES
            bounds = interval_bounds(row[f"{metric}_low"], row[f"{metric}_high"], n, _fmt)
            cells.append(f"{_fmt(row[metric])} {bounds}")
        cells.insert(2, _success_of_summary_row(row))
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", success_sentence("push", task_tolerance())]
    if short:
        lines += ["", no_interval_note("seeds")]
    lines += ["", "| a vs b | metric | mean a - b | beyond noise | p (Holm) | significant |"]
    lines.append("|---|---|---|---|---|---|")
    cmaes_wins: list[str] = []
    cmaes_losses: list[str] = []
    for _, row in pairwise.iterrows():
        lines.append(
            f"| {row['a']} vs {row['b']} | {row['metric']} | {_fmt(row['mean_difference'])} | "
            f"{beyond_noise_cell(row['beyond_noise'])} | {_fmt(row['p_holm'], 3)} | "
            f"{'yes' if row['significant'] else 'no'} |"
        )
        if row["metric"] == "auc" and "cmaes" in (row["a"], row["b"]) and row["significant"]:
            sign = row["mean_difference"] if row["a"] == "cmaes" else -row["mean_difference"]
            (cmaes_wins if sign < 0 else cmaes_losses).append(
                row["b"] if row["a"] == "cmaes" else row["a"]
            )
    others = sorted(set(summary["optimizer"]) - {"cmaes"})
    aucs = summary["auc"] if len(summary) else pd.Series(dtype=np.float64)
    best_auc = summary.loc[aucs.idxmin(), "optimizer"] if aucs.notna().any() else "n/a"
    if cmaes_losses:
        verdict = f"**does not hold**: {', '.join(cmaes_losses)} lower F significantly sooner"
    elif set(cmaes_wins) == set(others):
        verdict = "**holds**: CMA-ES's AUC is significantly lower than every other optimizer's"
    else:
        rest = sorted(set(others) - set(cmaes_wins))
        verdict = (
            f"**not shown**: CMA-ES is not told apart from {', '.join(rest)} "
            f"(lowest mean AUC: {best_auc})"
        )
    summary_cell = (
        f"lowest mean AUC: {best_auc}; CMA-ES significantly faster than "
        f"{', '.join(cmaes_wins) or 'none'}"
    )
    return summary_cell, verdict, lines


def _designs(folder: Path) -> pd.DataFrame:
    return designs_table(read_designs(folder))


#: The shape measures of claim (b), and the sign of their rank correlation with p^X that the
#: claim predicts (tools straighten as p^X grows: the turning angle falls, chord / arc rises).
SHAPE_MEASURES = (
    ("turning_angle", "turning angle (deg)", -1),
    ("straightness", "straightness (chord / arc)", 1),
)


def _trend(rho: float, p: float, expected: int) -> str:
    """``"for"`` a significant trend in the claimed direction, ``"against"`` one the other way."""
    if not (math.isfinite(rho) and math.isfinite(p)) or p >= 0.05 or rho == 0:
        return "none"
    return "for" if rho * expected > 0 else "against"


def _claim_b(folder: Path) -> tuple[str, str, list[str]]:
    """Claim (b) from the tools' shapes alone: where the box ends is claim (d)'s goal error."""
    table = _designs(folder)
    table = table[table["status"] == "ok"]
    low_px, high_px = table["goal_precision"].min(), table["goal_precision"].max()
    lines = [
        "## (b) Low p^X gives curved tools that hold the box; high p^X straighter tools",
        "",
        f"All {len(table)} designs of the robustness suite "
        f"({table['goal_precision'].nunique()} p^X x {table['seed'].nunique()} random goals), "
        f"`docs/results/{_where(folder)}/report/designs.md`; Spearman rank correlation of p^X with "
        "each shape measure (n, p). The claim is about the tool's shape: where the box ends "
        "(nearer the goal as p^X grows) is the goal error of claim (d), and is judged there.",
        "",
        f"| measure | mean at p^X = {_fmt(low_px)} | mean at p^X = {_fmt(high_px)} | rho | p | n "
        "| trend |",
        "|---|---|---|---|---|---|---|",
    ]
    results: dict[str, tuple[float, float, float, float, str]] = {}
    for column, name, expected in SHAPE_MEASURES:
        rho, p, n = _spearman(table["goal_precision"], table[column])
        low = float(table.loc[table["goal_precision"] == low_px, column].mean())
        high = float(table.loc[table["goal_precision"] == high_px, column].mean())
        trend = _trend(rho, p, expected)
        results[column] = (rho, p, low, high, trend)
        said = {"for": "straighter as p^X grows", "against": "*curved* as p^X grows"}
        lines.append(
            f"| {name} | {_fmt(low)} | {_fmt(high)} | {_fmt(rho, 3)} | {_fmt(p, 2)} | {n} | "
            f"{said.get(trend, 'none (p >= 0.05)')} |"
        )
    trends = [r[4] for r in results.values()]
    evidence = "; ".join(
        f"{name.split(' (')[0]} rho {_fmt(results[column][0], 2)}, p {_fmt(results[column][1], 2)}"
        for column, name, _ in SHAPE_MEASURES
    )
    angle = results["turning_angle"]
    # Which end's tools are the straighter on average (a smaller turning angle), significant or not.
    if angle[2] < angle[3]:
        lean = (
            f"; p^X = {_fmt(low_px)} tools are, if anything, slightly straighter (turning angle "
            f"{_fmt(angle[2], 3)} against {_fmt(angle[3], 3)} deg at p^X = {_fmt(high_px)})"
        )
    elif angle[2] > angle[3]:
        lean = (
            f"; p^X = {_fmt(high_px)} tools are slightly straighter on average (turning angle "
            f"{_fmt(angle[3], 3)} against {_fmt(angle[2], 3)} deg), not significantly"
        )
    else:
        lean = ""
    if all(t == "for" for t in trends):
        verdict = f"**holds**: tools straighten as p^X grows ({evidence})"
    elif "for" in trends and "against" not in trends:
        verdict = f"**holds in part**: one shape measure straightens as p^X grows ({evidence})"
    elif "against" in trends and "for" not in trends:
        verdict = f"**reversed**: tools curve *more* as p^X grows ({evidence})"
    elif "against" in trends:
        verdict = f"**not shown**: the shape measures disagree ({evidence})"
    else:
        verdict = f"**not shown**: the shape does not move with p^X ({evidence}){lean}"
    cell = (
        f"turning angle rho = {_fmt(angle[0], 2)} (p {_fmt(angle[1], 2)}), straightness "
        f"rho = {_fmt(results['straightness'][0], 2)} (p {_fmt(results['straightness'][1], 2)})"
    )
    return cell, verdict, lines


def _stress_rows(folder: Path) -> tuple[pd.DataFrame, list[dict[str, Any]]]:
    """Table I over masses of a folder's retests; a noise from one scene is NaN (unmeasured).

    A design's noise is the range of its mean across repeated scenes: the 0 that one scene
    gives is not a measurement, so the page shows n/a and claim (c) treats it as unmeasured.
    """
    retests = read_retests(folder)
    table = stress_table(retests, "mass")  # as stress.md, which the page cites
    if len(table) and stress_repeats(retests, "mass") < 2:
        for metric in (*ROBUSTNESS_METRICS, "final_distance"):
            table[f"{metric}_noise"] = math.nan
    return table, retests


#: The per-design stress metrics, in the stress tables' order.
STRESS_COLUMNS = tuple(metric for metric, _, _ in STRESS_METRICS)


def _design_stress(retests: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """Per retested design: its stress metrics over masses, as the stress tables take them.

    ``goal_key`` names the design's goal, which pairs designs of different objectives.
    """
    rows = []
    for retest in retests:
        means = design_means(retest, "mass")
        if means is not None:
            rows.append(
                {
                    "variant": retest["variant"],
                    "label": retest.get("label") or "",
                    "goal_precision": float(retest["goal_precision"]),
                    "goal_key": tuple(round(float(v), 9) for v in retest["goal"]),
                    "optimizer": str(retest.get("optimizer")),
                    **{m: means[m] for m in STRESS_COLUMNS},
                }
            )
    columns = ["variant", "label", "goal_precision", "goal_key", "optimizer", *STRESS_COLUMNS]
    return pd.DataFrame(rows, columns=columns)


#: Whether a higher value of a stress metric is better (+1) or worse (-1), and its unit.
METRIC_SENSE = {"robustness": (1, "m"), "accuracy": (1, "m"), "control_deviation": (-1, "N m")}


@dataclasses.dataclass(frozen=True)
class Comparison:
    """One objective against another on one stress metric, paired by goal (``a`` minus ``b``).

    ``outcome`` is ``"better"`` or ``"worse"`` (for ``a``) when the difference counts: its 95 %
    paired interval excludes 0 and it exceeds ``noise``, the larger of the two rows' noise;
    ``"none"`` otherwise.
    """

    first: str
    other: str
    metric: str
    diff: float
    low: float
    high: float
    n: int
    noise: float
    unmeasured: str
    outcome: str

    def evidence(self) -> str:
        """``"+1247 N m [425.9, 2069]"``: the difference with its sign, unit and interval."""
        unit = METRIC_SENSE[self.metric][1]
        sign = "+" if self.diff > 0 else ""
        return (
            f"{sign}{_fmt(self.diff)} {unit} {interval_bounds(self.low, self.high, self.n, _fmt)}"
        )


def _compare(
    per_design: pd.DataFrame, rows: pd.DataFrame, first: str, other: str, metric: str
) -> Comparison:
    """``first`` minus ``other`` on ``metric``, paired by goal, judged by the page's rule."""
    diff, low, high, n = _paired_difference(
        per_design[per_design["label"] == first], per_design[per_design["label"] == other], metric
    )
    noise, unmeasured = _comparison_noise(
        float(rows.loc[rows["label"] == first, f"{metric}_noise"].max()),
        float(rows.loc[rows["label"] == other, f"{metric}_noise"].max()),
        other,
        first,
    )
    outcome = "none"
    if _verdict_difference(low, high, diff, noise):
        outcome = "better" if diff * METRIC_SENSE[metric][0] > 0 else "worse"
    return Comparison(first, other, metric, diff, low, high, n, noise, unmeasured, outcome)


def _metric_verdict(first: str, name: str, found: Sequence[Comparison]) -> str:
    """The verdict on "``first`` has the best ``name``" from its comparisons with the others.

    It holds when ``first`` is better beyond the noise than every other objective; it is
    *reversed* when it is worse beyond the noise than some, with those differences stated.
    """
    better = [f for f in found if f.outcome == "better"]
    worse = [f for f in found if f.outcome == "worse"]
    if found and len(better) == len(found):
        return f"**{name} holds**"
    if worse:
        if len(worse) == len(found) > 1:
            against = f"all {len(found)} other objectives"
        else:
            against = ", ".join(f.other for f in worse)
        shown = "; ".join(f"{f.evidence()} against {f.other}" for f in worse)
        return (
            f"**{name} reversed**: {first} is significantly worse, beyond the noise, than "
            f"{against} ({shown})"
        )
    if better:
        return f"**{name} in part**: better only than {', '.join(f.other for f in better)}"
    return f"**{name} not shown**"


def _claim_c(folder: Path, baseline: Path | None) -> tuple[str, str, list[str]]:
    table, retests = _stress_rows(folder)
    per_design = _design_stress(retests)
    labelled = per_design[per_design["label"] != ""]
    settings: dict[str, Any] = retests[0]["settings"] if retests else {"masses": [], "repeats": 0}
    masses = ", ".join(f"{m:g}" for m in settings["masses"])
    lines = [
        "## (c) Pure confidence is the most robust and uses the least control deviation",
        "",
        f"Table I over a range of box masses ({masses} kg, each in {settings['repeats']} nudged "
        "scenes, every altered rollout compared with the nominal one in the same scene; "
        f"`docs/results/{_where(folder)}/report/stress.md`). Mean over goals [95 % t "
        "interval over goals] (median noise of a design's mean across scenes):",
        "",
        "| objective | p^X | robustness (m) | accuracy (m) | control deviation (N m) | "
        "final distance (m) |",
        "|---|---|---|---|---|---|",
    ]
    rows = table[table["label"] != ""] if len(table) else pd.DataFrame(columns=["label"])
    scenes = stress_repeats(retests, "mass")
    if baseline is not None:
        base_table, base_retests = _stress_rows(baseline)
        scenes = min(scenes, stress_repeats(base_retests, "mass"))
        rows = pd.concat([rows, base_table], ignore_index=True)
        per_design = pd.concat([labelled, _design_stress(base_retests)], ignore_index=True)
    else:
        per_design = labelled
    for _, row in rows.iterrows():
        cells = [str(row["label"] or row["variant"]), _fmt(row["goal_precision"])]
        for metric in (*ROBUSTNESS_METRICS, "final_distance"):
            bounds = interval_bounds(
                row[f"{metric}_low"], row[f"{metric}_high"], int(row[f"{metric}_n"]), _fmt
            )
            cells.append(f"{_fmt(row[metric])} {bounds} ({_fmt(row[f'{metric}_noise'], 2)})")
        lines.append("| " + " | ".join(cells) + " |")
    notes = []
    if len(rows) and short_intervals(rows):
        notes.append(no_interval_note("goals"))
    if len(rows) and unmeasured_noise(rows, ROBUSTNESS_METRICS):
        notes.append(
            "A noise of n/a was not measured: the design was rolled out in one scene only "
            "(`tooldesign retest --repeats 1`), and a range across scenes needs 2."
            if scenes < 2
            else MISSING_METRIC_NOTE
        )
    for note in notes:
        lines += ["", note]
    # Pure confidence against each other labelled objective, per metric.
    lines += [
        "",
        "Pure confidence minus the other objective, per metric, paired by goal (the mean "
        "difference over the goals both have a design for, n, with a 95 % paired t interval; "
        "it counts when the interval excludes 0 and the difference exceeds the larger of the "
        "two rows' noise):",
        "",
        "| metric | vs | difference [95 % CI] | n | counts |",
        "|---|---|---|---|---|",
    ]
    others = [lab for lab in per_design["label"].unique() if lab != "pure confidence"]
    found = [
        _compare(per_design, rows, "pure confidence", other, metric)
        for other in others
        for metric in ("robustness", "control_deviation")
    ]
    for f in found:
        short = 0 < f.n < MIN_INTERVAL_VALUES
        lines.append(
            f"| {f.metric.replace('_', ' ')} | {f.other} | {_fmt(f.diff)} "
            f"{interval_bounds(f.low, f.high, f.n, _fmt)} | {f.n} | "
            f"{'yes' if f.outcome != 'none' else 'no'}"
            f"{' (no interval: fewer than 2 shared goals)' if short else ''}"
            f"{' (pure confidence better)' if f.outcome == 'better' else ''}"
            f"{' (pure confidence worse)' if f.outcome == 'worse' else ''}"
            f"{f' ({f.unmeasured})' if f.unmeasured else ''} |"
        )
    parts = [
        _metric_verdict("pure confidence", name, [f for f in found if f.metric == metric])
        for metric, name in (
            ("robustness", "robustness"),
            ("control_deviation", "control deviation"),
        )
    ]
    verdict = "; ".join(parts)
    best = {}
    for metric, pick in (("robustness", "idxmax"), ("control_deviation", "idxmin")):
        if len(rows):
            best[metric] = rows.loc[getattr(rows[metric], pick)(), "label"]
    cell = (
        f"best robustness: {best.get('robustness', 'n/a')}; lowest control deviation: "
        f"{best.get('control_deviation', 'n/a')}"
    )
    return cell, verdict, lines


def _claim_d(folder: Path) -> tuple[str, str, list[str]]:
    per_design = _design_stress(read_retests(folder))
    designs = _designs(folder)
    designs = designs[designs["status"] == "ok"]
    lines = [
        "## (d) As p^X grows, robustness falls and the goal error falls",
        "",
        "Spearman rank correlation with p^X over the robustness suite's designs (robustness: "
        "the design's mean over masses and nudged scenes, `stress.md`; goal error: the "
        "squared goal error of the final test, and the box's final distance to the goal in the "
        "design's own run, `designs.md`):",
        "",
        "| quantity | rho | p | n |",
        "|---|---|---|---|",
    ]
    rob = _spearman(per_design["goal_precision"], per_design["robustness"])
    err = _spearman(designs["goal_precision"], designs["squared_goal_error"])
    near = _spearman(designs["goal_precision"], designs["final_distance"])
    dist = _spearman(per_design["goal_precision"], per_design["final_distance"])
    for name, (rho, p, n) in (
        ("robustness (higher is better)", rob),
        ("squared goal error", err),
        ("final distance to the goal (m)", near),
        ("final distance over the mass range", dist),
    ):
        lines.append(f"| {name} | {_fmt(rho, 3)} | {_fmt(p, 2)} | {n} |")
    rob_falls = rob[0] < 0 and rob[1] < 0.05
    rob_rises = rob[0] > 0 and rob[1] < 0.05
    err_falls = err[0] < 0 and err[1] < 0.05
    nearer = near[0] < 0 and near[1] < 0.05
    verdict = (
        "**"
        + ("goal error falls" if err_falls else "goal error: no significant trend")
        + (" and boxes end nearer the goal" if nearer else "")
        + "; "
        + (
            "robustness falls"
            if rob_falls
            else ("robustness *rises*" if rob_rises else "robustness: no significant trend")
        )
        + "**"
    )
    cell = (
        f"robustness rho = {_fmt(rob[0], 2)}, goal error rho = {_fmt(err[0], 2)}, final "
        f"distance rho = {_fmt(near[0], 2)}"
    )
    return cell, verdict, lines


#: The statement of the paper's Table I judged as claim (e), part by part: (name, metric, the
#: objectives free energy must beat on it).
TABLE_I_PARTS = (
    ("best accuracy", "accuracy", ("pure confidence", "pure performance")),
    ("better robustness than pure performance", "robustness", ("pure performance",)),
    (
        "lower control deviation than pure performance",
        "control_deviation",
        ("pure performance",),
    ),
)

#: The objectives of the paper's Table I, as the robustness suite labels them.
TABLE_I_OBJECTIVES = ("pure confidence", "free energy", "pure performance")


def _claim_e(folder: Path) -> tuple[str, str, list[str]]:
    """Table I's statement on free energy, from the stress tests of claim (c), part by part."""
    table, retests = _stress_rows(folder)
    rows = table[table["label"].isin(TABLE_I_OBJECTIVES)] if len(table) else table
    per_design = _design_stress(retests)
    lines = [
        "## (e) Table I: free energy has the best accuracy, and beats pure performance on "
        "robustness and control deviation",
        "",
        "The paper's Table I, in its words: \"the free energy objective generates tools with the "
        "highest goal accuracy with better robustness and control deviation than the pure "
        'performance objective". Judged on the stress tests of (c) '
        f"(`docs/results/{_where(folder)}/report/stress.md`: the robustness suite's designs of "
        "the three objectives of Table I, on the same goals, over the box masses), free energy "
        "minus the other objective per metric, paired by goal, by the same rule (95 % paired t "
        "interval excluding 0, and the difference larger than the larger of the two rows' "
        "noise):",
        "",
        "| part of the claim | metric | vs | free energy minus it [95 % CI] | n | noise "
        "| outcome |",
        "|---|---|---|---|---|---|---|",
    ]
    labels = set(per_design["label"])
    if not {"free energy", *(o for _, _, vs in TABLE_I_PARTS for o in vs)} <= labels:
        missing = sorted(set(TABLE_I_OBJECTIVES) - labels)
        lines[-2:] = [f"The suite has no designs of {', '.join(missing)}: nothing to compare."]
        return "n/a", f"**not judged**: no designs of {', '.join(missing)}", lines
    said = {"better": "free energy better", "worse": "free energy *worse*", "none": "no difference"}
    parts: list[tuple[str, str, list[Comparison]]] = []
    for name, metric, versus in TABLE_I_PARTS:
        found = [_compare(per_design, rows, "free energy", other, metric) for other in versus]
        for f in found:
            lines.append(
                f"| {name} | {metric.replace('_', ' ')} | {f.other} | {f.evidence()} | {f.n} | "
                f"{_fmt(f.noise, 2)} | {said[f.outcome]}"
                f"{f' ({f.unmeasured})' if f.unmeasured else ''} |"
            )
        if all(f.outcome == "better" for f in found):
            state = "holds"
        elif any(f.outcome == "worse" for f in found):
            state = "reversed"
        else:
            state = "not shown"
        parts.append((name, state, found))
    states = [state for _, state, _ in parts]
    if all(state == "holds" for state in states):
        head = "holds"
    elif all(state == "reversed" for state in states):
        head = "reversed"
    elif "reversed" in states:
        # A part the results contradict is said first, whatever else holds.
        head = "reversed in part" + (", holds in part" if "holds" in states else "")
    elif "holds" in states:
        head = "holds in part"
    else:
        head = "not shown"
    worse = {"better": "", "none": "", "worse": ", free energy worse"}
    detail = "; ".join(
        f"{name} {state} ("
        + ", ".join(f"{f.evidence()} against {f.other}{worse[f.outcome]}" for f in found)
        + ")"
        for name, state, found in parts
    )
    verdict = f"**{head}**: free energy minus the other objective, {detail}"
    best = rows.loc[rows["accuracy"].idxmax(), "label"] if rows["accuracy"].notna().any() else "n/a"
    fe_pp = {f.metric: f for _, _, found in parts for f in found if f.other == "pure performance"}
    cell = (
        f"highest mean accuracy: {best}; free energy minus pure performance: robustness "
        f"{fe_pp['robustness'].evidence()}, control deviation "
        f"{fe_pp['control_deviation'].evidence()}"
    )
    lines += [
        "",
        "Accuracy and robustness are in m (higher is better), control deviation in N m (lower is "
        "better); the means of each objective are in the table of (c).",
    ]
    return cell, verdict, lines


def _seeds(folder: Path) -> str:
    manifest = _suite_json(folder, "manifest.json")
    if manifest is None:
        return "n/a"
    return str(manifest.get("config", {}).get("n_seeds"))


def _run_facts(folder: Path) -> tuple[dict[str, Any], str, str]:
    """A suite folder's config, the short commit it ran with, and whether it was retested."""
    manifest = _suite_json(folder, "manifest.json") or {}
    commit = str(manifest.get("git_commit") or manifest.get("commit") or "n/a")[:7]
    retested = "yes" if (folder / "retest").is_dir() else "no"
    return manifest.get("config", {}), commit, retested


def _arm(config: Mapping[str, Any]) -> str:
    """The arm a suite ran with: a config stored before the hand was merged has 13 links."""
    scene = with_added_fields(config, ADDED_FIELDS)["scene"]
    return "hand merged" if scene.get("merge_fixed_links") else "13 links"


def _suite_rows(results: Path) -> list[str]:
    rows = []
    for suite in SUITES:
        if not (results / suite / "manifest.json").is_file():
            continue
        config, commit, retested = _run_facts(results / suite)
        rows.append(
            f"| {suite} | {config.get('section_shape', 'square')} | {_arm(config)} | "
            f"{config.get('estimator', 'n/a')} | "
            f"{config.get('objective', 'free-energy')} | {config.get('n_seeds', 'n/a')} | "
            f"{config.get('batch_size', 'n/a')} x {config.get('iterations', 'n/a')} | "
            f"{commit} | {retested} |"
        )
    return rows


def _nudges(floors: Iterable[Mapping[str, Any]]) -> str:
    """The scenes each suite's designs were retested in, as the page says it."""
    counts = sorted({int(f["nudges"]) for f in floors if f.get("nudges")})
    return " or ".join(map(str, counts)) if counts else "its"


def _floor_row(suite: str, floor: Mapping[str, Any]) -> str:
    # Designs invalid in a nudged scene count as a range above every measured one.
    unmeasured, failed = (int(floor.get(key) or 0) for key in ("unmeasured", "failed"))
    notes = [f"{unmeasured} unmeasured"] * bool(unmeasured)
    notes += [f"{failed} retests failed, left out"] * bool(failed)
    designs = f"{int(floor['designs'])}" + (f" ({', '.join(notes)})" if notes else "")
    return (
        f"| {suite} | {designs} | {_fmt(floor['free_energy'])} "
        f"({percent_cell(floor['free_energy_relative'])}) | {_fmt(floor['goal_error'])} | "
        f"{_fmt(floor['confidence'])} ({percent_cell(floor['confidence_relative'])}) | "
        f"{_fmt(floor['final_distance'])} |"
    )


def _section_noise(results: Path) -> str:
    """F's relative noise floor with the square section against the round one's, per suite."""
    parts = []
    for suite in SUITES:
        floors = []
        for folder in (results / SQUARE / suite, results / suite):
            floor = _suite_json(folder, "report/noise-floor.json")
            if floor is not None:
                floors.append(floor["all"])
        if len(floors) == 2:
            square, round_ = (percent_cell(f["free_energy_relative"]) for f in floors)
            parts.append(f"{suite} {square} against {round_}")
    return ", ".join(parts) or "n/a (no suite has both)"


TABLE_I_ROW = (
    "| (e) Table I: free energy has the best accuracy and beats pure performance on robustness "
    "and control deviation"
)


def _square_motion(results: Path) -> str:
    """The merged hand's and the nudges' effect on the square section's designs, if measured."""
    figures = _motion(results, "square")
    if figures is None:
        return ""
    return (
        f"; on its {int(figures['designs'])} final designs the nudges move the box's final "
        f"position by a median {_fmt(figures['nudge_median_shift_mm'], 2)} mm (up to "
        f"{_fmt(figures['nudge_max_shift_mm'], 3)} mm), and the merged hand moves F by up to "
        f"{_fmt(figures['merged_max_change'])} ({percent_cell(figures['merged_max_relative'])}"
        f"; `docs/results/{MOTION}/square.csv`; {_reproduced(figures)}: the merged hand is "
        "compared with the 13 links rolled out by the same code, not with the stored numbers)"
    )


def _square_section(results: Path) -> list[str]:
    """The claims again from the suites run with the paper's square section, if present."""
    square = results / SQUARE
    present = [name for name in SUITES if (square / name / "manifest.json").is_file()]
    if not present:
        return []
    rows, details = [], []
    if "optimizers" in present:
        a = _claim_a(square / "optimizers")
        rows.append(f"{CLAIM_A_ROW} | {a[0]} | {a[1]} |")
        details += ["", *a[2]]
    if "robustness" in present:
        baseline = square / "robust-design"
        b = _claim_b(square / "robustness")
        c = _claim_c(square / "robustness", baseline if "robust-design" in present else None)
        d = _claim_d(square / "robustness")
        e = _claim_e(square / "robustness")
        rows += [
            f"| (b) p^X = 0 tools are curved and hold the box; p^X = 50 tools are straighter "
            f"| {b[0]} | {b[1]} |",
            f"| (c) pure confidence has the best robustness and the lowest control deviation "
            f"| {c[0]} | {c[1]} |",
            f"| (d) robustness falls and goal error falls as p^X grows | {d[0]} | {d[1]} |",
            f"{TABLE_I_ROW} | {e[0]} | {e[1]} |",
        ]
        details += ["", *b[2], "", *c[2], "", *d[2], "", *e[2]]
    lines = [
        "## With the paper's square section",
        "",
        "The paper's tool has a square section. Pushing with it is chaotic ([The model]"
        "(model.md#the-tools-section-where-the-chaos-came-from) measures it on random designs); "
        "on the suites' final designs, the median relative range of F under 0.1 mm nudges is, "
        f"square against round: {_section_noise(results)} (the tables of noise floors)"
        f"{_square_motion(results)}. These "
        "suites ran with the square section, the default until the round one "
        f"replaced it, with everything else as above (`docs/results/{SQUARE}/`); they are judged "
        "by the same rules:",
        "",
        "| suite | section | arm | estimator | objective | seeds | batch x iterations | commit "
        "| retested |",
        "|---|---|---|---|---|---|---|---|---|",
        *_suite_rows(square),
        "",
        "| claim of the paper | here, square section | verdict |",
        "|---|---|---|",
        *rows,
        "",
        "Noise floors of the final designs, as above:",
        "",
        "| suite | designs | F | goal error | confidence | final distance (m) |",
        "|---|---|---|---|---|---|",
    ]
    for name in present:
        floor = _suite_json(square / name, "report/noise-floor.json")
        if floor is not None:
            lines.append(_floor_row(name, floor["all"]))
    # The details, one heading level down, after the suites' own.
    lines += [("#" + line) if line.startswith("## ") else line for line in details]
    return [*lines, ""]


#: The folder under the results with the committed final designs rolled out again with the hand
#: merged and in the retest's nudged scenes (``python -m perf.studies.committed_motion``), one
#: CSV per section (``round.csv``, ``square.csv``).
MOTION = "committed-motion"

#: The columns :func:`motion_figures` reads.
MOTION_COLUMNS = (
    "suite",
    "variant",
    "optimizer",
    "seed",
    "arm",
    "nudge",
    "free_energy",
    "box_x",
    "box_y",
    "stored_free_energy",
    "error",
)


def motion_figures(
    path: str | os.PathLike[str], one_rollout: Iterable[str] | None = None
) -> dict[str, float]:
    """What the merged hand and the retest's nudges do to the committed final designs.

    ``path`` is a CSV of ``perf.studies.committed_motion``: per final design, its rollout with
    13 links (the arm it ran with) in its own scene (``nudge`` 0) and in the retest's nudged
    scenes (``nudge`` 1, 2, ...), and with the hand merged in its own scene. A rollout in which
    the design is invalid (its ``error`` says why) has no numbers and is counted apart.

    ``one_rollout`` names the suites whose stored score is the F of one rollout (not, e.g., a
    mean over box masses); None: every suite.

    Returns:
        ``designs``; ``reproduced``: how many of the ``compared`` designs of the suites of
        ``one_rollout`` gave their stored F bit for bit with 13 links in their own scene;
        ``merged_max_change`` and ``merged_median_change``: the
        largest and the median |F merged - F 13 links| over the designs valid with both arms,
        with ``merged_max_relative`` (that over |F 13 links|), ``merged_unchanged`` (designs
        whose F is bit for bit the same), ``merged_moved_0.1%`` (designs whose F moves by more
        than 0.1 %) and ``merged_invalid``; ``merged_median_shift_mm`` and
        ``merged_max_shift_mm``: the median and the largest distance between the box's final
        positions with the two arms, mm;
        ``nudge_median_shift_mm`` and ``nudge_max_shift_mm``: the median and the largest
        distance between the box's final position in a nudged scene and in the design's own
        one, over the ``nudged_rollouts`` valid ones (``nudge_invalid`` were not).

    Raises:
        ValueError: The file lacks a column, or a design lacks its 13-link rollout in its own
            scene or its merged one.
    """
    table = pd.read_csv(path, dtype={"variant": str, "error": str})
    missing = [c for c in MOTION_COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(
            f"{os.fspath(path)} lacks the columns {missing}: not a committed_motion CSV"
        )
    keys = ["suite", "variant", "optimizer", "seed"]
    table["variant"] = table["variant"].fillna("").astype(str)
    table["error"] = table["error"].fillna("").astype(str)
    own = table[(table["arm"] == "13 links") & (table["nudge"] == 0)].set_index(keys)
    merged = table[table["arm"] == "hand merged"].set_index(keys)
    nudged = table[(table["arm"] == "13 links") & (table["nudge"] > 0)]
    if not own.index.is_unique or set(own.index) != set(merged.index):
        raise ValueError(
            f"{os.fspath(path)}: every design needs one 13-link rollout in its own scene and one "
            "with the hand merged"
        )
    merged = merged.loc[own.index]
    suites = set(own.index.get_level_values("suite"))
    scored = own[
        own.index.get_level_values("suite").isin(
            suites if one_rollout is None else set(one_rollout)
        )
    ]
    both = (own["error"] == "") & (merged["error"] == "")
    change = (merged["free_energy"] - own["free_energy"]).abs()[both]
    shift = np.hypot(merged["box_x"] - own["box_x"], merged["box_y"] - own["box_y"])[both]
    valid = nudged[nudged["error"] == ""]
    base = own.loc[pd.MultiIndex.from_frame(valid[keys])]
    moved = np.hypot(
        valid["box_x"].to_numpy() - base["box_x"].to_numpy(),
        valid["box_y"].to_numpy() - base["box_y"].to_numpy(),
    )
    moved = moved[np.isfinite(moved)]  # a nudge of a design invalid in its own scene: no base
    return {
        "designs": float(len(own)),
        "reproduced": float((scored["free_energy"] == scored["stored_free_energy"]).sum()),
        "compared": float(len(scored)),
        "merged_max_change": float(change.max()),
        "merged_median_change": float(change.median()),
        "merged_max_relative": float((change / own["free_energy"].abs()[both]).max()),
        "merged_unchanged": float((change == 0).sum()),
        "merged_invalid": float((~both).sum()),
        "merged_moved_0.1%": float((change / own["free_energy"].abs()[both] > 1e-3).sum()),
        "merged_median_shift_mm": float(1000 * np.median(shift)),
        "merged_max_shift_mm": float(1000 * np.max(shift)),
        "nudge_median_shift_mm": float(1000 * np.median(moved)) if len(moved) else math.nan,
        "nudge_max_shift_mm": float(1000 * np.max(moved)) if len(moved) else math.nan,
        "nudged_rollouts": float(len(moved)),
        "nudge_invalid": float(len(nudged) - len(moved)),
    }


def _one_rollout_suites(folder: Path) -> list[str]:
    """The suites under ``folder`` whose stored score is one rollout's F (objective free-energy)."""
    names = []
    for suite in SUITES:
        if (folder / suite / "manifest.json").is_file():
            config = read_manifest(folder / suite).get("config", {})  # through the reader gate
            if config.get("objective", "free-energy") == "free-energy":
                names.append(suite)
    return names


def _motion(results: Path, section: str) -> dict[str, float] | None:
    """:func:`motion_figures` of a section's committed CSV, or None without one."""
    path = results / MOTION / f"{section}.csv"
    if not path.is_file():
        return None
    return motion_figures(
        path, _one_rollout_suites(results / SQUARE if section == SQUARE else results)
    )


def _reproduced(figures: Mapping[str, float]) -> str:
    """How many designs the 13-link rollouts gave the stored F of, bit for bit."""
    return (
        f"with 13 links in its own scene, {int(figures['reproduced'])} of the "
        f"{int(figures['compared'])} designs whose stored score is one rollout's F gave it bit for "
        "bit"
    )


def _invalid(count: float) -> str:
    """``"; 1 invalid in its scene, left out"`` or nothing."""
    return f"; {int(count)} invalid in its scene, left out" if count else ""


def _merged_sentence(results: Path) -> str:
    """What the merged hand does to the outcomes, as measured on the committed designs."""
    figures = _motion(results, "round")
    if figures is None:
        return (
            "its outcomes on the committed designs not measured (no `committed-motion/round.csv`)"
        )
    return (
        "outcomes that differ from the 13 links' by rounding on most designs and by much more on "
        f"some, as the pushes' chaos amplifies it: on the {int(figures['designs'])} committed "
        "final designs of the round section, rolled out again with each arm in the design's own "
        f"scene, F moves by a median {_fmt(figures['merged_median_change'], 2)} but up to "
        f"{_fmt(figures['merged_max_change'])} ({percent_cell(figures['merged_max_relative'])}; "
        f"by more than 0.1 % on {int(figures['merged_moved_0.1%'])} designs, bit for bit on "
        f"{int(figures['merged_unchanged'])}{_invalid(figures['merged_invalid'])}), and the "
        f"box's final position by a median {_fmt(figures['merged_median_shift_mm'], 2)} mm and "
        f"up to {_fmt(figures['merged_max_shift_mm'], 3)} mm (`docs/results/{MOTION}/round.csv`, "
        f"below; {_reproduced(figures)})"
    )


def _nudge_sentence(results: Path) -> str:
    """What the retest's nudges do to the motion, as measured on the committed designs."""
    figures = _motion(results, "round")
    if figures is None:
        return "whose effect on the motion was not measured (no `committed-motion/round.csv`)"
    return (
        "which move the box's final position by a median "
        f"{_fmt(figures['nudge_median_shift_mm'], 2)} mm and up to "
        f"{_fmt(figures['nudge_max_shift_mm'], 3)} mm on the "
        f"{int(figures['designs'])} committed final designs of the round section "
        f"({int(figures['nudged_rollouts'])} nudged rollouts{_invalid(figures['nudge_invalid'])}, "
        f"`docs/results/{MOTION}/round.csv`): "
        "the pushes are chaotic, and the noise floor is how much of each quantity that chaos moves"
    )


#: The suites each claim is read from (robust-design is optional: claim (c)'s baseline).
REQUIRED_SUITES = ("optimizers", "robustness")


def reproduction_page(
    results: str | os.PathLike[str], *, protocol: ClaimSection | None = None
) -> str:
    """The Markdown of docs/reproduction.md, from the committed results under ``results``.

    Args:
        results: The folder of the suites' run folders (``docs/results``).
        protocol: Claim (a) judged under the benchmark protocol
            (:func:`benchmarks.protocol.claims.protocol_claim`, which reads a protocol run
            folder: a layer above this one). ``None``: not tested, which the page says, with
            the command that makes the run; refused while ``results`` holds
            :data:`PROTOCOL_FOLDER`, whose run would then be left unjudged.

    Raises:
        FileNotFoundError: ``results`` lacks a suite folder the claims are read from (its
            evaluation table), named in the message.
        ValueError: ``protocol`` is None and ``results`` holds :data:`PROTOCOL_FOLDER`.
    """
    results = Path(results)
    if protocol is None:
        if os.path.lexists(results / PROTOCOL_FOLDER):
            raise ValueError(
                f"{results / PROTOCOL_FOLDER} holds a protocol run, which claim (a) must be "
                "judged under: pass benchmarks.protocol.claims.protocol_claim(folder) as "
                "protocol= (tooldesign reproduce does)"
            )
        protocol = protocol_not_tested(
            f"no protocol run folder `docs/results/{PROTOCOL_FOLDER}` has been committed yet"
        )
    for suite in REQUIRED_SUITES:
        folder = results / suite
        if (
            not any((folder / f"evaluations.{ext}").is_file() for ext in ("parquet", "csv"))
            and not (folder / "parts").is_dir()
        ):
            raise FileNotFoundError(
                f"{folder} holds no results of the {suite!r} suite, which the page's claims are "
                f"read from; run `tooldesign bench {suite} --out {folder}` first, or point "
                "--results at a folder that has it"
            )
    floors = {}
    for suite in SUITES:
        floor = _suite_json(results / suite, "report/noise-floor.json")
        if floor is not None:
            floors[suite] = floor["all"]
    baseline = results / "robust-design"
    a = _claim_a(results / "optimizers")
    b = _claim_b(results / "robustness")
    c = _claim_c(results / "robustness", baseline if baseline.is_dir() else None)
    d = _claim_d(results / "robustness")
    e = _claim_e(results / "robustness")
    lines = [
        "# Reproduction of the paper's results",
        "",
        "This page is written by `tooldesign reproduce` from the committed results "
        "under `docs/results/` alone (it rebuilds every suite's report first); nothing on it is "
        "typed by hand. Each suite ran with the defaults of [The model](model.md) except what "
        "its config (`manifest.json`) says; the tool's section (round by default; the paper's "
        "square section has its own results, in the last section), the arm (13 links, or the "
        "hand merged into the last arm link, the default since 83b01fb: the same rigid body, "
        f"{_merged_sentence(results)}; [Performance](performance.md#fewer-links-the-hand-merged-"
        "into-the-last-arm-link-2026-11-25)), the estimator of Pi_U and the code each ran with:",
        "",
        "| suite | section | arm | estimator | objective | seeds | batch x iterations | commit "
        "| retested |",
        "|---|---|---|---|---|---|---|---|---|",
        *_suite_rows(results),
        "",
        "**How a claim is judged.** A difference counts when its 95 % interval (or its "
        "Holm-corrected test) excludes zero AND it is larger than the noise floor: the median "
        "range of that quantity over scenes nudged by at most 0.1 mm and 1e-4 rad "
        f"(`tooldesign retest`), {_nudge_sentence(results)}. A trend counts when its Spearman "
        "p < 0.05.",
        "",
        "| claim of the paper | here | verdict |",
        "|---|---|---|",
        f"{CLAIM_A_ROW} | {a[0]} | {a[1]} |",
        f"{PROTOCOL_ROW} | {protocol.cell} | {protocol.verdict} |",
        f"| (b) p^X = 0 tools are curved and hold the box; p^X = 50 tools are straighter "
        f"| {b[0]} | {b[1]} |",
        f"| (c) pure confidence has the best robustness and the lowest control deviation "
        f"| {c[0]} | {c[1]} |",
        f"| (d) robustness falls and goal error falls as p^X grows | {d[0]} | {d[1]} |",
        f"{TABLE_I_ROW} | {e[0]} | {e[1]} |",
        "",
        "## Noise floors",
        "",
        "Median over each suite's final designs of the range over "
        f"{_nudges(floors.values())} nudged scenes (`docs/results/SUITE/report/noise.md`; a "
        "design invalid in a nudged scene is unmeasured and counts as a range above every "
        "measured one):",
        "",
        "| suite | designs | F | goal error | confidence | final distance (m) |",
        "|---|---|---|---|---|---|",
    ]
    for suite, floor in floors.items():
        lines.append(_floor_row(suite, floor))
    lines += ["", *a[2], "", *protocol.lines, "", *b[2], "", *c[2], "", *d[2], "", *e[2], ""]
    lines += [
        "## Does control confidence buy robustness more cheaply than asking for it?",
        "",
        "The `robust-design` suite optimizes the goal error averaged over box masses 0.1, 0.5 and "
        "0.9 kg (no confidence term) with the same optimizer and budget per run as the "
        f"robustness suite, on its first {_seeds(baseline)} goals and seeds; its row in the "
        "table of (c) is `expected goal error` (its interval is over those goals only). Each of "
        "its evaluations costs 3 rollouts instead of 1.",
        "",
        *_square_section(results),
        "## How the results were made",
        "",
        "```bash",
        *[f"tooldesign bench {s} --size full --out docs/results/{s}" for s in SUITES],
        *[f"tooldesign retest docs/results/{s}" for s in SUITES],
        *protocol.made_by,
        *[
            f"tooldesign bench {s} --size full --section-shape square "
            f"--out docs/results/{SQUARE}/{s}"
            for s in SUITES
            if (results / SQUARE / s / "manifest.json").is_file()
        ],
        *[
            f"tooldesign retest docs/results/{SQUARE}/{s}"
            for s in SUITES
            if (results / SQUARE / s / "manifest.json").is_file()
        ],
        *[
            f"python -m perf.studies.committed_motion --section {section} "
            f"--out docs/results/{MOTION}/{section}.csv"
            for section in ("round", "square")
            if (results / MOTION / f"{section}.csv").is_file()
        ],
        "tooldesign reproduce   # every report, then this page",
        "```",
        "",
        f"`docs/results/{MOTION}/` holds every committed final design rolled out again, from the "
        "repository's root (`perf/studies/committed_motion.py`): with the 13 links it ran with in "
        "its own scene (its stored F, where that code and platform reproduce it: the page counts "
        "how many did) "
        "and in the retest's nudged scenes, and with the hand merged; per rollout F, its terms, "
        "and the box's final position. The page's figures on the merged hand and on the nudges "
        "are read from it.",
        "",
        "Each folder holds `manifest.json` (config, versions, commit, host, times), "
        "`evaluations.parquet`, `designs/`, `retest/` (the noise and stress rollouts of every "
        "final design), `report/` and `bench-output.txt`.",
    ]
    timing = _suite_file(results / "optimizers", "bench-output.txt")
    if timing is not None:
        lines += ["", "The `optimizers` suite's own account of its time:", "", "```"]
        lines += [
            ln
            for ln in timing.decode("utf-8", errors="replace").splitlines()
            if not ln.startswith("$")
        ]
        lines += ["```"]
    return "\n".join(lines) + "\n"
