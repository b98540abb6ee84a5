"""Write docs/reproduction.md: the paper's claims next to the committed results, with their noise.

One command rebuilds every suite's report from its stored results (nothing is simulated) and
then the page, whose every number is read from those files::

    tooldesign reproduce [--results docs/results] [--out docs/reproduction.md]

The results are made by ``tooldesign bench SUITE --size full --out docs/results/SUITE`` and
``tooldesign retest docs/results/SUITE`` for the suites of :data:`SUITES`. A claim's verdict
follows one rule everywhere: a difference counts when its 95 % interval (or its Holm-corrected
test) excludes zero AND it is larger than the noise floor of the quantity (its median range over
nudged scenes that leave the motion unchanged); a rank correlation counts when p < 0.05.
"""

from __future__ import annotations

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
from benchmarks.reports.suite import designs_table
from benchmarks.storage import read_designs, read_retests, read_run_file, with_added_fields
from benchmarks.storage.runfolder import read_report_file
from benchmarks.suites.config import ADDED_FIELDS
from tooldesign_env.schema import ROBUSTNESS_METRICS

__all__ = ["SUITES", "reproduction_page"]

SUITES = ("optimizers", "precision-sweep", "mass-perturbation", "robustness", "robust-design")

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


def _comparison_noise(pure: float, other: float, label: str) -> tuple[float, str]:
    """The noise a difference of claim (c) must exceed: the larger of the two rows' noise.

    A row whose noise was not measured (NaN) does not count (``max(nan, x)`` would depend on
    the order of its arguments); the second value says which was missing, for the table, or
    is empty. With neither measured the noise is 0: the interval alone decides.
    """
    known = [v for v in (pure, other) if math.isfinite(v)]
    missing = [
        name for name, v in (("pure confidence", pure), (label, other)) if not math.isfinite(v)
    ]
    if len(missing) == 2:
        return 0.0, "noise not measured"
    note = f"noise of {missing[0]} not measured" if missing else ""
    return float(max(known)), note


def _claim_a(folder: Path) -> tuple[str, str, list[str]]:
    summary = _read_csv(folder, "report/summary.csv")
    pairwise = _read_csv(folder, "report/pairwise.csv")
    floor = noise_floor(read_retests(folder))
    runs = int(summary["runs"].max()) if len(summary) else 0
    lines = [
        "## (a) CMA-ES lowers F fastest",
        "",
        f"{len(summary)} optimizers, {runs} seeds each "
        f"(`docs/results/{_where(folder)}/report/summary.md`, `pairwise.md`, "
        f"`convergence-{folder.name}.png`). Noise floor of F over the {int(floor['designs'])} "
        f"final designs: {_fmt(floor['free_energy'])} "
        f"({percent_cell(floor['free_energy_relative'])}, median range over nudged scenes, "
        "`noise.md`).",
        "",
        "| optimizer | final F [95 % CI] | AUC [95 % CI] |",
        "|---|---|---|",
    ]
    short = False
    for _, row in summary.iterrows():
        cells = [str(row["optimizer"])]
        for metric in ("final_free_energy", "auc"):
            n = int(row["runs"]) - int(row[f"{metric}_excluded"])
            short |= n < MIN_INTERVAL_VALUES
            bounds = interval_bounds(row[f"{metric}_low"], row[f"{metric}_high"], n, _fmt)
            cells.append(f"{_fmt(row[metric])} {bounds}")
        lines.append("| " + " | ".join(cells) + " |")
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


