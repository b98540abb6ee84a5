"""The protocol's statistics: paired comparisons, ranking stability and power.

The unit of comparison is the **instance**: every optimizer runs every instance with the same
seeds, a run's score is one number (the area under its ECDF over the instance's targets, or its
normalized regret at the budget), and an optimizer's score on an instance is the mean over its
seeds. Comparisons are therefore paired by instance.

- :func:`paired_comparisons`: for each pair of optimizers, the Wilcoxon signed-rank test of the
  per-instance differences (two-sided), Holm-corrected over the pairs
  (:func:`benchmarks.reports.stats.holm_bonferroni`), the mean difference with its Student t
  interval over instances (:func:`benchmarks.reports.stats.t_interval`; the percentile
  bootstrap covers too little with few instances), and the standardized effect
  d_z = mean / SD of the differences with a percentile bootstrap interval over instances
  (``d_z_low``, ``d_z_high``: no t interval exists for a ratio; with few instances it is
  rough and may be infinite, where a resample's differences are all equal).
- :func:`cluster_runs`: the runs of a pooled section collapsed to one row per instance,
  optimizer and seed, the mean over the instance's blocks (its dimensions, with the task axis
  its task's dimensions): an instance's blocks are not independent, so the pooled test pairs
  instances (n = instances) and the ranking resamples instances with all their blocks.
- :func:`held_out_gap`: per optimizer, the mean score on held-out instances minus that on
  public ones, with a Welch t interval over instances (to see tuning to the public set).
- :func:`ladder_quality` and :func:`weak_cell_sensitivity`: whether a cell's target ladder is
  weak (its reference's noise floor is a large part of the ladder's span, or random sampling
  at the budget reaches its last target), and the comparisons and ranking without such cells.
- :func:`rank_stability`: the probability of each rank for each optimizer when instances are
  resampled with replacement and, within each drawn instance, each optimizer's seeds too.
- :func:`power_analysis`: per pair, the smallest difference of means the run detects at 80 %
  power, and how many instances, or seeds per instance, a wanted difference needs.

**What the test can detect at all.** The exact signed-rank test of n pairs cannot give a
two-sided p below 2 / 2^n (every difference of the same sign). Holm's first step compares the
smallest p with alpha / m over m pairs, so with fewer than :func:`min_instances` (alpha, m)
instances no pair can ever be significant, whatever the difference: 11 instances for the
protocol's alpha = 0.01 and the 6 pairs of four optimizers. Below it the detectable difference
is ``inf`` and no number of seeds helps. At or above it, for normal paired differences of SD
s_d, the detectable difference is what the exact test itself reaches with ``power``
(n <= 50, where SciPy's test is exact): the statistic T+ of differences shifted by delta
reaches the exact critical value c (the smallest with P(T+ >= c) < alpha / 2m under the null)
exactly when delta exceeds minus the c-th largest Walsh average of the unshifted differences,
so the detectable delta is the ``power`` quantile of that value over 4000 seeded normal draws
(no approximation but the Monte Carlo one). Near the minimum n the test's discreteness
matters: there the paired t approximation with the signed-rank test's efficiency 3 / pi
reaches only 55 % power at n = 11 and 68 % at n = 12 instead of 80 %. Above 50 instances (the
test is then the normal approximation) it is that approximation, an effective
``n_eff = 3 n / pi`` instances and

    detectable = (t_(1 - alpha / 2m, n - 1) + t_(power, n - 1)) s_d / sqrt(n_eff)

The instances a wanted difference needs are the smallest n >= :func:`min_instances` for which
the detectable difference is at most the wanted one. The SD of a paired difference of seed
means is split into an instance-by-optimizer part and a seed part,
``s_d^2 = s_int^2 + (v_a + v_b) / S`` with ``v`` the within-instance variance over seeds and
S the seeds: more seeds shrink only the second part, more instances shrink both.

Bad input (an alpha, power, level or resample count out of range, a score that is infinite)
is refused with a ValueError naming the value; a NaN score is a missing run and is left out.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.reports.measures import COMPARISON_COLUMNS, paired_table

__all__ = [
    "COMPARISON_COLUMNS",
    "WEAK_LADDER_FRACTION",
    "WILCOXON_ARE",
    "cluster_runs",
    "detectable_difference",
    "held_out_gap",
    "instances_needed",
    "ladder_quality",
    "min_instances",
    "paired_comparisons",
    "power_analysis",
    "rank_stability",
    "weak_cell_sensitivity",
]

#: Asymptotic relative efficiency of the signed-rank test to the t test for normal data.
WILCOXON_ARE = 3.0 / math.pi

_SCORES = ("instance", "optimizer", "seed", "score")

#: The largest sample size the power functions search (a wanted difference that needs more is
#: reported as ``inf``).
_N_MAX = 10**7

#: Up to this many pairs SciPy's signed-rank test is exact, and so is the power computed here.
_EXACT_MAX = 50

#: Normal draws of the power computation at n <= :data:`_EXACT_MAX` (seeded: reproducible).
_DRAWS = 4000


def _check_frame(frame: Any, name: str, columns: Sequence[str]) -> None:
    """Refuse ``frame`` (the argument ``name``) unless it is a DataFrame with rows and ``columns``.

    Raises:
        TypeError: not a DataFrame.
        ValueError: a missing column (named, with all it needs), or no row.
    """
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"{name} must be a DataFrame, got {type(frame).__name__}")
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ValueError(f"{name} lacks columns {missing}; needs {list(columns)}")
    if frame.empty:
        raise ValueError(f"{name} holds no row")


def _check_scores(scores: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``scores`` with a score (NaN: a missing run); infinite scores refused."""
    _check_frame(scores, "scores", _SCORES)
    try:
        values = scores["score"].to_numpy(dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("scores' column 'score' must hold numbers") from None
    infinite = np.isinf(values)
    if infinite.any():
        row = scores[infinite].iloc[0]
        raise ValueError(
            f"score of optimizer {row['optimizer']!r} on instance {row['instance']!r} is "
            f"{row['score']!r}; scores must be finite numbers (NaN for a missing run)"
        )
    kept = scores[~np.isnan(values)]
    if kept.empty:
        raise ValueError("scores holds no row with a score (every score is NaN)")
    return kept.assign(score=values[~np.isnan(values)])


def _check_level(name: str, value: object) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float, np.integer, np.floating))
        or not 0 < float(value) < 1
    ):
        raise ValueError(f"{name} must be a number in (0, 1), got {value!r}")
    return float(value)


