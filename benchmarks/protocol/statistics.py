"""The protocol's statistics: paired comparisons, ranking stability and power.

The unit of comparison is the **instance**: every optimizer runs every instance with the same
seeds, a run's score is one number (the area under its ECDF over the instance's targets, or its
normalized regret at the budget), and an optimizer's score on an instance is the mean over its
seeds. Comparisons are therefore paired by instance.

- :func:`paired_comparisons`: for each pair of optimizers, the Wilcoxon signed-rank test of the
  per-instance differences (two-sided), Holm-corrected over the pairs
  (:func:`benchmarks.reports.stats.holm_bonferroni`), the mean difference with a bootstrap
  interval over instances, and the standardized effect d_z = mean / SD of the differences.
- :func:`rank_stability`: the probability of each rank for each optimizer when instances are
  resampled with replacement and, within each drawn instance, each optimizer's seeds too.
- :func:`power_analysis`: per pair, the smallest difference of means the run detects at 80 %
  power (a paired z approximation at the Holm family's strictest level alpha / m), and how many
  instances, or seeds per instance, a wanted difference needs. The SD of a paired difference of
  seed means is split into an instance-by-optimizer part and a seed part,
  ``s_d^2 = s_int^2 + (v_a + v_b) / S`` with ``v`` the within-instance variance over seeds and
  S the seeds: more seeds shrink only the second part, more instances shrink both.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from benchmarks.reports.stats import holm_bonferroni

__all__ = [
    "COMPARISON_COLUMNS",
    "detectable_difference",
    "instances_needed",
    "paired_comparisons",
    "power_analysis",
    "rank_stability",
]

COMPARISON_COLUMNS: tuple[str, ...] = (
    "a",
    "b",
    "n",
    "mean_diff",
    "ci_low",
    "ci_high",
    "d_z",
    "p",
    "p_holm",
    "significant",
)

_SCORES = ("instance", "optimizer", "seed", "score")


def _check_scores(scores: pd.DataFrame) -> pd.DataFrame:
    if not isinstance(scores, pd.DataFrame):
        raise TypeError(f"scores must be a DataFrame, got {type(scores).__name__}")
    missing = [c for c in _SCORES if c not in scores.columns]
    if missing:
        raise ValueError(f"scores lacks columns {missing}; needs {list(_SCORES)}")
    if scores.empty:
        raise ValueError("scores holds no row")
    return scores


def _z(p: float) -> float:
    from scipy.stats import norm

    return float(norm.ppf(p))


def detectable_difference(
    sd: float, n: int, *, alpha: float = 0.05, power: float = 0.8, tests: int = 1
) -> float:
    """Smallest paired mean difference detected with ``power``: (z_(1-a/2m) + z_power) sd / sqrt(n).

    Args:
        sd: SD of the paired differences (one per instance).
        n: Instances (pairs), >= 1.
        alpha: Family-wise level.
        power: Wanted power, in (0, 1).
        tests: Tests m in the Holm family (the first step is at alpha / m).
    """
    _check_power_args(alpha, power, tests)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an int >= 1, got {n!r}")
    if not math.isfinite(sd) or sd < 0:
        raise ValueError(f"sd must be a finite number >= 0, got {sd!r}")
    return (_z(1 - alpha / (2 * tests)) + _z(power)) * sd / math.sqrt(n)


def instances_needed(
    sd: float, difference: float, *, alpha: float = 0.05, power: float = 0.8, tests: int = 1
) -> int:
    """Instances a paired test needs to detect ``difference`` with ``power`` (at least 2)."""
    _check_power_args(alpha, power, tests)
    if not math.isfinite(difference) or difference <= 0:
        raise ValueError(f"difference must be a finite number > 0, got {difference!r}")
    z = _z(1 - alpha / (2 * tests)) + _z(power)
    return max(2, math.ceil((z * sd / difference) ** 2))


def _check_power_args(alpha: float, power: float, tests: int) -> None:
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    if not 0 < power < 1:
        raise ValueError(f"power must be in (0, 1), got {power!r}")
    if isinstance(tests, bool) or not isinstance(tests, int) or tests < 1:
        raise ValueError(f"tests must be an int >= 1, got {tests!r}")


def _instance_means(scores: pd.DataFrame) -> pd.DataFrame:
    table = scores.groupby(["instance", "optimizer"])["score"].mean().unstack("optimizer")
    return table


def paired_comparisons(
    scores: pd.DataFrame,
    *,
    alpha: float = 0.01,
    resamples: int = 2000,
    level: float = 0.95,
    rng: np.random.Generator | int | None = 0,
) -> pd.DataFrame:
    """Every pair of optimizers compared on the instances both ran, Holm-corrected.

    Args:
        scores: One row per run: ``instance``, ``optimizer``, ``seed``, ``score``.
        alpha: Family-wise level of ``significant``.
        resamples: Bootstrap resamples of instances for the interval of the mean difference.
        level: Interval level.
        rng: Seed or generator of the bootstrap.

    Returns:
        One row per pair with :data:`COMPARISON_COLUMNS`; ``mean_diff`` is mean(a - b) over
        instances.
    """
    from scipy.stats import wilcoxon

    _check_scores(scores)
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    means = _instance_means(scores)
    rows = []
    for a, b in itertools.combinations(sorted(means.columns), 2):
        both = means[[a, b]].dropna()
        diff = (both[a] - both[b]).to_numpy()
        n = diff.size
        row = {"a": a, "b": b, "n": n, "mean_diff": float(diff.mean()) if n else math.nan}
        if n >= 2:
            picks = generator.integers(0, n, size=(resamples, n))
            boot = diff[picks].mean(axis=1)
            tail = (1 - level) / 2
            row["ci_low"], row["ci_high"] = (float(v) for v in np.quantile(boot, [tail, 1 - tail]))
            sd = float(diff.std(ddof=1))
            row["d_z"] = row["mean_diff"] / sd if sd > 0 else math.nan
            row["p"] = (
                1.0 if np.all(diff == 0) else float(wilcoxon(diff, zero_method="zsplit").pvalue)
            )
        else:
            row.update(ci_low=math.nan, ci_high=math.nan, d_z=math.nan, p=math.nan)
        rows.append(row)
    table = pd.DataFrame(rows, columns=[c for c in COMPARISON_COLUMNS[:8]])
    table["p_holm"] = holm_bonferroni(table["p"].to_numpy(dtype=np.float64))
    table["significant"] = (table["p_holm"] < alpha).astype(bool)
    return table[list(COMPARISON_COLUMNS)]


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
    their resampled scores (1 = best).

    Returns:
        A table optimizer x rank (1..k) of probabilities, rows in the order of the full data's
        ranking, with a column ``rank`` (the full data's rank) and ``mean`` (its mean score).
    """
    _check_scores(scores)
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    optimizers = sorted(scores["optimizer"].unique())
    instances = sorted(scores["instance"].unique())
    cells: dict[tuple[str, str], np.ndarray] = {
        (str(i), str(o)): g["score"].to_numpy(dtype=np.float64)
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
        alpha: Family-wise level (Holm over all pairs: the first step is at alpha / m).
        power: Wanted power.
        wanted: Differences of mean score to size for; ``[]`` uses the pair's own observed
            difference.

    Returns:
        One row per pair: ``n`` instances, ``seeds`` (median per instance and optimizer),
        ``sd_diff`` (SD of the per-instance differences), ``sd_instance`` and ``sd_seed`` (its
        two parts, see the module doc), ``observed`` difference, ``detectable`` difference,
        ``wanted``, ``instances_needed`` and ``seeds_needed`` (at the present instances; ``inf``
        when more seeds alone cannot reach it; NaN, like ``sd_seed``, with one seed per
        instance, where the seed variance is unknown).
    """
    _check_scores(scores)
    means = _instance_means(scores)
    variances = scores.groupby(["instance", "optimizer"])["score"].var(ddof=1)
    seeds = scores.groupby(["instance", "optimizer"])["score"].size()
    pairs = list(itertools.combinations(sorted(means.columns), 2))
    tests = max(1, len(pairs))
    z = _z(1 - alpha / (2 * tests)) + _z(power)
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
        targets = list(wanted) if wanted else [observed]
        for want in targets:
            row = {
                "a": a,
                "b": b,
                "n": n,
                "seeds": s,
                "sd_diff": sd,
                "sd_instance": math.sqrt(inst_part) if math.isfinite(inst_part) else math.nan,
                "sd_seed": math.sqrt(seed_part) if math.isfinite(seed_part) else math.nan,
                "observed": observed,
                "detectable": z * sd / math.sqrt(n),
                "wanted": float(want),
            }
            if want > 0 and sd > 0:
                row["instances_needed"] = max(2, math.ceil((z * sd / want) ** 2))
                room = n * want**2 / z**2 - inst_part
                if not math.isfinite(v):
                    row["seeds_needed"] = math.nan  # unknown with one seed per instance
                else:
                    row["seeds_needed"] = math.ceil(v / room) if room > 0 and v > 0 else math.inf
            else:
                row["instances_needed"] = math.nan
                row["seeds_needed"] = math.nan
            rows.append(row)
    return pd.DataFrame(rows)