def _claim_b(folder: Path) -> tuple[str, str, list[str]]:
    table = _designs(folder)
    table = table[table["status"] == "ok"]
    lines = [
        "## (b) Low p^X gives curved tools that hold the box; high p^X straighter tools",
        "",
        f"All {len(table)} designs of the robustness suite "
        f"({table['goal_precision'].nunique()} p^X x {table['seed'].nunique()} random goals), "
        f"`docs/results/{_where(folder)}/report/designs.md`; Spearman rank correlation of p^X with "
        "each shape measure and the final distance (n, p):",
        "",
        "| measure | mean at p^X = 0 | mean at p^X = 50 | rho | p |",
        "|---|---|---|---|---|",
    ]
    results = {}
    for column, name in (
        ("turning_angle", "turning angle (deg)"),
        ("straightness", "straightness (chord / arc)"),
        ("final_distance", "final distance to the goal (m)"),
    ):
        rho, p, n = _spearman(table["goal_precision"], table[column])
        results[column] = (rho, p)
        low = table.loc[table["goal_precision"] == table["goal_precision"].min(), column].mean()
        high = table.loc[table["goal_precision"] == table["goal_precision"].max(), column].mean()
        lines.append(f"| {name} | {_fmt(low)} | {_fmt(high)} | {_fmt(rho, 3)} | {_fmt(p, 2)} |")
    straighter = results["turning_angle"][0] < 0 and results["turning_angle"][1] < 0.05
    closer = results["final_distance"][0] < 0 and results["final_distance"][1] < 0.05
    if straighter and closer:
        verdict = "**holds**: tools straighten and boxes end nearer the goal as p^X grows"
    elif straighter or closer:
        verdict = "**holds in part**: " + (
            "tools straighten" if straighter else "boxes end nearer the goal"
        )
    else:
        verdict = "**does not hold**: no significant trend of shape or distance with p^X"
    cell = (
        f"turning angle rho = {_fmt(results['turning_angle'][0], 2)}, final distance "
        f"rho = {_fmt(results['final_distance'][0], 2)}"
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
    pure = per_design[per_design["label"] == "pure confidence"]
    findings: dict[str, list[bool]] = {"robustness": [], "control_deviation": []}
    for other in [lab for lab in per_design["label"].unique() if lab != "pure confidence"]:
        part = per_design[per_design["label"] == other]
        for metric, better in (("robustness", 1), ("control_deviation", -1)):
            diff, low, high, n = _paired_difference(pure, part, metric)
            noise, unmeasured = _comparison_noise(
                float(rows.loc[rows["label"] == "pure confidence", f"{metric}_noise"].max()),
                float(rows.loc[rows["label"] == other, f"{metric}_noise"].max()),
                other,
            )
            counts = _verdict_difference(low, high, diff, noise)
            findings[metric].append(counts and diff * better > 0)
            short = 0 < n < MIN_INTERVAL_VALUES
            lines.append(
                f"| {metric.replace('_', ' ')} | {other} | {_fmt(diff)} "
                f"{interval_bounds(low, high, n, _fmt)} | {n} | {'yes' if counts else 'no'}"
                f"{' (no interval: fewer than 2 shared goals)' if short else ''}"
                f"{' (pure confidence better)' if counts and diff * better > 0 else ''}"
                f"{' (pure confidence worse)' if counts and diff * better < 0 else ''}"
                f"{f' ({unmeasured})' if unmeasured else ''} |"
            )
    parts = []
    for metric, name in (("robustness", "robustness"), ("control_deviation", "control deviation")):
        if findings[metric] and all(findings[metric]):
            parts.append(f"{name} holds")
        else:
            parts.append(f"{name} not shown")
    verdict = "**" + "; ".join(parts) + "**"
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
        "squared goal error of the final test, `designs.md`):",
        "",
        "| quantity | rho | p | n |",
        "|---|---|---|---|",
    ]
    rob = _spearman(per_design["goal_precision"], per_design["robustness"])
    err = _spearman(designs["goal_precision"], designs["squared_goal_error"])
    dist = _spearman(per_design["goal_precision"], per_design["final_distance"])
    for name, (rho, p, n) in (
        ("robustness (higher is better)", rob),
        ("squared goal error", err),
        ("final distance over the mass range", dist),
    ):
        lines.append(f"| {name} | {_fmt(rho, 3)} | {_fmt(p, 2)} | {n} |")
    rob_falls = rob[0] < 0 and rob[1] < 0.05
    rob_rises = rob[0] > 0 and rob[1] < 0.05
    err_falls = err[0] < 0 and err[1] < 0.05
    verdict = (
        "**"
        + ("goal error falls" if err_falls else "goal error: no significant trend")
        + "; "
        + (
            "robustness falls"
            if rob_falls
            else ("robustness *rises*" if rob_rises else "robustness: no significant trend")
        )
        + "**"
    )
    cell = f"robustness rho = {_fmt(rob[0], 2)}, goal error rho = {_fmt(err[0], 2)}"
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