def _check_count(name: str, value: object, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")
    return int(value)


def _check_power_args(alpha: float, power: float, tests: int) -> None:
    _check_level("alpha", alpha)
    _check_level("power", power)
    _check_count("tests", tests)


def min_instances(alpha: float = 0.01, tests: int = 1) -> int:
    """Fewest pairs for which the exact signed-rank test can pass Holm's first step.

    The smallest two-sided p of n pairs is 2 / 2^n; Holm rejects the smallest of ``tests``
    p-values when ``tests * p < alpha``. With fewer pairs than this no difference, however
    large, is significant.

    Args:
        alpha: Family-wise level, in (0, 1).
        tests: Tests m in the Holm family, >= 1.

    Returns:
        The smallest n with ``tests * 2 / 2^n < alpha`` (11 for alpha 0.01 and 6 tests).
    """
    _check_level("alpha", alpha)
    _check_count("tests", tests)
    n = 1
    while tests * 2.0 ** (1 - n) >= alpha:
        n += 1
    return n


def _quantiles(n: int, alpha: float, power: float, tests: int) -> float:
    """t_(1 - alpha/2m, n-1) + t_(power, n-1): the multiplier of s_d / sqrt(n_eff)."""
    from scipy.stats import t

    df = max(n - 1, 1)
    return float(t.ppf(1 - alpha / (2 * tests), df) + t.ppf(power, df))


def _critical(n: int, level: float) -> int:
    """The smallest c with P(T+ >= c) < level for the exact null distribution of n pairs."""
    top = n * (n + 1) // 2
    counts = [1] + [0] * top  # subsets of {1..k} by their sum, k = 0..n
    for k in range(1, n + 1):
        for total in range(top, k - 1, -1):
            counts[total] += counts[total - k]
    tail = 0
    bound = level * 2**n
    for c in range(top, -1, -1):
        if tail + counts[c] >= bound:
            return c + 1
        tail += counts[c]
    return 0


@functools.lru_cache(maxsize=512)
def _multiplier(n: int, alpha: float, power: float, tests: int) -> float:
    """Detectable difference per unit SD of the paired differences (module doc)."""
    if n < min_instances(alpha, tests):
        return math.inf
    if n > _EXACT_MAX:
        return _quantiles(n, alpha, power, tests) / math.sqrt(WILCOXON_ARE * n)
    c = _critical(n, alpha / (2 * tests))
    rng = np.random.default_rng(np.random.SeedSequence(32, spawn_key=(n,)))
    z = rng.standard_normal((_DRAWS, n))
    i, j = np.triu_indices(n)
    walsh = (z[:, i] + z[:, j]) / 2  # T+ of z + delta = number of Walsh averages above -delta
    k = walsh.shape[1] - c
    needed = -np.partition(walsh, k, axis=1)[:, k]  # the c-th largest, negated
    return float(np.quantile(needed, power))


def detectable_difference(
    sd: float, n: int, *, alpha: float = 0.05, power: float = 0.8, tests: int = 1
) -> float:
    """Smallest paired mean difference the signed-rank test detects with ``power``.

    ``inf`` when ``n`` < :func:`min_instances` (alpha, tests): the test can then never reach
    Holm's first-step level. Otherwise, for normal differences, the exact test's power at
    n <= 50 and (t_(1-a/2m, n-1) + t_(power, n-1)) sd / sqrt(3 n / pi) above (the module doc).

    Args:
        sd: SD of the paired differences (one per instance), finite, >= 0.
        n: Instances (pairs), >= 1.
        alpha: Family-wise level, in (0, 1).
        power: Wanted power, in (0, 1).
        tests: Tests m in the Holm family (the first step is at alpha / m).
    """
    _check_power_args(alpha, power, tests)
    _check_count("n", n)
    if (
        isinstance(sd, bool)
        or not isinstance(sd, (int, float, np.integer, np.floating))
        or not math.isfinite(sd)
        or sd < 0
    ):
        raise ValueError(f"sd must be a finite number >= 0, got {sd!r}")
    factor = _multiplier(int(n), float(alpha), float(power), int(tests))
    return math.inf if math.isinf(factor) else factor * float(sd)


def instances_needed(
    sd: float, difference: float, *, alpha: float = 0.05, power: float = 0.8, tests: int = 1
) -> float:
    """Instances a paired signed-rank test needs to detect ``difference`` with ``power``.

    At least :func:`min_instances` (alpha, tests): fewer can never be significant. ``inf`` if
    more than 10^7 would be needed.
    """
    _check_power_args(alpha, power, tests)
    for name, value, low in (("sd", sd, 0.0), ("difference", difference, None)):
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float, np.integer, np.floating))
            or not math.isfinite(value)
            or (value < low if low is not None else value <= 0)
        ):
            allowed = "a finite number >= 0" if low is not None else "a finite number > 0"
            raise ValueError(f"{name} must be {allowed}, got {value!r}")
    return _needed(float(sd), float(difference), float(alpha), float(power), int(tests))


