"""Reports of a suite's retest (``tooldesign retest``): its noise floor and its stress tests.

Read from the retest files alone (:func:`benchmarks.storage.read_retests`); nothing is
simulated.
:func:`make_retest_report` writes, under ``run_folder/report/``:

- ``noise-floor.json`` and ``noise.csv/md``: per design, the range (max - min) of F, of its two
  terms and of the final distance over the nudged scenes; the suite's noise floor is the median
  range over its designs. Every other report of the folder uses it: a difference smaller than
  the noise floor of F is not called significant.
- with stress rows: ``stress.csv/md``, Table I over ranges: per variant, robustness, accuracy,
  control deviation and final distance, each the mean over designs of the design's mean over
  repeats and altered conditions, with a 95 % interval over designs and the median
  over designs of the range of the design's mean across repeated scenes (its noise);
  ``stress-mass.png`` and ``stress-friction.png``: final distance against the box mass (or
  friction) per variant, mean over designs with the interval as a band; and
  ``stress-success.csv`` / ``stress-friction-success.csv`` (a second table of the ``.md``): at
  each altered mass (friction), the share of designs whose box ends within the task's
  tolerance of the goal in the scene itself (the first nudge), with its Wilson interval
  (:func:`stress_success_table`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.reports import plots
from benchmarks.reports.comparison import (
    MIN_INTERVAL_VALUES,
    interval_bounds,
    no_interval_note,
    percent_cell,
    with_notice,
)
from benchmarks.reports.stats import INTERVAL_NAMES, check_interval, mean_interval
from benchmarks.storage import atomic_write_text, json_text, retest_outcome
from tooldesign_env.schema import METRICS

__all__ = [
    "MISSING_METRIC_NOTE",
    "STRESS_METRICS",
    "design_means",
    "make_retest_report",
    "noise_table",
    "short_intervals",
    "stress_repeats",
    "stress_success_table",
    "stress_table",
    "unmeasured_noise",
]

LEVEL = 0.95
TERMS = METRICS
STRESS_METRICS = (
    ("robustness", "robustness (m)", "higher"),
    ("accuracy", "accuracy (m)", "higher"),
    ("control_deviation", "control deviation (N m)", "lower"),
    ("final_distance", "final distance (m)", "lower"),
)


def _rng(seed: int, *labels: Any) -> np.random.Generator:
    import zlib

    text = "/".join(map(str, labels))
    return np.random.default_rng([seed, zlib.crc32(text.encode("utf-8"))])


def _fmt(value: float, digits: int = 4) -> str:
    return "n/a" if not math.isfinite(value) else f"{value:.{digits}g}"


def noise_table(retests: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """One row per retested design: for each term, its mean and range over the nudges."""
    rows = []
    for retest in retests:
        noise = retest.get("noise") or []
        row: dict[str, Any] = {
            k: retest.get(k) for k in ("variant", "optimizer", "seed", "goal_precision")
        }
        row["nudges"] = len(noise)
        for term in TERMS:
            values = np.array([r[term] for r in noise], dtype=np.float64)
            row[f"{term}_mean"] = float(values.mean()) if len(values) else math.nan
            row[f"{term}_range"] = float(np.ptp(values)) if len(values) else math.nan
        rows.append(row)
    return pd.DataFrame(rows)


def design_means(retest: Mapping[str, Any], change: str) -> dict[str, Any] | None:
    """A retested design's stress metrics under ``change``; None if it has no row of ``change``.

    Per metric m: ``m``, the mean over its repeated scenes of each scene's mean, and
    ``m_noise``, the range of those means (NaN when the metric is missing in a scene).
    """
    rows = [r for r in retest.get("stress") or [] if r["change"] == change]
    if not rows:
        return None
    frame = pd.DataFrame(rows)
    per_repeat = frame.groupby("nudge")[[m for m, _, _ in STRESS_METRICS]].mean()
    out: dict[str, Any] = {}
    for metric, _, _ in STRESS_METRICS:
        out[metric] = float(per_repeat[metric].mean())
        values = per_repeat[metric].to_numpy(dtype=float, na_value=math.nan)
        # A metric missing in every scene has no range: NaN, without NumPy's warning of it.
        out[f"{metric}_noise"] = float(np.ptp(values)) if np.isfinite(values).all() else math.nan
    return out


def stress_table(
    retests: Sequence[Mapping[str, Any]],
    change: str,
    *,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
) -> pd.DataFrame:
    """Table I over a range of one change (``"mass"`` or ``"friction"``), one row per variant.

    With the retests of several optimizers, one row per variant and optimizer (an ``optimizer``
    column), since their designs are not repeats of one another. ``interval`` is the interval
    of a mean (:data:`~benchmarks.reports.stats.INTERVALS`); ``n_boot`` and ``seed`` are the
    bootstrap's.

    Returns:
        ``variant``, ``label``, ``goal_precision``, ``designs`` and, per metric m of
        :data:`STRESS_METRICS`: ``m`` (mean over designs), ``m_low``/``m_high`` (its 95 %
        interval over designs), ``m_n`` (the designs with a finite value, which the
        mean and interval are of), ``m_noise`` (median, over the designs
        that have the metric in every repeated scene, of the range of the design's mean across
        those scenes; NaN when no design has) and ``m_best``.
    """
    # Several optimizers' designs are not repeats of one another: a row per variant and
    # optimizer then (as Table I), never pooled.
    split = len({str(r.get("optimizer")) for r in retests}) > 1
    by_group: dict[tuple[str, str], list[tuple[Mapping[str, Any], dict[str, Any]]]] = {}
    for retest in retests:
        means = design_means(retest, change)
        if means is not None:
            key = (str(retest["variant"]), str(retest.get("optimizer")) if split else "")
            by_group.setdefault(key, []).append((retest, means))
    rows = []
    for (variant, optimizer), items in by_group.items():
        first = items[0][0]
        row: dict[str, Any] = {
            "variant": variant,
            "label": first.get("label") or "",
            **({"optimizer": optimizer} if split else {}),
            "goal_precision": float(first["goal_precision"]),
            "designs": len(items),
        }
        stream = f"{variant}/{optimizer}" if split else variant
        for metric, _, _ in STRESS_METRICS:
            values = np.array([m[metric] for _, m in items])
            # A design missing the metric in a scene has no range; the others' still count.
            noises = np.array([m[f"{metric}_noise"] for _, m in items], dtype=np.float64)
            noises = noises[np.isfinite(noises)]
            ci = mean_interval(
                values,
                interval=interval,
                level=LEVEL,
                n_boot=n_boot,
                rng=_rng(seed, change, metric, stream),
            )
            row.update(
                {
                    metric: ci.estimate,
                    f"{metric}_low": ci.low,
                    f"{metric}_high": ci.high,
                    f"{metric}_n": ci.n,
                    f"{metric}_noise": float(np.median(noises)) if len(noises) else math.nan,
                }
            )
        rows.append(row)
    table = pd.DataFrame(rows)
    if len(table):
        table = table.sort_values("goal_precision", kind="stable").reset_index(drop=True)
        for metric, _, better in STRESS_METRICS:
            pick = table[metric].max() if better == "higher" else table[metric].min()
            table[f"{metric}_best"] = table[metric] == pick
    return table


def stress_success_table(
    retests: Sequence[Mapping[str, Any]],
    change: str,
    tolerance: float = 0.1,
    level: float = LEVEL,
) -> pd.DataFrame:
    """At each altered value of ``change``, the share of designs that succeed, per variant.

    A design succeeds at a value when its box ends within ``tolerance`` (m, the task's) of the
    goal in the scene itself (the stress row of the first nudge, ``nudge`` 0, which the other
    scenes are nudged from). The stress rows store the final distance only (not the box's
    height or tilt), so this is the distance part of the task's test. A design with no finite
    distance there has an unknown outcome and is left out of n.

    Args:
        retests: The retest records.
        change: ``"mass"`` or ``"friction"``.
        tolerance: The success radius, m.
        level: The Wilson interval's coverage.

    Returns:
        One row per variant (and optimizer, when several were retested) and value:
        ``variant``, ``label``, (``optimizer``), ``goal_precision``, ``value``, ``designs``
        (with a known outcome), ``unknown``, ``successes``, ``success_rate``, ``success_low``,
        ``success_high``; sorted by p^X, then value.
    """
    from benchmarks.reports.success import design_succeeded, success_rate

    if change not in ("mass", "friction"):
        raise ValueError(f"change must be 'mass' or 'friction', got {change!r}")
    split = len({str(r.get("optimizer")) for r in retests}) > 1
    outcomes: dict[tuple[str, str, float], list[bool | None]] = {}
    first: dict[tuple[str, str], Mapping[str, Any]] = {}
    for retest in retests:
        key = (str(retest["variant"]), str(retest.get("optimizer")) if split else "")
        for row in retest.get("stress") or []:
            if row["change"] != change or row.get("nudge", 0) != 0:
                continue
            first.setdefault(key, retest)
            outcome = design_succeeded("ok", row.get("final_distance"), tolerance)
            outcomes.setdefault((*key, float(row["value"])), []).append(outcome)
    rows = []
    for (variant, optimizer, value), found in outcomes.items():
        record = first[(variant, optimizer)]
        rate = success_rate(found, level)
        rows.append(
            {
                "variant": variant,
                "label": record.get("label") or "",
                **({"optimizer": optimizer} if split else {}),
                "goal_precision": float(record["goal_precision"]),
                "value": value,
                "designs": rate.n,
                "unknown": rate.unknown,
                "successes": rate.successes,
                "success_rate": rate.rate,
                "success_low": rate.low,
                "success_high": rate.high,
            }
        )
    table = pd.DataFrame(rows)
    if len(table):
        table = table.sort_values(["goal_precision", "value"], kind="stable").reset_index(drop=True)
    return table


def _stress_success_markdown(table: pd.DataFrame, change: str, tolerance: float, task: str) -> str:
    from benchmarks.reports.success import SuccessRate, success_cell

    unit = " kg" if change == "mass" else ""
    split = "optimizer" in table.columns
    keys = ["variant", *(["optimizer"] if split else [])]
    values = sorted(set(table["value"]))
    lines = [
        "",
        f"## Success at each box {change}",
        "",
        f"The share of designs whose box ends within {tolerance:g} m of the goal (the {task} "
        "task's tolerance) in the scene itself (the first of the nudged scenes), at each box "
        f"{change}, with its {LEVEL:.0%} Wilson interval. The stress test stores the final "
        "distance only, not the box's height and tilt, so a box tipped within the tolerance "
        "would count here.",
        "",
    ]
    header = ["objective", *(["optimizer"] if split else []), "p^X"]
    header += [f"{v:g}{unit}" for v in values]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for _, group in table.groupby(keys, sort=False):
        head = group.iloc[0]
        cells = [str(head["label"] or head["variant"])]
        cells += [str(head["optimizer"])] if split else []
        cells.append(_fmt(head["goal_precision"]))
        by_value = {float(r["value"]): r for _, r in group.iterrows()}
        for v in values:
            r = by_value.get(float(v))
            if r is None:
                cells.append("-")
                continue
            rate = SuccessRate(
                int(r["successes"]),
                int(r["designs"]),
                int(r["unknown"]),
                float(r["success_rate"]),
                float(r["success_low"]),
                float(r["success_high"]),
            )
            cells.append(success_cell(rate))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def short_intervals(table: pd.DataFrame) -> bool:
    """Whether an interval of a :func:`stress_table` has fewer than 2 designs with a value."""
    return any((table[f"{m}_n"] < MIN_INTERVAL_VALUES).any() for m, _, _ in STRESS_METRICS)


#: Why a noise is n/a although every design was rolled out in two scenes or more.
MISSING_METRIC_NOTE = (
    "A noise of n/a was not measured: every design lacked that metric in at least one of its "
    "scenes (a rollout that gave no value), so no design's range across scenes could be taken."
)


def unmeasured_noise(table: pd.DataFrame, metrics: Sequence[str]) -> bool:
    """Whether a :func:`stress_table` row has a NaN noise for one of ``metrics``."""
    return bool(table[[f"{m}_noise" for m in metrics]].isna().any(axis=None))


def stress_repeats(retests: Sequence[Mapping[str, Any]], change: str) -> int:
    """Fewest repeated scenes of a retested design's stress rows of ``change`` (0 if none).

    A design's noise is the range of its mean across those scenes: with one scene there is no
    range to measure, and its 0 in the CSV is not a measurement.
    """
    counts = [
        len({r.get("nudge") for r in rows})
        for retest in retests
        for rows in [[r for r in retest.get("stress") or [] if r["change"] == change]]
        if rows
    ]
    return min(counts, default=0)


def _stress_markdown(
    table: pd.DataFrame, change: str, values: Sequence[float], repeats: int, interval: str = "t"
) -> str:
    unit = "kg" if change == "mass" else ""
    lines = [
        f"# Table I over a range of box {change}",
        "",
        f"Each design was rolled out at box {change} "
        f"{', '.join(f'{v:g}' for v in values)} {unit} in several nudged scenes, and each "
        "altered rollout was compared with the nominal one in the same scene. Per design: the "
        "mean over scenes and altered conditions; here: the mean over designs with a "
        f"{LEVEL:.0%} {INTERVAL_NAMES[interval]} over designs, and in parentheses the median over "
        "designs of the range of that mean across the repeated scenes (its noise). Robustness "
        "= -sum_t |X - X_0| (m, per altered condition), accuracy = -sum_t |X - X^g| (m), "
        "control deviation = sum_t |U - U_0| (N m), final distance |X_T - X^g| (m). Best mean "
        "in bold.",
        "",
    ]
    split = "optimizer" in table.columns
    header = ["objective", *(["optimizer"] if split else []), "p^X", "designs"]
    header += [title for _, title, _ in STRESS_METRICS]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for _, row in table.iterrows():
        name = str(row["label"] or row["variant"])
        cells = [name, *([str(row["optimizer"])] if split else [])]
        cells += [_fmt(row["goal_precision"]), str(row["designs"])]
        for metric, _, _ in STRESS_METRICS:
            mean = _fmt(row[metric])
            mean = f"**{mean}**" if row[f"{metric}_best"] else mean
            bounds = interval_bounds(
                row[f"{metric}_low"], row[f"{metric}_high"], int(row[f"{metric}_n"]), _fmt
            )
            noise = _fmt(row[f"{metric}_noise"], 2) if repeats >= 2 else "n/a"
            cells.append(f"{mean} {bounds} ({noise})")
        lines.append("| " + " | ".join(cells) + " |")
    notes = []
    if len(table) and short_intervals(table):
        notes.append(no_interval_note("designs"))
    if repeats < 2:
        notes.append(
            f"The noise is n/a: each design was rolled out in {repeats} scene(s), and a range "
            "across scenes needs at least 2 (retest with --repeats 2 or more)."
        )
    elif len(table) and unmeasured_noise(table, [m for m, _, _ in STRESS_METRICS]):
        notes.append(MISSING_METRIC_NOTE)
    for note in notes:
        lines += ["", note]
    return "\n".join(lines) + "\n"


def _plot_stress(
    retests: Sequence[Mapping[str, Any]], change: str, target: Path, seed: int, interval: str
) -> Path | None:
    frames = []
    for retest in retests:
        rows = [r for r in retest.get("stress") or [] if r["change"] == change]
        if rows:
            frame = pd.DataFrame(rows).groupby("value", as_index=False)["final_distance"].mean()
            frame["variant"] = retest["variant"]
            frame["goal_precision"] = float(retest["goal_precision"])
            frame["label"] = retest.get("label") or ""
            frames.append(frame)
    if not frames:
        return None
    data = pd.concat(frames, ignore_index=True)
    figure, ax = plots.new_figure(figsize=(6.4, 4.2))
    variants = data.drop_duplicates("variant").sort_values("goal_precision")
    colors = plots.sequential_colors(len(variants), "viridis")
    for (_, variant), color in zip(variants.iterrows(), colors, strict=True):
        part = data[data["variant"] == variant["variant"]]
        xs, means, lows, highs = [], [], [], []
        for value, cell in part.groupby("value"):
            ci = mean_interval(
                cell["final_distance"],
                interval=interval,
                level=LEVEL,
                n_boot=2000,
                rng=_rng(seed, "stress-plot", change, variant["variant"], value),
            )
            xs.append(value)
            means.append(ci.estimate)
            lows.append(ci.low)
            highs.append(ci.high)
        name = f"p^X = {variant['goal_precision']:g}"
        if variant["label"]:
            name += f" ({variant['label']})"
        ax.plot(xs, means, color=color, marker="o", markersize=3, label=name)
        ax.fill_between(xs, lows, highs, color=color, alpha=0.15, linewidth=0)
    ax.set_xlabel("box mass (kg)" if change == "mass" else "box friction coefficient")
    ax.set_ylabel("final distance to the goal (m)")
    ax.set_title(f"final distance over a range of box {change} ({LEVEL:.0%} CI over designs)")
    ax.grid(True, alpha=0.3)
    ax.legend(frameon=False, fontsize="small", loc="best")
    return plots.save_png(figure, target / f"stress-{change}.png")


_NO_RELATIVE_NOTE = (
    " A relative noise of n/a has no base: the term's mean is 0 for every design (as the "
    "goal-error term at p^X = 0), or no design has 2 scenes."
)


def _relative_missing(floor: Mapping[str, float]) -> bool:
    return any(
        not math.isfinite(floor[f"{t}_relative"])
        for t in ("free_energy", "goal_error", "confidence")
    )


def make_retest_report(
    retests: Sequence[Mapping[str, Any]],
    target: Path,
    *,
    n_boot: int = 10_000,
    seed: int = 0,
    interval: str = "t",
    notice: str | None = None,
    task: str | None = None,
) -> list[Path]:
    """Write the noise-floor and stress reports of retested designs into ``target``.

    ``interval`` is the interval of a mean (:data:`~benchmarks.reports.stats.INTERVALS`);
    ``n_boot`` and ``seed`` are the bootstrap's. ``notice`` (an incomplete run's) leads every
    ``.md`` page, as :func:`~benchmarks.reports.comparison.with_notice` puts it. ``task``: the
    registered task the designs were made for, whose tolerance the stress success shares use
    (None: push).

    Raises:
        ValueError: a bad ``interval``, or an unknown ``task`` (the message lists the known).
    """
    from benchmarks.reports.success import success_criterion

    interval = check_interval(interval)
    criterion = success_criterion(task)
    if not retests:
        return []
    floor = noise_floor(retests)
    by_variant = {
        str(v): noise_floor([r for r in retests if r.get("variant") == v])
        for v in sorted({r.get("variant") for r in retests}, key=str)
    }
    written = [
        atomic_write_text(
            target / "noise-floor.json", json_text({"all": floor, "by_variant": by_variant})
        )
    ]
    table = noise_table(retests)
    written.append(atomic_write_text(target / "noise.csv", table.to_csv(index=False)))
    lines = [
        "# Noise floor of F",
        "",
        f"Each final design was evaluated again in {int(table['nudges'].max())} scenes whose box "
        "start differs by at most 0.1 mm and 1e-4 rad (the same scenes for every design). Range "
        "= max - min over those scenes. The noise floor is the median range over designs, per "
        "variant (F's scale depends on p^X) in `noise-floor.json`; over all "
        f"{int(floor['designs'])} designs: F {_fmt(floor['free_energy'])} "
        f"({percent_cell(floor['free_energy_relative'])}), goal error "
        f"{_fmt(floor['goal_error'])} ({percent_cell(floor['goal_error_relative'])}), "
        f"confidence {_fmt(floor['confidence'])} ({percent_cell(floor['confidence_relative'])}),"
        f" final distance {_fmt(floor['final_distance'])} m. Differences of F below their "
        "variant's floor are not called significant in this folder's reports."
        + (_NO_RELATIVE_NOTE if _relative_missing(floor) else "")
        + _retest_notes(retests, floor),
        "",
        "| variant | optimizer | seed | F (mean) | F range | goal error range | "
        "confidence range | final distance range (m) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for _, row in table.iterrows():
        lines.append(
            f"| {row['variant'] or '-'} | {row['optimizer']} | {row['seed']} | "
            f"{_fmt(row['free_energy_mean'])} | {_fmt(row['free_energy_range'])} | "
            f"{_fmt(row['goal_error_range'])} | {_fmt(row['confidence_range'])} | "
            f"{_fmt(row['final_distance_range'])} |"
        )
    page = with_notice("\n".join(lines) + "\n", notice)
    written.append(atomic_write_text(target / "noise.md", page))
    for change in ("mass", "friction"):
        stress = stress_table(retests, change, n_boot=n_boot, seed=seed, interval=interval)
        if not len(stress):
            continue
        values = sorted(
            {r["value"] for t in retests for r in t.get("stress") or [] if r["change"] == change}
        )
        stem = "stress" if change == "mass" else "stress-friction-table"
        written.append(atomic_write_text(target / f"{stem}.csv", stress.to_csv(index=False)))
        repeats = stress_repeats(retests, change)
        markdown = _stress_markdown(stress, change, values, repeats, interval)
        success = stress_success_table(retests, change, criterion.tolerance)
        if len(success):
            written.append(
                atomic_write_text(
                    target / f"{stem.removesuffix('-table')}-success.csv",
                    success.to_csv(index=False),
                )
            )
            markdown += _stress_success_markdown(
                success, change, criterion.tolerance, criterion.name
            )
        written.append(atomic_write_text(target / f"{stem}.md", with_notice(markdown, notice)))
        figure = _plot_stress(retests, change, target, seed, interval)
        if figure is not None:
            written.append(figure)
    return written


def noise_floor(retests: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """The suite's noise floor of each term: the median over designs of its range over nudges.

    A design that was invalid in a nudged scene, or that has a nudge without a finite value, has
    no range to measure: its outcome changed by more than any range, so it counts as an
    infinite range, above every measured one, rather than being left out (which would lower the
    floor by dropping the noisiest designs). A median that lands on such a design (half of the
    designs or more) is NaN: not measured. A retest that broke for another reason (a worker
    that died: :func:`benchmarks.storage.retest_outcome` ``"failed"``) says nothing about the
    design and is left out (``tooldesign retest`` tries it again).

    Returns:
        ``{term: median of (max - min)}`` and ``{term + "_relative": median of (max - min) /
        |mean|}`` for F, goal error, confidence and final distance; ``designs``, the designs
        counted, ``unmeasured``, those of them without a measurable range, ``failed``, the
        retests left out, and ``nudges``, the most scenes a design was evaluated in. NaN values
        when no design was retested.
    """
    terms = METRICS
    ranges: dict[str, list[float]] = {t: [] for t in terms}
    relative: dict[str, list[float]] = {t: [] for t in terms}
    unmeasured = nudges = failed = 0
    for retest in retests:
        rows = retest.get("noise") or []
        nudges = max(nudges, len(rows))
        outcome = retest_outcome(retest)
        if outcome == "failed":
            failed += 1
            continue
        if len(rows) < 2 and outcome == "ok":
            continue  # retested in fewer than 2 scenes: no range, and nothing went wrong
        table = {t: np.array([r[t] for r in rows], dtype=np.float64) for t in terms}
        if outcome == "invalid" or not all(np.isfinite(v).all() for v in table.values()):
            unmeasured += 1
            for t in terms:
                ranges[t].append(math.inf)
                relative[t].append(math.inf)
            continue
        for t, values in table.items():
            ranges[t].append(float(np.ptp(values)))
            mean = abs(float(values.mean()))
            relative[t].append(float(np.ptp(values)) / mean if mean > 0 else math.nan)
    out: dict[str, float] = {
        "designs": float(len(ranges["free_energy"])),
        "unmeasured": float(unmeasured),
        "failed": float(failed),
        "nudges": float(nudges),
    }
    for t in terms:
        out[t] = _finite_median(ranges[t])
        out[f"{t}_relative"] = _finite_median([v for v in relative[t] if not math.isnan(v)])
    return out


def _retest_notes(retests: Sequence[Mapping[str, Any]], floor: Mapping[str, float]) -> str:
    def where(outcome: str) -> str:
        return "; ".join(
            f"{r.get('variant') or '-'} / {r.get('optimizer')} / seed {r.get('seed')}: {r['error']}"
            for r in retests
            if retest_outcome(r) == outcome
        )

    notes = ""
    if floor["unmeasured"]:
        invalid = where("invalid")
        notes += (
            f" {int(floor['unmeasured'])} design(s) had no measurable range (n/a below) and "
            "count as a range above every measured one, not left out: leaving them out would "
            "lower the floor by dropping the noisiest designs"
            + (f" ({invalid})." if invalid else ".")
        )
    if floor.get("failed"):
        notes += (
            f" {int(floor['failed'])} retest(s) broke for a reason of their own and are left "
            f"out; run tooldesign retest on the folder again to redo them ({where('failed')})."
        )
    return notes


def _finite_median(values: Sequence[float]) -> float:
    """The median (infinities rank above every number); NaN when empty or when it is infinite."""
    if not values:
        return math.nan
    median = float(np.median(values))
    return median if math.isfinite(median) else math.nan


# --- command line ------------------------------------------------------------------------------