def _square_section(results: Path) -> list[str]:
    """The claims again from the suites run with the paper's square section, if present."""
    square = results / SQUARE
    present = [name for name in SUITES if (square / name / "manifest.json").is_file()]
    if not present:
        return []
    rows, details = [], []
    if "optimizers" in present:
        a = _claim_a(square / "optimizers")
        rows.append(f"| (a) CMA-ES lowers F fastest | {a[0]} | {a[1]} |")
        details += ["", *a[2]]
    if "robustness" in present:
        baseline = square / "robust-design"
        b = _claim_b(square / "robustness")
        c = _claim_c(square / "robustness", baseline if "robust-design" in present else None)
        d = _claim_d(square / "robustness")
        rows += [
            f"| (b) p^X = 0 tools are curved and hold the box; p^X = 50 tools are straighter "
            f"| {b[0]} | {b[1]} |",
            f"| (c) pure confidence has the best robustness and the lowest control deviation "
            f"| {c[0]} | {c[1]} |",
            f"| (d) robustness falls and goal error falls as p^X grows | {d[0]} | {d[1]} |",
        ]
        details += ["", *b[2], "", *c[2], "", *d[2]]
    lines = [
        "## With the paper's square section",
        "",
        "The paper's tool has a square section. Pushing with it is chaotic ([The model]"
        "(model.md#the-tools-section-where-the-chaos-came-from) measures it on random designs); "
        "on the suites' final designs, the median relative range of F under 0.1 mm nudges is, "
        f"square against round: {_section_noise(results)} (the tables of noise floors). These "
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


#: The suites each claim is read from (robust-design is optional: claim (c)'s baseline).
REQUIRED_SUITES = ("optimizers", "robustness")


def reproduction_page(results: str | os.PathLike[str]) -> str:
    """The Markdown of docs/reproduction.md, from the committed results under ``results``.

    Raises:
        FileNotFoundError: ``results`` lacks a suite folder the claims are read from (its
            evaluation table), named in the message.
    """
    results = Path(results)
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
    lines = [
        "# Reproduction of the paper's results",
        "",
        "This page is written by `tooldesign reproduce` from the committed results "
        "under `docs/results/` alone (it rebuilds every suite's report first); nothing on it is "
        "typed by hand. Each suite ran with the defaults of [The model](model.md) except what "
        "its config (`manifest.json`) says; the tool's section (round by default; the paper's "
        "square section has its own results, in the last section), the arm (13 links, or the "
        "hand merged into the last arm link, the default since 83b01fb: the same rigid body, "
        "results equal to rounding, [Performance](performance.md#fewer-links-the-hand-merged-"
        "into-the-last-arm-link-2026-11-25)), the estimator of Pi_U and the code each ran with:",
        "",
        "| suite | section | arm | estimator | objective | seeds | batch x iterations | commit "
        "| retested |",
        "|---|---|---|---|---|---|---|---|---|",
        *_suite_rows(results),
        "",
        "**How a claim is judged.** A difference counts when its 95 % interval (or its "
        "Holm-corrected test) excludes zero AND it is larger than the noise floor: the median "
        "range of that quantity over scenes nudged by at most 0.1 mm and 1e-4 rad, which leave "
        "the motion unchanged (`tooldesign retest`). A trend counts when its Spearman p < 0.05.",
        "",
        "| claim of the paper | here | verdict |",
        "|---|---|---|",
        f"| (a) CMA-ES lowers F fastest | {a[0]} | {a[1]} |",
        f"| (b) p^X = 0 tools are curved and hold the box; p^X = 50 tools are straighter "
        f"| {b[0]} | {b[1]} |",
        f"| (c) pure confidence has the best robustness and the lowest control deviation "
        f"| {c[0]} | {c[1]} |",
        f"| (d) robustness falls and goal error falls as p^X grows | {d[0]} | {d[1]} |",
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
    lines += ["", *a[2], "", *b[2], "", *c[2], "", *d[2], ""]
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
        "tooldesign reproduce   # every report, then this page",
        "```",
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