def _needed(sd: float, difference: float, alpha: float, power: float, tests: int) -> float:
    floor = min_instances(alpha, tests)
    if sd == 0:
        return floor

    def enough(n: int) -> bool:
        return _multiplier(n, alpha, power, tests) * sd <= difference

    for n in range(floor, _EXACT_MAX + 1):
        if enough(n):
            return n
    from scipy.stats import norm

    z = float(norm.ppf(1 - alpha / (2 * tests)) + norm.ppf(power))
    # The t quantiles exceed the normal ones: the normal formula is a lower bound to start at.
    low = max(floor, _EXACT_MAX + 1, math.ceil((z * sd / difference) ** 2 / WILCOXON_ARE))
    if enough(low):
        return low
    high = low
    while not enough(high):  # detectable falls with n: double until it is reached, then bisect
        low, high = high, high * 2
        if high > _N_MAX:
            return math.inf
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if enough(mid) else (mid, high)
    return high


def _instance_means(scores: pd.DataFrame) -> pd.DataFrame:
    table = scores.groupby(["instance", "optimizer"])["score"].mean().unstack("optimizer")
    return table


def paired_comparisons(
    scores: pd.DataFrame,
    *,
    alpha: float = 0.01,
    level: float = 0.95,
    resamples: int = 2000,
    rng: np.random.Generator | int | None = 0,
) -> pd.DataFrame:
    """Every pair of optimizers compared on the instances both ran, Holm-corrected.

    Args:
        scores: One row per run: ``instance``, ``optimizer``, ``seed``, ``score`` (finite; NaN
            for a missing run, left out).
        alpha: Family-wise level of ``significant``, in (0, 1).
        level: Level of the Student t interval of the mean difference and of the bootstrap
            interval of d_z, in (0, 1).
        resamples: Bootstrap resamples of the instances for d_z's interval, an int >= 1.
        rng: Seed or generator of that bootstrap.

    Returns:
        One row per pair with :data:`COMPARISON_COLUMNS`, then ``d_z_low`` and ``d_z_high``;
        ``mean_diff`` is mean(a - b) over instances, ``ci_low``/``ci_high`` its t interval
        (:func:`benchmarks.reports.stats.t_interval`), ``d_z_low``/``d_z_high`` the percentile
        bootstrap interval of d_z over instances (NaN below 3 instances).
    """
    scores = _check_scores(scores)
    _check_level("alpha", alpha)
    _check_level("level", level)
    resamples = _check_count("resamples", resamples)
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    means = _instance_means(scores)
    table = paired_table(means, alpha=alpha, level=level)
    bounds = [
        _d_z_interval(
            (means[a] - means[b]).dropna().to_numpy(dtype=np.float64), level, resamples, generator
        )
        for a, b in zip(table["a"], table["b"], strict=True)
    ]
    table["d_z_low"] = [low for low, _ in bounds]
    table["d_z_high"] = [high for _, high in bounds]
    return table


