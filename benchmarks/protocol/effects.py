"""Effects beyond the noise floor: when the protocol tells two optimizers apart, and why not.

A significant difference of ECDF area is not enough to tell two optimizers apart: near the
bottom of a target ladder adjacent targets lie one or two noise floors apart, and two
optimizers that reach the same targets a few evaluations apart can differ significantly in
score while their final designs differ by less than the measurement's noise. So the protocol
also compares the designs the runs end with:

- :func:`floor_effects`: per pair of optimizers, the paired difference of final best F per
  block (block: an instance; pooled, an instance with its d blocks averaged, its floor the
  mean of theirs (:func:`instance_floors`); with tasks a (task, instance) likewise; an
  optimizer's F on a block is the mean over its seeds of each run's final best F, as
  the score's pairing takes the mean of scores), ``f_diff`` = mean over blocks of
  F(a) - F(b) with its Student t interval ``f_diff_low``/``f_diff_high`` over blocks; **a
  negative f_diff means a ends lower, i.e. better**. ``floor`` is the comparison's noise
  floor, the **median** over the pair's blocks of their references' noise floors, and
  ``beyond_floor`` is True when the t interval lies wholly beyond +-floor on one side
  (``f_diff_high < -floor`` or ``f_diff_low > floor``; at least two blocks).
- :func:`told_apart`: **the rule**. A pair is told apart when its Holm-corrected p of the
  ECDF area is below alpha (``significant``), it is ``beyond_floor``, and the two agree in
  direction (the optimizer with the higher score ends with the lower F). A pair significant
  in score whose F difference is not clear of the floor is not told apart.
- :func:`separation_sentence`: the verdict of one group of the report (a dimension, pooled,
  a task) in one sentence from its tables: the pairs told apart, with p, F difference and its
  interval in floors; for each other pair either (a) its F interval lies within +-floor, a
  property of the problem, or (b) the power analysis in F units (detectable difference,
  instances or seeds the observed difference would need), a property of the run's size.
- :func:`compare_with_floor`: a group's comparisons table with the rule applied, and its power
  table in F units, as the report's dimension, pooled and task sections all build them; and
  :func:`section_floor`, the group's one noise floor (the median of its blocks' floors), which
  the F-unit power sentence and the claim page print beside the rule's ``floor``.

A run with no valid evaluation (final F infinite or NaN) is left out of its block's mean, as
the report's F-unit power table leaves it out.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd

from benchmarks.protocol.statistics import (
    _check_frame,
    _check_level,
    paired_comparisons,
    power_analysis,
)
from benchmarks.reports.stats import t_interval

__all__ = [
    "EFFECT_COLUMNS",
    "TOLD_APART",
    "compare_with_floor",
    "floor_effects",
    "instance_floors",
    "section_floor",
    "separation_sentence",
    "told_apart",
]

#: The columns :func:`floor_effects` adds to a comparisons table (after ``a`` and ``b``).
EFFECT_COLUMNS: tuple[str, ...] = ("f_diff", "f_diff_low", "f_diff_high", "floor", "beyond_floor")

#: The comparisons table's column of :func:`told_apart`.
TOLD_APART = "told_apart"

_RUNS = ("instance", "optimizer", "seed", "final_f")
_RULE = ("mean_diff", "significant", "f_diff", "beyond_floor")


def _block_floors(floors: Mapping[str, float], blocks: list[str]) -> dict[str, float]:
    if not isinstance(floors, Mapping):
        raise TypeError(f"floors must map a block to its noise floor, got {type(floors).__name__}")
    out = {}
    for block in blocks:
        if block not in floors:
            raise ValueError(
                f"no noise floor for block {block!r}; floors has {sorted(map(str, floors))[:5]}"
                " (one per block of the runs)"
            )
        value = floors[block]
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float, np.integer, np.floating))
            or not math.isfinite(float(value))
            or float(value) <= 0
        ):
            raise ValueError(
                f"the noise floor of block {block!r} is {value!r}; it must be a finite F > 0"
            )
        out[block] = float(value)
    return out


def floor_effects(
    runs: pd.DataFrame, floors: Mapping[str, float], *, level: float = 0.95
) -> pd.DataFrame:
    """Per pair of optimizers: the paired final-F difference, its interval and the noise floor.

    Args:
        runs: One row per run: ``instance`` (the block's label), ``optimizer``, ``seed`` and
            ``final_f`` (the run's final best F; infinite or NaN: no valid evaluation, left
            out).
        floors: The noise floor of F of every block in ``runs`` (finite, > 0).
        level: Level of the Student t interval, in (0, 1).

    Returns:
        One row per pair (``a`` < ``b`` by name, as
        :func:`~benchmarks.protocol.statistics.paired_comparisons` orders them) with ``a``,
        ``b`` and :data:`EFFECT_COLUMNS`: ``f_diff`` = mean over the blocks both have of
        F(a) - F(b) (negative: a ends lower, better), its t interval (NaN with fewer than two
        blocks), ``floor`` the median of those blocks' floors and ``beyond_floor``.

    Raises:
        TypeError: ``runs`` is not a DataFrame or ``floors`` not a mapping.
        ValueError: A missing column, no row, a final F that is not a number, a block without
            a floor or with a floor that is not a finite F > 0, a level outside (0, 1).
    """
    _check_frame(runs, "runs", _RUNS)
    level = _check_level("level", level)
    try:
        final = runs["final_f"].to_numpy(dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("runs' column 'final_f' must hold numbers") from None
    runs = runs.assign(instance=runs["instance"].astype(str), final_f=final)
    block_floor = _block_floors(floors, sorted(runs["instance"].unique()))
    valid = runs[np.isfinite(final)]
    means = valid.groupby(["instance", "optimizer"])["final_f"].mean().unstack("optimizer")
    names = sorted(str(o) for o in runs["optimizer"].unique())
    rows = []
    for a, b in itertools.combinations(names, 2):
        both = (
            means[[a, b]].dropna()
            if a in means.columns and b in means.columns
            else pd.DataFrame(columns=[a, b])
        )
        diff = (both[a] - both[b]).to_numpy(dtype=np.float64)
        floor = (
            float(np.median([block_floor[str(k)] for k in both.index])) if diff.size else math.nan
        )
        row: dict[str, object] = {
            "a": a,
            "b": b,
            "f_diff": math.nan,
            "f_diff_low": math.nan,
            "f_diff_high": math.nan,
            "floor": floor,
            "beyond_floor": False,
        }
        if diff.size:
            row["f_diff"] = float(diff.mean())
        if diff.size >= 2:
            interval = t_interval(diff, level)
            row["f_diff_low"], row["f_diff_high"] = interval.low, interval.high
            row["beyond_floor"] = bool(interval.high < -floor or interval.low > floor)
        rows.append(row)
    return pd.DataFrame(rows, columns=["a", "b", *EFFECT_COLUMNS]).astype({"beyond_floor": bool})


def instance_floors(references: pd.DataFrame) -> dict[str, float]:
    """Each instance's noise floor pooled over its d: the mean of its (instance, d) floors.

    A pooled section averages an instance's d blocks, its final F too
    (:func:`~benchmarks.protocol.statistics.cluster_runs`), so its floor is the mean of its
    blocks' floors.

    Args:
        references: One row per (instance, d) cell with ``instance`` and ``noise floor``.

    Returns:
        The floor of every instance, by its label.

    Raises:
        TypeError: ``references`` is not a DataFrame.
        ValueError: A missing column.
    """
    if not isinstance(references, pd.DataFrame):
        raise TypeError(f"references must be a DataFrame, got {type(references).__name__}")
    missing = [c for c in ("instance", "noise floor") if c not in references.columns]
    if missing:
        raise ValueError(f"references lacks columns {missing}; needs ['instance', 'noise floor']")
    return {str(i): float(f.mean()) for i, f in references.groupby("instance")["noise floor"]}


def section_floor(floors: Mapping[str, float], blocks: Iterable[object] | None = None) -> float:
    """A group's one noise floor: the median of its blocks' floors (NaN without a block).

    The same floor :func:`floor_effects` gives a pair that has every block of the group.

    Args:
        floors: The noise floor of each block, by label (pooled: :func:`instance_floors`).
        blocks: The group's block labels (an iterable); None: every block in ``floors``.
    """
    if not isinstance(floors, Mapping):
        raise TypeError(f"floors must map a block to its noise floor, got {type(floors).__name__}")
    labels = [str(b) for b in floors] if blocks is None else sorted({str(b) for b in blocks})
    values = _block_floors(floors, labels) if labels else {}
    return float(np.median(list(values.values()))) if values else math.nan


def compare_with_floor(
    frame: pd.DataFrame, floors: Mapping[str, float], *, alpha: float
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """One group's comparisons with the rule applied, and its power table in F units.

    Args:
        frame: One row per run (or, pooled, per cluster-seed from
            :func:`~benchmarks.protocol.statistics.cluster_runs`) with ``instance``,
            ``optimizer``, ``seed``, ``score`` and ``final_f``.
        floors: The noise floor of every block of ``frame``.
        alpha: The family-wise level of the Holm-corrected comparisons.

    Returns:
        ``(table, in_f)``: :func:`~benchmarks.protocol.statistics.paired_comparisons` with
        :data:`EFFECT_COLUMNS` and :data:`TOLD_APART`; and
        :func:`~benchmarks.protocol.statistics.power_analysis` of the final F (a run with no
        valid evaluation, final F infinite, left out).
    """
    table = paired_comparisons(frame, alpha=alpha).merge(
        floor_effects(frame, floors), on=["a", "b"], how="left", validate="one_to_one"
    )
    table = table.assign(**{TOLD_APART: told_apart(table)})
    in_f = power_analysis(
        frame.assign(score=frame["final_f"].replace([np.inf, -np.inf], np.nan)), alpha=alpha
    )
    return table, in_f


def told_apart(comparisons: pd.DataFrame) -> pd.Series:
    """The rule: Holm-significant in score, final F beyond the floor, both the same way.

    Args:
        comparisons: A comparisons table with ``mean_diff`` (score a - b, positive: a
            sooner), ``significant`` (Holm p < alpha), ``f_diff`` (F a - b, negative: a
            lower) and ``beyond_floor``.

    Returns:
        A boolean Series on ``comparisons``' index: True where the pair is told apart.

    Raises:
        TypeError: ``comparisons`` is not a DataFrame.
        ValueError: A column is missing.
    """
    if not isinstance(comparisons, pd.DataFrame):
        raise TypeError(f"comparisons must be a DataFrame, got {type(comparisons).__name__}")
    missing = [c for c in _RULE if c not in comparisons.columns]
    if missing:
        raise ValueError(
            f"comparisons lacks columns {missing}; needs {list(_RULE)} (the protocol report's "
            "comparisons.csv has them)"
        )
    score = comparisons["mean_diff"].to_numpy(dtype=np.float64)
    f = comparisons["f_diff"].to_numpy(dtype=np.float64)
    agree = np.sign(score) * np.sign(f) < 0  # higher score, lower F
    rule = comparisons["significant"].astype(bool) & comparisons["beyond_floor"].astype(bool)
    return pd.Series(rule.to_numpy() & agree, index=comparisons.index, name=TOLD_APART)


def _g(value: float, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    if math.isinf(value):
        return "inf"
    return f"{value + 0.0:.{digits}g}"  # + 0.0: no "-0"


def _signed(value: float) -> str:
    return ("+" if value > 0 else "") + _g(value)


def _interval(row: pd.Series) -> str:
    return (
        f"{_signed(float(row['f_diff']))} [{_g(float(row['f_diff_low']))}, "
        f"{_g(float(row['f_diff_high']))}]"
    )


def _size(row: pd.Series, power: pd.DataFrame, unit: str) -> tuple[str, bool]:
    """What the run's size leaves open for a pair (F-unit power), and whether it detects at all."""
    found = power[(power["a"] == row["a"]) & (power["b"] == row["b"])]
    if found.empty:
        return "no power row", False
    p = found.iloc[0]
    floor = float(row["floor"])
    detectable = float(p["detectable"])
    parts = []
    if math.isfinite(detectable):
        parts.append(f"detects >= {_g(detectable)} ({_g(detectable / floor, 2)} floors)")
    needed = float(p["instances_needed"])
    seeds = float(p["seeds_needed"]) if "seeds_needed" in p.index else math.nan
    need = f"the observed {_g(abs(float(row['f_diff'])))} would need {_g(needed, 4)} {unit}"
    if math.isfinite(seeds):
        need += f" or {_g(seeds, 4)} seeds"
    parts.append(need)
    if abs(float(row["f_diff"])) <= floor:
        parts.append("mean within the floor")
    return "; ".join(parts), math.isfinite(detectable)


def separation_sentence(
    comparisons: pd.DataFrame,
    power: pd.DataFrame,
    *,
    group: str,
    alpha: float,
    unit: str = "blocks",
) -> str:
    """The verdict of one group of a protocol report, in one sentence built from its tables.

    Each pair is either told apart (:func:`told_apart`: its Holm p, its F difference with its
    interval and in floors), or not, and then (a) its F interval lies within +-floor: a
    property of the problem; or (b) not: a property of the run's size, with the F-unit power
    (the detectable difference, the instances or seeds the observed difference would need).
    A pair significant in score and beyond the floor the other way in F is named apart.

    Args:
        comparisons: The group's rows of the comparisons table (``a``, ``b``, ``mean_diff``,
            ``p_holm``, ``significant`` and :data:`EFFECT_COLUMNS`).
        power: The group's F-unit power rows (``a``, ``b``, ``min_n``, ``detectable``,
            ``instances_needed``, optionally ``seeds_needed``), as the report's ``power.csv``
            holds them with ``measure`` "final F".
        group: The group's name as the sentence opens with it (``"d = 5"``, ``"pooled"``).
        alpha: The Holm family's level.
        unit: What the group's blocks are, in words (``"instances"``).

    Returns:
        The sentence (markdown).

    Raises:
        TypeError: A table is not a DataFrame.
        ValueError: A column is missing.
    """
    if not isinstance(power, pd.DataFrame):
        raise TypeError(f"power must be a DataFrame, got {type(power).__name__}")
    rule = told_apart(comparisons)  # refuses a non-DataFrame and the rule's missing columns
    needs = ("a", "b", "p_holm", "floor", "f_diff_low", "f_diff_high")
    missing = [c for c in needs if c not in comparisons.columns]
    if missing:
        raise ValueError(f"comparisons lacks columns {missing}; needs {list(needs)}")
    missing = [c for c in ("a", "b", "min_n", "detectable", "instances_needed")
               if c not in power.columns]  # fmt: skip
    if missing:
        raise ValueError(f"power lacks columns {missing} (the report's F-unit power rows)")
    head = (
        f"**Verdict, {group}** (told apart: Holm p < {alpha:g} on the ECDF area AND the "
        f"final-F difference's 95 % t interval over {unit} wholly beyond +-the noise floor, "
        f"the median floor over {unit}; F difference a - b, negative: a ends lower)."
    )
    if comparisons.empty:
        return f"{head} No pair compared."
    told, problem, size, other = [], [], [], []
    detects = False
    for k, row in comparisons.iterrows():
        pair = f"{row['a']} ~ {row['b']}"
        floor = float(row["floor"])
        evidence = f"p_holm {_g(float(row['p_holm']), 2)}; F difference {_interval(row)}"
        if bool(rule.loc[k]):
            better, worse = (row["a"], row["b"]) if row["f_diff"] < 0 else (row["b"], row["a"])
            told.append(
                f"{better} better than {worse} ({evidence}, "
                f"{_g(float(row['f_diff']) / floor, 2)} floors of {_g(floor)})"
            )
        elif math.isnan(float(row["f_diff_low"])):
            other.append(f"{pair} (no F interval: fewer than two {unit})")
        elif -floor <= float(row["f_diff_low"]) and float(row["f_diff_high"]) <= floor:
            problem.append(f"{pair} ({evidence}, floor {_g(floor)})")
        elif bool(row["significant"]) and bool(row["beyond_floor"]):
            other.append(f"{pair} ({evidence}: the ECDF area and the final F disagree in sign)")
        else:
            text, finite = _size(row, power, unit)
            detects = detects or finite
            size.append(f"{pair} ({evidence}, floor {_g(floor)}; {text})")
    sentence = f"{head} Told apart: {'; '.join(told) if told else 'none'}."
    if problem:
        sentence += (
            " Not told apart, a property of the problem (the F difference's interval lies "
            "within +-floor: the optimizers' final designs differ by less than the "
            f"measurement's noise): {'; '.join(problem)}."
        )
    if size:
        if detects:
            why = "the F-unit power at 80 %: the smallest F difference the run detects"
        else:
            min_n = int(power["min_n"].max()) if len(power) else 0
            why = (
                f"with fewer than {min_n} {unit} the test detects no difference at all, however "
                "large"
            )
        sentence += (
            " Not told apart, a property of the run's size (the interval is not within "
            f"+-floor; {why}): {'; '.join(size)}."
        )
    if other:
        sentence += f" Not told apart otherwise: {'; '.join(other)}."
    return sentence
