"""Measures shared by the benchmark protocol and the reports of studies: one formula each.

- :func:`expected_best_of_random`: the expected lowest F of t random designs, computed exactly
  from a pool of N such designs' F (random sampling at a budget, the scale of normalized
  regret).
- :func:`paired_table`: every pair of methods compared on the instances (tasks) both have: the
  two-sided Wilcoxon signed-rank test of the per-instance differences, Holm-corrected over the
  pairs (:func:`benchmarks.reports.stats.holm_bonferroni`), the mean difference with its Student
  t interval over instances (:func:`benchmarks.reports.stats.t_interval`) and d_z = mean / SD of
  the differences.

They live here, in the reports' layer, so that both the protocol
(:mod:`benchmarks.protocol.measures`, :mod:`benchmarks.protocol.statistics`, which sit above
the reports) and the study reports (:mod:`benchmarks.reports.breakeven`) use the same code.
Pure NumPy, pandas and SciPy: no files, no simulation.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from benchmarks.reports.stats import holm_bonferroni, t_interval

__all__ = ["COMPARISON_COLUMNS", "expected_best_of_random", "paired_table"]

#: The columns of :func:`paired_table`, one row per pair of methods.
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


def _log_comb(n: np.ndarray, k: int) -> np.ndarray:
    from scipy.special import gammaln

    n = np.asarray(n, dtype=np.float64)
    return np.asarray(gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1))


def expected_best_of_random(pool: ArrayLike, budgets: ArrayLike) -> np.ndarray:
    """Expected lowest F of t designs drawn at random without replacement from ``pool``.

    With the pool sorted, x_(1) <= ... <= x_(N), the minimum of t draws is x_(i) with
    probability C(N - i, t - 1) / C(N, t).

    Args:
        pool: (N,) F of random designs (finite; NaN values are dropped).
        budgets: (k,) t values, each an int from 1 to N.

    Returns:
        (k,) expected minima.

    Raises:
        ValueError: An empty pool or a budget outside 1..N.
    """
    x = np.asarray(pool, dtype=np.float64)
    if x.ndim != 1:
        raise ValueError(f"pool must be 1-D, got shape {x.shape}")
    x = np.sort(x[~np.isnan(x)])
    n = x.size
    if n == 0:
        raise ValueError("pool must hold at least one F (at least one finite once NaN is dropped)")
    if not np.all(np.isfinite(x)):
        raise ValueError("pool must hold finite F values")
    t = np.asarray(budgets)
    if t.ndim != 1 or not np.issubdtype(t.dtype, np.integer) or np.any((t < 1) | (t > n)):
        raise ValueError(f"budgets must be ints from 1 to the pool size {n}, got {t.tolist()}")
    i = np.arange(1, n + 1)
    out = np.empty(t.size)
    for k, b in enumerate(t.tolist()):
        valid = n - i >= b - 1
        log_p = np.full(n, -np.inf)
        m = n - i[valid]
        log_p[valid] = _log_comb(m, b - 1) - _log_comb(np.array([n]), b)[0]
        p = np.exp(log_p)
        out[k] = float(np.dot(p / p.sum(), x))
    return out


def paired_table(means: pd.DataFrame, *, alpha: float = 0.05, level: float = 0.95) -> pd.DataFrame:
    """Every pair of methods on the instances both have, Holm-corrected over the pairs.

    The two-sided Wilcoxon signed-rank test of the per-instance differences
    (``zero_method="zsplit"``; p = 1 when every difference is 0), the mean difference with its
    Student t interval over instances, d_z = mean / SD of the differences. Fewer than two
    instances in common: NaN statistics (and not significant).

    Args:
        means: Instances as rows, methods as columns: a method's score on an instance (its mean
            over seeds; NaN: none).
        alpha: Family-wise level of ``significant``.
        level: Level of the t interval.

    Returns:
        One row per pair (a < b by name) with :data:`COMPARISON_COLUMNS`; ``mean_diff`` is
        mean(a - b).
    """
    from scipy.stats import wilcoxon

    rows = []
    for a, b in itertools.combinations(sorted(means.columns), 2):
        both = means[[a, b]].dropna()
        diff = (both[a] - both[b]).to_numpy(dtype=np.float64)
        n = diff.size
        row: dict[str, Any] = {
            "a": a,
            "b": b,
            "n": n,
            "mean_diff": float(diff.mean()) if n else math.nan,
        }
        if n >= 2:
            interval = t_interval(diff, level)
            sd = float(diff.std(ddof=1))
            row.update(
                ci_low=interval.low,
                ci_high=interval.high,
                d_z=row["mean_diff"] / sd if sd > 0 else math.nan,
                p=1.0 if np.all(diff == 0) else float(wilcoxon(diff, zero_method="zsplit").pvalue),
            )
        else:
            row.update(ci_low=math.nan, ci_high=math.nan, d_z=math.nan, p=math.nan)
        rows.append(row)
    table = pd.DataFrame(rows, columns=list(COMPARISON_COLUMNS[:8]))
    table["p_holm"] = holm_bonferroni(table["p"].to_numpy(dtype=np.float64))
    table["significant"] = (table["p_holm"] < alpha).astype(bool)
    return table[list(COMPARISON_COLUMNS)]