def _d_z_interval(
    diff: np.ndarray, level: float, resamples: int, generator: np.random.Generator
) -> tuple[float, float]:
    """Percentile bootstrap interval of d_z = mean / SD over resampled instances.

    NaN below 3 instances (a resample of 2 has SD 0 half the time). A resample whose
    differences are all equal has d_z = +-inf (0 when they are all 0); the bounds are the
    order statistics at the two tails (no interpolation, which an infinite value would spoil).
    """
    n = diff.size
    if n < 3:
        return math.nan, math.nan
    drawn = diff[generator.integers(0, n, size=(resamples, n))]
    mean = drawn.mean(axis=1)
    sd = drawn.std(axis=1, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        # np.sign(0) * inf is NaN, which would spoil every quantile: an all-zero resample is 0.
        tied = np.where(mean == 0, 0.0, np.sign(mean) * np.inf)
        d_z = np.where(sd > 0, mean / np.where(sd > 0, sd, 1.0), tied)
    tail = (1 - level) / 2
    low = float(np.quantile(d_z, tail, method="lower"))
    high = float(np.quantile(d_z, 1 - tail, method="higher"))
    return low, high


def rank_stability(
    scores: pd.DataFrame,
    *,
    higher_is_better: bool = True,
    resamples: int = 2000,
    rng: np.random.Generator | int | None = 0,
) -> pd.DataFrame:
    """P(rank k) of each optimizer under resampling of instances and seeds.

    Each resample draws the instances with replacement and, for every drawn instance and
    optimizer, that optimizer's seeds with replacement; optimizers are ranked by the mean of
    their resampled scores (1 = best). Instance and optimizer ids are used as they are (str or
    int alike).

    Args:
        scores: One row per run (see :func:`paired_comparisons`).
        higher_is_better: Rank high scores first.
        resamples: Resamples, an int >= 1.
        rng: Seed or generator.

    Returns:
        A table optimizer x rank (1..k) of probabilities, rows in the order of the full data's
        ranking, with a column ``rank`` (the full data's rank) and ``mean`` (its mean score).
    """
    scores = _check_scores(scores)
    resamples = _check_count("resamples", resamples)
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    optimizers = sorted(scores["optimizer"].unique())
    instances = sorted(scores["instance"].unique())
    cells: dict[tuple[object, object], np.ndarray] = {
        (i, o): g["score"].to_numpy(dtype=np.float64)
        for (i, o), g in scores.groupby(["instance", "optimizer"])
    }
    missing = [(i, o) for i in instances for o in optimizers if (i, o) not in cells]
    if missing:
        raise ValueError(f"every optimizer must have runs on every instance; missing {missing[:3]}")
    sign = -1.0 if higher_is_better else 1.0
    k = len(optimizers)
    counts = np.zeros((k, k))
    for _ in range(resamples):
        drawn = generator.integers(0, len(instances), size=len(instances))
        means = np.zeros(k)
        for j, o in enumerate(optimizers):
            total = 0.0
            for i in drawn:
                seeds = cells[(instances[i], o)]
                total += seeds[generator.integers(0, seeds.size, size=seeds.size)].mean()
            means[j] = total / len(drawn)
        order = np.argsort(sign * means, kind="stable")
        counts[order, np.arange(k)] += 1
    full = np.array([np.mean([cells[(i, o)].mean() for i in instances]) for o in optimizers])
    full_order = np.argsort(sign * full, kind="stable")
    table = pd.DataFrame(
        counts / resamples, index=optimizers, columns=[f"P(rank {r})" for r in range(1, k + 1)]
    )
    table["mean"] = full
    table["rank"] = 0
    table.loc[[optimizers[j] for j in full_order], "rank"] = np.arange(1, k + 1)
    return table.sort_values("rank")


def power_analysis(
    scores: pd.DataFrame,
    *,
    alpha: float = 0.01,
    power: float = 0.8,
    wanted: Sequence[float] = (),
) -> pd.DataFrame:
    """Per pair: the smallest difference detectable at ``power``, and the size a wanted one needs.

    Args:
        scores: One row per run: ``instance``, ``optimizer``, ``seed``, ``score``.
        alpha: Family-wise level, in (0, 1) (Holm over all pairs: the first step is at
            alpha / m).
        power: Wanted power, in (0, 1).
        wanted: Differences of mean score to size for, finite and > 0; ``[]`` uses the pair's
            own observed difference.

    Returns:
        One row per pair (and wanted difference): ``n`` instances, ``min_n`` (the fewest
        instances with which the exact signed-rank test can pass Holm's first step,
        :func:`min_instances`), ``separable`` (n >= min_n), ``seeds`` (median per instance and
        optimizer), ``sd_diff`` (SD of the per-instance differences), ``sd_instance`` and
        ``sd_seed`` (its two parts, see the module doc), ``observed`` difference,
        ``detectable`` difference (``inf`` when n < min_n), ``wanted``, ``instances_needed``
        (never below min_n) and ``seeds_needed`` (at the present instances; ``inf`` when more
        seeds alone cannot reach it, as always when n < min_n; NaN, like ``sd_seed``, with one
        seed per instance, where the seed variance is unknown).
    """
    scores = _check_scores(scores)
    alpha = _check_level("alpha", alpha)
    power = _check_level("power", power)
    if isinstance(wanted, (str, bytes)) or not isinstance(wanted, Sequence):
        raise ValueError(f"wanted must be a sequence of differences, got {wanted!r}")
    for want in wanted:
        if (
            isinstance(want, bool)
            or not isinstance(want, (int, float, np.integer, np.floating))
            or not math.isfinite(want)
            or want <= 0
        ):
            raise ValueError(f"wanted differences must be finite numbers > 0, got {want!r}")
    means = _instance_means(scores)
    variances = scores.groupby(["instance", "optimizer"])["score"].var(ddof=1)
    seeds = scores.groupby(["instance", "optimizer"])["score"].size()
    pairs = list(itertools.combinations(sorted(means.columns), 2))
    tests = max(1, len(pairs))
    floor = min_instances(alpha, tests)
    rows = []
    for a, b in pairs:
        both = means[[a, b]].dropna()
        diff = (both[a] - both[b]).to_numpy()
        n = diff.size
        if n < 2:
            continue
        s = float(np.median(seeds.loc[list(both.index)].to_numpy()))
        v = 0.0
        for o in (a, b):
            per = variances.xs(o, level="optimizer").reindex(both.index).to_numpy(dtype=float)
            # One seed per instance: the seed variance cannot be told from the instances'.
            v += float(np.nanmean(per)) if np.isfinite(per).any() else math.nan
        sd = float(diff.std(ddof=1))
        seed_part = v / s
        inst_part = max(sd**2 - seed_part, 0.0) if math.isfinite(seed_part) else math.nan
        observed = abs(float(diff.mean()))
        separable = n >= floor
        factor = _multiplier(n, alpha, power, tests)  # detectable per unit SD; inf if not
        targets = list(wanted) if wanted else [observed]
        for want in targets:
            row = {
                "a": a,
                "b": b,
                "n": n,
                "min_n": floor,
                "separable": separable,
                "seeds": s,
                "sd_diff": sd,
                "sd_instance": math.sqrt(inst_part) if math.isfinite(inst_part) else math.nan,
                "sd_seed": math.sqrt(seed_part) if math.isfinite(seed_part) else math.nan,
                "observed": observed,
                "detectable": factor * sd if separable else math.inf,
                "wanted": float(want),
            }
            if want > 0 and sd > 0:
                row["instances_needed"] = _needed(sd, float(want), alpha, power, tests)
                if not math.isfinite(v):
                    row["seeds_needed"] = math.nan  # unknown with one seed per instance
                elif not separable:
                    row["seeds_needed"] = math.inf  # seeds cannot lower the smallest p
                else:
                    room = (want / factor) ** 2 - inst_part  # s_int^2 + v / S must fit in it
                    row["seeds_needed"] = math.ceil(v / room) if room > 0 and v > 0 else math.inf
            else:
                row["instances_needed"] = math.nan
                row["seeds_needed"] = math.nan
            rows.append(row)
    return pd.DataFrame(rows)


#: A cell's target ladder is weak when its reference's noise floor exceeds this fraction of the
#: ladder's span (median random F - F_ref; docs/protocol.md, References).
WEAK_LADDER_FRACTION = 0.25


def _number(name: str, value: object) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float, np.integer, np.floating))
        or not math.isfinite(value)
    ):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def ladder_quality(
    f_ref: float,
    f_random_median: float,
    floor: float,
    f_random_budget: float,
    *,
    fraction: float = WEAK_LADDER_FRACTION,
) -> dict[str, float | bool]:
    """How much of a cell's target ladder lies above its reference's noise.

    The ladder runs from the median F of a random design down to ``F_ref + floor``
    (:func:`benchmarks.protocol.measures.target_ladder`). It is **weak** when the floor exceeds
    ``fraction`` of its span (``f_random_median - f_ref``: the targets are then squeezed into
    the top of the span, a reference that is the luckiest of many noisy draws) or when random
    sampling's expected best at the budget already reaches the last target (every optimizer
    then reaches every target: the cell adds ties, not information).

    Args:
        f_ref: The reference F.
        f_random_median: Median F of a random design (the first target).
        floor: The reference's noise floor (> 0).
        f_random_budget: F_random at the run budget.
        fraction: The share of the span above which the floor makes a ladder weak, in (0, 1).

    Returns:
        ``floor_pct_ref`` (100 floor / |F_ref|, inf when F_ref = 0), ``floor_share`` (floor /
        span; inf when the span is not positive), and ``weak``.

    Raises:
        ValueError: A value that is not a finite number, ``floor <= 0``, or ``fraction``
            outside (0, 1).
    """
    f_ref = _number("f_ref", f_ref)
    median = _number("f_random_median", f_random_median)
    floor = _number("floor", floor)
    at_budget = _number("f_random_budget", f_random_budget)
    fraction = _check_level("fraction", fraction)
    if floor <= 0:
        raise ValueError(f"floor must be > 0 (an F difference), got {floor!r}")
    span = median - f_ref
    share = floor / span if span > 0 else math.inf
    return {
        "floor_pct_ref": 100.0 * floor / abs(f_ref) if f_ref != 0 else math.inf,
        "floor_share": share,
        "weak": bool(share > fraction or at_budget <= f_ref + floor),
    }


