"""The protocol's measures: regret at budgets, fixed-target runtimes, ERT, ECDFs and their area.

All functions are pure NumPy on arrays (no simulation, no files); F is minimized.

- **Best-so-far** ``b_r(t)``: the lowest F among a run's first t evaluations (a failed
  evaluation, NaN, improves nothing; an invalid one has the env's finite penalty F).
- **Random sampling at a budget** ``F_random(t)``: the expected best of t designs drawn
  uniformly in the bounds, computed exactly from a pool of N such designs' F (the expected
  minimum of t draws without replacement from the pool, :func:`expected_best_of_random`,
  shared with the study reports from :mod:`benchmarks.reports.measures`).
- **Normalized regret** at budget t: ``(b_r(t) - F_ref) / (F_random(t) - F_ref)``. 0 is the
  reference, 1 is as good as random sampling with the same budget, > 1 worse than random. It is
  negative when a run beats the reference (the reference is then to be lowered).
- **Targets**: a ladder of ``n`` values between the median F of a random design (the easiest,
  ``F_ref + gap``) and ``F_ref + floor``, the reference plus its noise floor (the hardest), evenly
  spaced in log(F - F_ref): ``F_ref + gap (floor / gap)^(k / (n - 1))``, k = 0..n-1. No target is
  closer to the reference than the noise floor; an instance whose floor is not below its gap has
  no target (:func:`target_ladder`).
- **Runtime** to a target: the first evaluation count t with ``b_r(t) <= target``; ``inf``
  (censored) when the run's budget ends first (:func:`runtimes`).
- **ERT** (expected running time, COCO's aRT): evaluations spent by all runs until they hit the
  target or ran out, divided by the number of runs that hit it; ``inf`` when none did
  (:func:`expected_running_time`).
- **ECDF** of runtimes: over a set of (run, target) pairs, the fraction with runtime <= t, as a
  function of the budget t (:func:`ecdf`); bands from a bootstrap over instances, each with all
  its dimensions when they are pooled (:func:`bootstrap_ecdf`).
- **Area under the ECDF** (AUC): the mean of the ECDF over t = 1..B (B the budget), in [0, 1]:
  1 is every target hit at the first evaluation, 0 none ever (:func:`ecdf_area`). COCO shows the
  ECDF against log(t); the linear mean used here weighs every evaluation of the budget alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from benchmarks.reports.measures import expected_best_of_random

__all__ = [
    "best_so_far",
    "bootstrap_ecdf",
    "ecdf",
    "ecdf_area",
    "expected_best_of_random",
    "expected_running_time",
    "normalized_regret",
    "runtimes",
    "target_ladder",
]


def _vector(values: ArrayLike, name: str) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {array.shape}")
    return array


def _count(value: object, name: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")
    return int(value)


def best_so_far(values: ArrayLike) -> np.ndarray:
    """Running minimum of F in evaluation order; NaN (failed) counts as +inf.

    Args:
        values: (T,) F of a run's evaluations, in order.

    Returns:
        (T,) lowest F among the first 1, 2, ..., T evaluations (inf until one is finite).
    """
    f = _vector(values, "values")
    return np.minimum.accumulate(np.where(np.isnan(f), np.inf, f)) if f.size else f


def normalized_regret(best: ArrayLike, f_ref: float, f_random: ArrayLike) -> np.ndarray:
    """``(best - F_ref) / (F_random - F_ref)``, elementwise.

    Args:
        best: Best-so-far F at some budgets.
        f_ref: The reference F of the instance.
        f_random: F of random sampling at the same budgets; must exceed ``f_ref``.

    Raises:
        ValueError: If a ``f_random`` is not above ``f_ref`` (no scale), or values are not finite.
    """
    b = np.asarray(best, dtype=np.float64)
    r = np.asarray(f_random, dtype=np.float64)
    if not math.isfinite(f_ref) or not np.all(np.isfinite(r)):
        raise ValueError(f"f_ref and f_random must be finite, got {f_ref!r} and {r.tolist()}")
    if np.any(r <= f_ref):
        raise ValueError(
            f"f_random must be above f_ref = {f_ref:g} (random sampling worse than the "
            f"reference), got {r.tolist()}"
        )
    return np.asarray((b - f_ref) / (r - f_ref))


def target_ladder(f_ref: float, f_random_median: float, floor: float, n: int = 10) -> np.ndarray:
    """``n`` targets from ``f_random_median`` down to ``f_ref + floor``, log-spaced in F - F_ref.

    Args:
        f_ref: The reference F.
        f_random_median: Median F of a random design: the first (easiest) target.
        floor: The noise floor of F at the reference (> 0): the last target is
            ``f_ref + floor``.
        n: Targets, >= 2.

    Returns:
        (n,) targets in decreasing order; empty when ``floor >= f_random_median - f_ref``.

    Raises:
        ValueError: Non-finite inputs, ``floor <= 0`` or ``n < 2``.
    """
    n = _count(n, "n", 2)
    values = (f_ref, f_random_median, floor)
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"f_ref, f_random_median and floor must be finite, got {values}")
    if floor <= 0:
        raise ValueError(f"floor must be > 0 (an F difference), got {floor!r}")
    gap = f_random_median - f_ref
    if floor >= gap:
        return np.zeros(0)
    k = np.arange(n) / (n - 1)
    return np.asarray(f_ref + gap * (floor / gap) ** k)


def runtimes(curve: ArrayLike, targets: ArrayLike) -> np.ndarray:
    """Evaluations a run needed to reach each target: the first t with best-so-far <= target.

    Args:
        curve: (T,) F of the run's evaluations in order (or its best-so-far curve).
        targets: (k,) target F values.

    Returns:
        (k,) runtimes as floats, 1..T, or ``inf`` where the run never reached the target.
    """
    best = best_so_far(curve)
    t = _vector(targets, "targets")
    if best.size == 0:
        return np.full(t.size, np.inf)
    hit = best[None, :] <= t[:, None]
    first = np.argmax(hit, axis=1).astype(np.float64) + 1.0
    return np.asarray(np.where(hit.any(axis=1), first, np.inf))


def expected_running_time(times: ArrayLike, budgets: ArrayLike | float) -> float:
    """ERT of one target over runs: evaluations until success or budget, per success.

    Args:
        times: (r,) runtimes of r runs to the target (``inf`` where censored).
        budgets: The runs' budgets, (r,) or one number for all.

    Returns:
        sum_r min(time_r, budget_r) / #successes; ``inf`` if no run reached the target; NaN for
        no runs.

    Raises:
        ValueError: If a finite runtime exceeds its run's budget, or a budget is not a finite
            number >= 1.
    """
    t = _vector(times, "times")
    b = np.broadcast_to(np.asarray(budgets, dtype=np.float64), t.shape)
    if t.size == 0:
        return math.nan
    bad = ~(np.isfinite(b) & (b >= 1))
    if bad.any():
        raise ValueError(
            f"budgets must be finite numbers >= 1 (evaluations), got {float(b[bad][0])!r}"
        )
    done = np.isfinite(t)
    if np.any(t[done] > b[done]):
        raise ValueError("a runtime exceeds its run's budget")
    if not done.any():
        return math.inf
    return float(np.where(done, t, b).sum() / done.sum())


def ecdf(times: ArrayLike, grid: ArrayLike) -> np.ndarray:
    """Fraction of runtimes <= each budget of ``grid`` (censored ones count as never).

    Args:
        times: (m,) runtimes over (run, target) pairs; ``inf`` where censored.
        grid: (g,) budgets.

    Returns:
        (g,) fractions in [0, 1]; NaN where ``times`` is empty.
    """
    t = np.sort(_vector(times, "times"))
    g = _vector(grid, "grid")
    if t.size == 0:
        return np.full(g.size, np.nan)
    return np.searchsorted(t, g, side="right") / t.size


def ecdf_area(times: ArrayLike, budget: int) -> float:
    """Mean of the ECDF over t = 1..budget: the area under it, normalized to [0, 1].

    Equals the mean over (run, target) pairs of (budget - runtime + 1) / budget, 0 for a pair
    not hit within the budget.
    """
    budget = _count(budget, "budget")
    t = _vector(times, "times")
    if t.size == 0:
        return math.nan
    within = np.isfinite(t) & (t <= budget)
    return float(np.where(within, (budget - t + 1) / budget, 0.0).mean())


def bootstrap_ecdf(
    groups: Sequence[ArrayLike],
    grid: ArrayLike,
    *,
    resamples: int = 1000,
    level: float = 0.95,
    rng: np.random.Generator | int | None = 0,
    clusters: Sequence[object] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pooled ECDF of ``groups`` (one array of runtimes per instance) with a band.

    Instances are resampled with replacement, each bringing all its runs and targets, and the
    pooled ECDF recomputed; the band is the percentile interval at ``level``. With
    ``clusters`` (one label per group), the clusters are resampled instead, each bringing all
    its groups: the blocks (instance, d) of one instance are not independent, so a pooled band
    resamples instances with all their dimensions. Groups that are their own clusters give the
    band without ``clusters``, to the bit.

    Args:
        groups: One array of runtimes per group (``inf`` where censored).
        grid: (g,) budgets.
        resamples: Bootstrap resamples, >= 1.
        level: Level of the band, in (0, 1).
        rng: Seed or generator.
        clusters: A label per group (``None``: every group is its own cluster).

    Returns:
        (estimate, low, high), each (g,).

    Raises:
        ValueError: No group, a level or resample count out of range, or ``clusters`` not of
            one label per group.
    """
    resamples = _count(resamples, "resamples")
    if not 0 < level < 1:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    arrays = [_vector(g, "group") for g in groups]
    if not arrays:
        raise ValueError("groups must hold at least one instance")
    g = _vector(grid, "grid")
    generator = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    per = np.array([np.searchsorted(np.sort(a), g, side="right") for a in arrays], dtype=float)
    sizes = np.array([a.size for a in arrays], dtype=float)
    if clusters is not None:
        labels = list(clusters)
        if len(labels) != len(arrays):
            raise ValueError(
                f"clusters must give one label per group ({len(arrays)}), got {len(labels)}"
            )
        index = {label: k for k, label in enumerate(dict.fromkeys(labels))}  # first-seen order
        which = np.array([index[label] for label in labels])
        summed = np.zeros((len(index), g.size))
        np.add.at(summed, which, per)
        per = summed
        sizes = np.bincount(which, weights=sizes, minlength=len(index)).astype(float)
    estimate = per.sum(axis=0) / sizes.sum()
    picks = generator.integers(0, len(per), size=(resamples, len(per)))
    counts = per[picks].sum(axis=1) / sizes[picks].sum(axis=1)[:, None]
    alpha = (1 - level) / 2
    low, high = np.quantile(counts, [alpha, 1 - alpha], axis=0)
    return estimate, np.asarray(low), np.asarray(high)
