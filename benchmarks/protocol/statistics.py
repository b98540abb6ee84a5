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
  d_z = mean / SD of the differences.
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

import numpy as np
import pandas as pd

from benchmarks.reports.measures import COMPARISON_COLUMNS, paired_table

__all__ = [
    "COMPARISON_COLUMNS",
    "WILCOXON_ARE",
    "detectable_difference",
    "instances_needed",
    "min_instances",
    "paired_comparisons",
    "power_analysis",
    "rank_stability",
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


def _check_scores(scores: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``scores`` with a score (NaN: a missing run); infinite scores refused."""
    if not isinstance(scores, pd.DataFrame):
        raise TypeError(f"scores must be a DataFrame, got {type(scores).__name__}")
    missing = [c for c in _SCORES if c not in scores.columns]
    if missing:
        raise ValueError(f"scores lacks columns {missing}; needs {list(_SCORES)}")
    if scores.empty:
        raise ValueError("scores holds no row")
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
) -> pd.DataFrame:
    """Every pair of optimizers compared on the instances both ran, Holm-corrected.

    Args:
        scores: One row per run: ``instance``, ``optimizer``, ``seed``, ``score`` (finite; NaN
            for a missing run, left out).
        alpha: Family-wise level of ``significant``, in (0, 1).
        level: Level of the Student t interval of the mean difference, in (0, 1).

    Returns:
        One row per pair with :data:`COMPARISON_COLUMNS`; ``mean_diff`` is mean(a - b) over
        instances, ``ci_low``/``ci_high`` its t interval
        (:func:`benchmarks.reports.stats.t_interval`).
    """
    scores = _check_scores(scores)
    _check_level("alpha", alpha)
    _check_level("level", level)
    return paired_table(_instance_means(scores), alpha=alpha, level=level)


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