def cluster_runs(
    scores: pd.DataFrame, *, cluster: str = "instance", blocks: Sequence[str] = ("degree",)
) -> pd.DataFrame:
    """One row per (cluster, optimizer, seed): a seed's mean score over the cluster's blocks.

    A pooled section's blocks (an instance at each d) are not independent: one instance's
    blocks share its goal, mass and friction. Averaging them per instance first makes the
    instance the unit again: :func:`paired_comparisons` then pairs instances (n = instances),
    :func:`power_analysis` sizes in instances, and :func:`rank_stability` resamples instances
    each with all its blocks (the k-th seed of every block stays together; the seeds of
    different blocks are independent runs, so which one is k-th does not matter).

    Args:
        scores: One row per run with ``optimizer``, ``seed``, ``score``, the ``cluster``
            column and the ``blocks`` columns; ``final_f`` and ``set`` are carried when present
            (the mean, and the cluster's one value). NaN scores (missing runs) are left out. A
            seed whose final F is infinite in one block (no valid evaluation) has an infinite
            mean final F, so that cluster-seed drops out of F statistics that keep finite values.
        cluster: The column naming the unit that is resampled and paired.
        blocks: The columns that tell a cluster's blocks apart; ``"instance"`` may be one of
            them when ``cluster`` is another column (e.g. ``cluster="task"``).

    Returns:
        A frame with ``instance`` (the cluster's label), ``optimizer``, ``seed`` (0-based
        index: the k-th seed of each block, by seed value), ``score``, ``blocks`` (how many
        were averaged) and ``final_f`` / ``set`` where given.

    Raises:
        ValueError: A missing column; optimizers with different blocks in one cluster (their
            means would be over different blocks, yet paired as the same unit); or an optimizer
            with different numbers of seeds in the blocks of one cluster (the mean would weigh
            the blocks unequally).
    """
    if not isinstance(scores, pd.DataFrame):
        raise TypeError(f"scores must be a DataFrame, got {type(scores).__name__}")
    if not isinstance(cluster, str):
        raise TypeError(f"cluster must be a column name (str), got {cluster!r}")
    if isinstance(blocks, str) or not isinstance(blocks, Sequence):
        raise ValueError(f"blocks must be a sequence of column names, got {blocks!r}")
    if not all(isinstance(b, str) for b in blocks):
        raise TypeError(f"blocks must be column names (str), got {blocks!r}")
    if cluster in blocks:
        raise ValueError(f"cluster {cluster!r} cannot also be a block column {list(blocks)}")
    needed = [cluster, *blocks, "optimizer", "seed", "score"]
    missing = [c for c in needed if c not in scores.columns]
    if missing:
        raise ValueError(f"scores lacks columns {missing}; needs {needed}")
    # Group on a temporary key, so a block column named "instance" keeps its values.
    frame = scores.assign(_cluster=scores[cluster])
    if "instance" not in frame.columns:
        frame = frame.assign(instance=frame[cluster])
    kept = _check_scores(frame)
    keys = ["_cluster", *blocks, "optimizer"]
    kept = kept.sort_values([*keys, "seed"], kind="stable")
    per_block = kept.groupby(keys).size()
    for name, part in per_block.groupby(level="_cluster"):
        have = {
            optimizer: set(rows.index.droplevel(["_cluster", "optimizer"]))
            for optimizer, rows in part.groupby(level="optimizer")
        }
        every = set().union(*have.values())
        for optimizer, own in have.items():
            if own != every:
                raise ValueError(
                    f"optimizer {optimizer!r} lacks blocks {sorted(every - own)} of "
                    f"{blocks} in {cluster} {name!r} that other optimizers have; every "
                    "optimizer needs the same blocks in a cluster"
                )
    spread = per_block.groupby(["_cluster", "optimizer"]).agg(["min", "max"])
    uneven = spread[spread["min"] != spread["max"]]
    if not uneven.empty:
        (name, optimizer), row = next(iter(uneven.iterrows()))
        raise ValueError(
            f"optimizer {optimizer!r} has {row['min']} to {row['max']} seeds in the blocks of "
            f"{cluster} {name!r}; every block of a cluster needs the same seeds"
        )
    kept = kept.assign(seed=kept.groupby(keys).cumcount())
    group = kept.groupby(["_cluster", "optimizer", "seed"], sort=True)
    out = group["score"].mean().to_frame()
    out["blocks"] = group.size()
    if "final_f" in kept.columns:
        out["final_f"] = group["final_f"].mean()
    if "set" in kept.columns:
        out["set"] = group["set"].first()
    return out.reset_index().rename(columns={"_cluster": "instance"})


def held_out_gap(scores: pd.DataFrame, *, level: float = 0.95) -> pd.DataFrame:
    """Per optimizer: mean score on held-out instances minus that on public ones.

    An instance's score is its mean over its runs (seeds, and dimensions where ``scores`` holds
    several). The two sets are different instances, so the interval is Welch's t interval of a
    difference of two independent means over instances (NaN with fewer than two instances in
    a set). A gap well below the built-ins' says an optimizer was tuned to the public set.

    Args:
        scores: One row per run with ``instance``, ``optimizer``, ``set`` (``public`` or
            ``held-out``) and ``score``.
        level: Level of the interval, in (0, 1).

    Returns:
        One row per optimizer: ``public`` and ``held-out`` (mean scores), ``n_public``,
        ``n_held_out``, ``gap`` (held-out - public), ``gap_low``, ``gap_high``.

    Raises:
        ValueError: A missing column, a set other than public and held-out, an instance in
            both sets, or ``level`` outside (0, 1).
    """
    from scipy.stats import t

    if not isinstance(scores, pd.DataFrame):
        raise TypeError(f"scores must be a DataFrame, got {type(scores).__name__}")
    level = _check_level("level", level)
    needed = ["instance", "optimizer", "set", "score"]
    missing = [c for c in needed if c not in scores.columns]
    if missing:
        raise ValueError(f"scores lacks columns {missing}; needs {needed}")
    sets = {"public", "held-out"}
    other = sorted(set(map(str, scores["set"].unique())) - sets)
    if other:
        raise ValueError(f"set must be 'public' or 'held-out', got {other[0]!r}")
    both = scores.groupby("instance")["set"].nunique()
    if (both > 1).any():
        raise ValueError(f"instance {both[both > 1].index[0]!r} is in both sets")
    kept = _check_scores(scores.assign(seed=0) if "seed" not in scores.columns else scores)
    rows = []
    for optimizer, frame in kept.groupby("optimizer", sort=True):
        per = frame.groupby(["set", "instance"])["score"].mean()
        public = per.xs("public").to_numpy() if "public" in per.index else np.zeros(0)
        held = per.xs("held-out").to_numpy() if "held-out" in per.index else np.zeros(0)
        row: dict[str, object] = {
            "optimizer": optimizer,
            "public": float(public.mean()) if public.size else math.nan,
            "held-out": float(held.mean()) if held.size else math.nan,
            "n_public": int(public.size),
            "n_held_out": int(held.size),
        }
        gap = float(row["held-out"]) - float(row["public"])  # type: ignore[arg-type]
        low = high = math.nan
        if public.size >= 2 and held.size >= 2:
            vp, vh = public.var(ddof=1) / public.size, held.var(ddof=1) / held.size
            se = math.sqrt(vp + vh)
            if se > 0:
                df = (vp + vh) ** 2 / (vp**2 / (public.size - 1) + vh**2 / (held.size - 1))
                half = float(t.ppf((1 + level) / 2, df)) * se
            else:
                half = 0.0
            low, high = gap - half, gap + half
        row.update(gap=gap, gap_low=low, gap_high=high)
        rows.append(row)
    return pd.DataFrame(rows)


def _order(scores: pd.DataFrame) -> list[str]:
    """The optimizers by mean score over instances, best first."""
    means = _instance_means(scores).mean(axis=0)
    return [str(o) for o in means.sort_values(ascending=False, kind="stable").index]


def weak_cell_sensitivity(
    scores: pd.DataFrame,
    weak: Sequence[tuple[str, int]],
    *,
    alpha: float = 0.01,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The comparisons and ranking of each dimension and pooled, with and without weak cells.

    Each group is compared as the report compares it (per dimension: paired by instance;
    pooled: :func:`cluster_runs` first, paired by instance), once on every cell and once
    without the ``weak`` cells (:func:`ladder_quality`).

    Args:
        scores: One row per run with ``instance``, ``degree``, ``optimizer``, ``seed``,
            ``score``.
        weak: The (instance, d) cells to leave out.
        alpha: Family-wise level of ``significant``, in (0, 1).

    Returns:
        ``(comparisons, ranking)``. ``comparisons``: per group ``d`` (a degree as text, or
        ``"all"``) and pair, ``n``, ``p_holm`` and ``significant`` on every cell, the same with
        the suffix ``_without`` (NaN / None where fewer than two instances are left), and
        ``changed`` (the verdict differs). ``ranking``: per group, the order of the optimizers
        by mean score (best first) on every cell and without the weak cells, and ``changed``.

    Raises:
        ValueError: A missing column, ``weak`` not a sequence, or a weak cell that is not an
            (instance, int d) pair.
    """
    if not isinstance(scores, pd.DataFrame):
        raise TypeError(f"scores must be a DataFrame, got {type(scores).__name__}")
    alpha = _check_level("alpha", alpha)
    if "degree" not in scores.columns:
        raise ValueError("scores lacks column 'degree'")
    if isinstance(weak, (str, bytes)) or not isinstance(weak, Sequence):
        raise ValueError(
            f"weak must be a sequence of (instance, d) cells (empty for none), got {weak!r}"
        )
    cells: set[tuple[str, int]] = set()
    for cell in weak:
        if (
            not isinstance(cell, tuple)
            or len(cell) != 2
            or isinstance(cell[1], bool)
            or not isinstance(cell[1], (int, np.integer))
        ):
            raise ValueError(
                f"a weak cell must be an (instance, d) pair with an int d, got {cell!r}"
            )
        cells.add((str(cell[0]), int(cell[1])))
    scores = _check_scores(scores)
    dropped = np.array(
        [
            (str(i), int(d)) in cells
            for i, d in zip(scores["instance"], scores["degree"], strict=True)
        ],
        dtype=bool,
    )
    degrees = sorted(int(d) for d in scores["degree"].unique())
    comparisons, rankings = [], []
    for label in [*map(str, degrees), "all"]:
        frames = []
        for mask in (np.ones(len(scores), dtype=bool), ~dropped):
            frame = scores[mask]
            if label != "all":
                frame = frame[frame["degree"] == int(label)]
            elif not frame.empty:
                frame = cluster_runs(frame)
            frames.append(frame)
        tables: list[pd.DataFrame | None] = []
        for frame in frames:
            if frame.empty or frame["instance"].nunique() < 2 or frame["optimizer"].nunique() < 2:
                tables.append(None)
            else:
                tables.append(paired_comparisons(frame, alpha=alpha, resamples=1))
        full, without = tables
        if full is None:
            continue
        table = full[["a", "b", "n", "p_holm", "significant"]].assign(d=label)
        if without is None:
            table["n_without"] = 0
            table["p_holm_without"] = math.nan
            table["significant_without"] = None
            table["changed"] = False
        else:
            merged = without.set_index(["a", "b"]).reindex(
                list(zip(table["a"], table["b"], strict=True))
            )
            table["n_without"] = merged["n"].to_numpy()
            table["p_holm_without"] = merged["p_holm"].to_numpy()
            table["significant_without"] = merged["significant"].to_numpy()
            table["changed"] = table["significant"].to_numpy() != merged["significant"].to_numpy()
        comparisons.append(table[["d", *[c for c in table.columns if c != "d"]]])
        order = " > ".join(_order(frames[0]))
        order_without = " > ".join(_order(frames[1])) if without is not None else "n/a"
        rankings.append(
            {
                "d": label,
                "ranking": order,
                "ranking without weak cells": order_without,
                "changed": without is not None and order != order_without,
            }
        )
    comparison = pd.concat(comparisons, ignore_index=True) if comparisons else pd.DataFrame()
    return comparison, pd.DataFrame(rankings)
