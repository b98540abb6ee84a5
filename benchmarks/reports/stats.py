"""Statistics of stored benchmark results: intervals of means, effect sizes, tests, curves.

Pure numpy, scipy and pandas; no plotting, no files. Every function excludes non-finite values
(NaN for a failed evaluation, +-inf) from its samples and reports how many it excluded, and
answers NaN with a note rather than raising when a sample is too small to say anything.

The objective is minimised: a smaller free energy F is better throughout.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy import stats as _sps

from tooldesign_env.schema import RUN_COLUMNS

__all__ = [
    "INTERVALS",
    "INTERVAL_NAMES",
    "PAIRWISE_COLUMNS",
    "BootstrapCI",
    "Interval",
    "area_under_curve",
    "best_so_far_curves",
    "bootstrap_ci",
    "check_interval",
    "finite_values",
    "holm_bonferroni",
    "mann_whitney_holm",
    "mean_interval",
    "run_metrics",
    "t_interval",
    "vargha_delaney_a12",
]

#: The intervals of a mean the reports can give (their ``interval`` argument): ``"t"``, the
#: Student t interval (the default), and ``"bootstrap"``, the percentile bootstrap. With the
#: 3 to 10 seeds or goals of the suites the percentile bootstrap covers less than its level
#: (``perf/studies/interval_coverage.py`` measures both; docs/results-format.md).
INTERVALS = ("t", "bootstrap")

#: What the reports call each interval.
INTERVAL_NAMES = {"t": "Student t interval", "bootstrap": "percentile bootstrap interval"}


PAIRWISE_COLUMNS: tuple[str, ...] = (
    "a",
    "b",
    "U",
    "p",
    "p_holm",
    "a12",
    "significant",
    "n_a",
    "n_b",
    "note",
)
"""Columns of :func:`mann_whitney_holm`."""

# Resampled values per block in bootstrap_ci: bounds memory at ~8 MB whatever the sample size.
_BOOTSTRAP_BLOCK = 1 << 20


def finite_values(values: ArrayLike, *, name: str = "values") -> tuple[np.ndarray, int]:
    """Keep the finite entries of a 1-D sample.

    Args:
        values: (n,) numbers.
        name: Argument name for error messages.

    Returns:
        ``(finite, n_excluded)``: the (m,) float64 finite entries in their order and the number
        n - m of NaN or infinite entries left out.

    Raises:
        TypeError: If ``values`` are not numbers.
        ValueError: If ``values`` is not 1-D.
    """
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name} must be numbers: {err}") from err
    if array.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {array.shape}")
    keep = np.isfinite(array)
    return array[keep], int(array.size - keep.sum())


@dataclasses.dataclass(frozen=True)
class Interval:
    """A statistic with its confidence interval (:func:`t_interval`, :func:`bootstrap_ci`).

    Unpacks as ``estimate, low, high = t_interval(...)``.

    Attributes:
        estimate: The statistic of the finite sample (NaN if it is empty).
        low: Lower bound of the interval.
        high: Upper bound of the interval.
        n: Number of finite values used.
        n_excluded: Number of NaN or infinite values left out.
    """

    estimate: float
    low: float
    high: float
    n: int
    n_excluded: int

    def __iter__(self) -> Iterator[float]:
        return iter((self.estimate, self.low, self.high))


#: The former name of :class:`Interval`, when the bootstrap was the only interval.
BootstrapCI = Interval


def t_interval(values: ArrayLike, level: float = 0.95) -> Interval:
    """The mean of the finite values with its Student t interval.

    mean +- t_{(1 + level) / 2, n - 1} s / sqrt(n), with s the sample standard deviation (ddof
    1): exact for normal values whatever n, where the percentile bootstrap is too narrow with
    few values (it cannot reach past the sample's range). One value gives a zero-width
    interval, as :func:`bootstrap_ci` does (the reports print no interval below 2 values); no
    value gives NaN.

    Args:
        values: (n,) sample, e.g. the final F of each seed.
        level: Coverage in (0, 1).

    Returns:
        The mean, interval and counts; see :class:`Interval`.

    Raises:
        TypeError: If ``values`` are not numbers.
        ValueError: If ``level`` is out of range.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    sample, excluded = finite_values(values)
    n = sample.size
    if n == 0:
        return Interval(np.nan, np.nan, np.nan, 0, excluded)
    mean = float(sample.mean())
    if n == 1:
        return Interval(mean, mean, mean, 1, excluded)
    half = float(_sps.t.ppf((1.0 + level) / 2.0, n - 1) * sample.std(ddof=1) / np.sqrt(n))
    return Interval(mean, mean - half, mean + half, n, excluded)


def mean_interval(
    values: ArrayLike,
    *,
    interval: str = "t",
    level: float = 0.95,
    n_boot: int = 10_000,
    rng: np.random.Generator | np.random.SeedSequence | int = 0,
) -> Interval:
    """The mean with the interval the reports give: :func:`t_interval` or :func:`bootstrap_ci`.

    Args:
        values: (n,) sample.
        interval: One of :data:`INTERVALS`.
        level: Coverage in (0, 1).
        n_boot: Resamples of the bootstrap (``interval="bootstrap"`` only).
        rng: Seed or Generator of the bootstrap (``interval="bootstrap"`` only).

    Raises:
        ValueError: If ``interval`` is not one of :data:`INTERVALS`, or as the interval does.
    """
    if interval == "t":
        return t_interval(values, level)
    if interval == "bootstrap":
        return bootstrap_ci(values, np.mean, n_boot, level, rng=rng)
    raise ValueError(f"interval must be one of {INTERVALS}, got {interval!r}")


def check_interval(interval: Any) -> str:
    """``interval`` if it is one of :data:`INTERVALS`, else a ValueError naming it."""
    if not isinstance(interval, str) or interval not in INTERVALS:
        raise ValueError(f"interval must be one of {INTERVALS}, got {interval!r}")
    return interval


def bootstrap_ci(
    values: ArrayLike,
    stat: Callable[..., Any] = np.mean,
    n_boot: int = 10_000,
    level: float = 0.95,
    *,
    rng: np.random.Generator | np.random.SeedSequence | int,
) -> Interval:
    """Percentile bootstrap confidence interval of a statistic.

    Draws ``n_boot`` resamples of the finite values with replacement, applies ``stat`` to each
    and takes the (1 - level)/2 and (1 + level)/2 quantiles (linear interpolation). One value
    gives a zero-width interval; no value gives NaN. For a mean of few values it covers less
    than ``level`` (about 90 % at n = 10, 76 % at n = 3 for normal values at level 0.95):
    :func:`t_interval` does not.

    Args:
        values: (n,) sample, e.g. the final F of each seed.
        stat: Statistic of a 1-D sample; it is called as ``stat(samples, axis=1)`` on a
            (n_boot, n) block when it accepts ``axis`` (``np.mean``, ``np.median``) and row by
            row otherwise.
        n_boot: Number of resamples, >= 1.
        level: Coverage in (0, 1).
        rng: A Generator, SeedSequence or int seed; the same seed gives the same interval.

    Returns:
        The estimate, interval and counts; see :class:`Interval`.

    Raises:
        TypeError: If ``values`` are not numbers or ``rng`` is not a seed or Generator.
        ValueError: If ``n_boot`` or ``level`` is out of range.
    """
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 1:
        raise ValueError(f"n_boot must be an int >= 1, got {n_boot!r}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    generator = _generator(rng)
    sample, excluded = finite_values(values)
    n = sample.size
    if n == 0:
        return Interval(np.nan, np.nan, np.nan, 0, excluded)
    estimate = float(stat(sample))
    block = max(1, _BOOTSTRAP_BLOCK // n)
    replicates = np.empty(n_boot)
    for start in range(0, n_boot, block):
        stop = min(n_boot, start + block)
        resamples = sample[generator.integers(0, n, size=(stop - start, n))]
        replicates[start:stop] = _apply_rows(stat, resamples)
    low, high = np.quantile(replicates, [(1.0 - level) / 2.0, (1.0 + level) / 2.0])
    return Interval(estimate, float(low), float(high), n, excluded)


def _generator(rng: Any) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, np.random.SeedSequence) or (
        isinstance(rng, (int, np.integer)) and not isinstance(rng, bool)
    ):
        return np.random.default_rng(rng)
    raise TypeError(
        f"rng must be a numpy Generator, SeedSequence or int seed, got {type(rng).__name__}"
    )


def _apply_rows(stat: Callable[..., Any], resamples: np.ndarray) -> np.ndarray:
    try:
        out = np.asarray(stat(resamples, axis=1), dtype=np.float64)
    except TypeError:
        out = None
    if out is None or out.shape != (resamples.shape[0],):
        out = np.array([float(stat(row)) for row in resamples])
    return out


def vargha_delaney_a12(a: ArrayLike, b: ArrayLike) -> float:
    """Vargha-Delaney A12 effect size: P(X > Y) + P(X = Y) / 2 for X drawn from a, Y from b.

    0.5 means no effect. For a minimised objective such as F, A12 < 0.5 means ``a`` tends to
    be smaller, i.e. ``a`` is better; A12 = 0 means every value of a is below every value of b.
    Vargha and Delaney (2000) call |A12 - 0.5| >= 0.06, 0.14, 0.21 small, medium, large.
    It equals U_a / (n_a n_b) for the Mann-Whitney statistic U_a of a.

    Args:
        a: (n_a,) sample; non-finite values are excluded.
        b: (n_b,) sample; non-finite values are excluded.

    Returns:
        A12 in [0, 1], or NaN if a sample has no finite value.
    """
    x, _ = finite_values(a, name="a")
    y, _ = finite_values(b, name="b")
    if x.size == 0 or y.size == 0:
        return float("nan")
    ranks = _sps.rankdata(np.concatenate([x, y]))  # midranks: ties count half
    u_a = ranks[: x.size].sum() - x.size * (x.size + 1) / 2.0
    return float(u_a / (x.size * y.size))


def holm_bonferroni(p_values: ArrayLike) -> np.ndarray:
    """Holm-Bonferroni step-down adjustment of a family of p-values.

    With the m finite p-values sorted, p_(1) <= ... <= p_(m), the adjusted value of p_(i) is
    max over j <= i of min(1, (m - j + 1) p_(j)). Rejecting where the adjusted value is below
    alpha controls the family-wise error rate at alpha. NaN entries (tests not made) stay NaN
    and do not count in m.

    Args:
        p_values: (k,) p-values in [0, 1] or NaN.

    Returns:
        (k,) adjusted p-values in the input order.

    Raises:
        ValueError: If a p-value is outside [0, 1] or the input is not 1-D.
    """
    p = np.asarray(p_values, dtype=np.float64)
    if p.ndim != 1:
        raise ValueError(f"p_values must be 1-D, got shape {p.shape}")
    tested = ~np.isnan(p)
    if ((p[tested] < 0) | (p[tested] > 1)).any():
        raise ValueError("p_values must lie in [0, 1] (or be NaN for tests not made)")
    adjusted = np.full(p.shape, np.nan)
    index = np.flatnonzero(tested)
    order = index[np.argsort(p[index], kind="stable")]
    m = order.size
    scaled = np.minimum(1.0, (m - np.arange(m)) * p[order])
    adjusted[order] = np.maximum.accumulate(scaled)
    return adjusted


def mann_whitney_holm(
    groups: Mapping[str, ArrayLike],
    alternative: str = "two-sided",
    *,
    alpha: float = 0.05,
    min_n: int = 2,
) -> pd.DataFrame:
    """Pairwise Mann-Whitney U tests with Holm-Bonferroni correction and A12 effect sizes.

    Every unordered pair (a, b) of groups, in the order of ``groups``, is tested with
    ``scipy.stats.mannwhitneyu`` (method "auto": exact for small samples without ties). The
    family for the Holm correction is the pairs that could be tested.

    Args:
        groups: Name to (n,) sample, e.g. optimizer to final F per seed; non-finite values are
            excluded and counted in ``note``.
        alternative: ``"two-sided"``, ``"less"`` (a tends to be smaller: better when
            minimising) or ``"greater"``.
        alpha: Family-wise error rate for ``significant``.
        min_n: Fewest finite values a group needs to be tested; below it U and p are NaN and
            ``note`` says why.

    Returns:
        One row per pair with :data:`PAIRWISE_COLUMNS`: ``U`` is the statistic of a, ``p`` the
        raw p-value, ``p_holm`` the adjusted one, ``a12`` = A12(a, b), ``significant`` is
        ``p_holm < alpha`` (False where untested), ``n_a``/``n_b`` the finite counts.
        Empty (with those columns) for fewer than two groups.

    Raises:
        TypeError: If ``groups`` is not a mapping of str to numbers.
        ValueError: If ``alternative``, ``alpha`` or ``min_n`` is out of range.
    """
    if not isinstance(groups, Mapping):
        raise TypeError(f"groups must be a mapping of name to sample, got {type(groups).__name__}")
    if alternative not in ("two-sided", "less", "greater"):
        raise ValueError(
            f"alternative must be 'two-sided', 'less' or 'greater', got {alternative!r}"
        )
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    if isinstance(min_n, bool) or not isinstance(min_n, int) or min_n < 1:
        raise ValueError(f"min_n must be an int >= 1, got {min_n!r}")
    clean: dict[str, tuple[np.ndarray, int]] = {}
    for name, values in groups.items():
        if not isinstance(name, str):
            raise TypeError(f"groups keys must be str, got {name!r}")
        clean[name] = finite_values(values, name=f"groups[{name!r}]")

    rows = []
    for a, b in itertools.combinations(clean, 2):
        (x, drop_x), (y, drop_y) = clean[a], clean[b]
        notes = [
            f"{drop} non-finite value(s) of {g} excluded"
            for g, drop in ((a, drop_x), (b, drop_y))
            if drop
        ]
        u = p = np.nan
        small = [f"{g} has {s.size}" for g, s in ((a, x), (b, y)) if s.size < min_n]
        if small:
            notes.append(f"not tested: {' and '.join(small)} finite value(s), fewer than {min_n}")
        else:
            result = _sps.mannwhitneyu(x, y, alternative=alternative)
            u, p = float(result.statistic), float(result.pvalue)
            if np.unique(np.concatenate([x, y])).size == 1:
                notes.append("all values identical")
            if np.isnan(p):
                notes.append("scipy returned no p-value")
        rows.append(
            {
                "a": a,
                "b": b,
                "U": u,
                "p": p,
                "a12": vargha_delaney_a12(x, y),
                "n_a": int(x.size),
                "n_b": int(y.size),
                "note": "; ".join(notes),
            }
        )
    table = pd.DataFrame(
        rows, columns=[c for c in PAIRWISE_COLUMNS if c not in ("p_holm", "significant")]
    )
    table["p_holm"] = holm_bonferroni(table["p"].to_numpy(dtype=np.float64))
    table["significant"] = (table["p_holm"] < alpha).astype(bool)
    table = table.astype({"U": np.float64, "p": np.float64, "a12": np.float64})
    table = table.astype({"n_a": np.int64, "n_b": np.int64})
    return table[list(PAIRWISE_COLUMNS)]


def _check_columns(frame: pd.DataFrame, required: tuple[str, ...], name: str) -> None:
    if not isinstance(frame, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame, got {type(frame).__name__}")
    missing = [c for c in required if c not in frame.columns]
    if missing:
        raise ValueError(f"{name}: missing columns {missing}")


def best_so_far_curves(evaluations: pd.DataFrame) -> pd.DataFrame:
    """Best finite F so far of every run after every iteration.

    Only rows with a finite ``free_energy`` (and ``status == "ok"`` if there is a ``status``
    column) count. An iteration before the first finite F has ``best_so_far`` NaN.

    Args:
        evaluations: One row per evaluation with ``optimizer``, ``seed``, ``iteration`` and
            ``free_energy`` columns (and optionally ``suite``, ``variant``, ``status``).

    Returns:
        One row per (suite, variant, optimizer, seed, iteration) present, sorted, with the
        run key columns present, ``iteration``, ``evaluations`` (evaluations made so far in
        the run, failed ones included) and ``best_so_far`` (F).

    Raises:
        TypeError: If ``evaluations`` is not a DataFrame or ``free_energy`` is not numeric.
        ValueError: If a required column is missing.
    """
    _check_columns(evaluations, ("optimizer", "seed", "iteration", "free_energy"), "evaluations")
    energy = evaluations["free_energy"]
    if not pd.api.types.is_numeric_dtype(energy) or pd.api.types.is_bool_dtype(energy):
        raise TypeError(f"evaluations: column 'free_energy' must be numeric, got {energy.dtype}")
    energy = energy.astype(np.float64)
    valid = np.isfinite(energy)
    if "status" in evaluations.columns:
        valid &= evaluations["status"] == "ok"
    keys = [c for c in RUN_COLUMNS if c in evaluations.columns]  # suite, variant optional
    frame = evaluations[keys + ["iteration"]].assign(_f=energy.where(valid))
    per_iteration = (
        frame.groupby(keys + ["iteration"], sort=True)
        .agg(evaluations=("_f", "size"), best=("_f", "min"))
        .reset_index()
    )
    run = per_iteration.groupby(keys, sort=False)
    per_iteration["evaluations"] = run["evaluations"].cumsum().astype(np.int64)
    # cummin leaves NaN at iterations without a finite F; the forward fill carries the best.
    best = run["best"].cummin()
    per_iteration["best_so_far"] = best.groupby([per_iteration[k] for k in keys]).ffill()
    return per_iteration.drop(columns="best").reset_index(drop=True)


def area_under_curve(curve: ArrayLike, x: ArrayLike | None = None) -> float:
    """Normalised area under a best-so-far curve: its mean height over the x range.

    The trapezoid integral of the curve over x divided by the width x[-1] - x[0], so the result
    is in the units of F and lies between the curve's minimum and maximum; lower is better
    (F dropped sooner). With x = iteration index 0..T-1 (the default), runs of equal length
    compare directly. A single point gives its value; an empty curve or one with NaN (a run
    that had no finite F yet) gives NaN.

    Args:
        curve: (T,) best-so-far F per iteration.
        x: (T,) strictly increasing abscissae, e.g. evaluations so far; default 0..T-1.

    Returns:
        The normalised area in units of F.

    Raises:
        TypeError: If the inputs are not numbers.
        ValueError: If the inputs are not 1-D of equal length or ``x`` is not increasing.
    """
    try:
        y = np.asarray(curve, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise TypeError(f"curve must be numbers: {err}") from err
    if y.ndim != 1:
        raise ValueError(f"curve must be 1-D, got shape {y.shape}")
    t = np.arange(y.size, dtype=np.float64) if x is None else np.asarray(x, dtype=np.float64)
    if t.shape != y.shape:
        raise ValueError(f"x must have the shape of curve {y.shape}, got {t.shape}")
    if y.size and (not np.isfinite(t).all() or (np.diff(t) <= 0).any()):
        raise ValueError("x must be finite and strictly increasing")
    if y.size == 0 or np.isnan(y).any():
        return float("nan")
    if y.size == 1:
        return float(y[0])
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def run_metrics(curves: pd.DataFrame) -> pd.DataFrame:
    """Final best F and normalised AUC of every run from :func:`best_so_far_curves`.

    Args:
        curves: Output of :func:`best_so_far_curves`.

    Returns:
        One row per run with its key columns, ``iterations`` (T), ``final_free_energy`` (the
        best F after the run's last stored iteration) and ``auc`` (:func:`area_under_curve`
        over the iteration index).

    A run whose first iterations had no valid design has no best F there yet: for its AUC
    those iterations count as the worst best-so-far F of any run of its suite and variant (the
    highest point of their curves), so that a slow start costs the run rather than dropping
    it from the comparison. A run with no valid design at all has NaN for both.
    """
    _check_columns(curves, ("optimizer", "seed", "iteration", "best_so_far"), "curves")
    keys = [c for c in RUN_COLUMNS if c in curves.columns]
    groups = [k for k in ("suite", "variant") if k in keys]  # runs that compare
    heights = curves["best_so_far"].astype(np.float64)
    finite = curves[np.isfinite(heights)]
    worst: dict[Any, float] = (
        finite.groupby(groups)["best_so_far"].max().to_dict()
        if groups
        else {(): float(finite["best_so_far"].max()) if len(finite) else np.nan}
    )
    rows = []
    for key, run in curves.sort_values(keys + ["iteration"]).groupby(keys, sort=True):
        values = run["best_so_far"].to_numpy(dtype=np.float64)
        run_key = dict(zip(keys, key, strict=True))
        group = tuple(run_key[k] for k in groups)
        ceiling = worst.get(group[0] if len(group) == 1 else group, np.nan)
        started = np.isfinite(values)
        if started.any():  # only leading iterations can lack a best F (it never rises again)
            values = np.where(started, values, ceiling)
        rows.append(
            {
                **run_key,
                "iterations": int(values.size),
                "final_free_energy": float(values[-1]),
                "auc": area_under_curve(values, run["iteration"].to_numpy(dtype=np.float64)),
            }
        )
    return pd.DataFrame(rows, columns=[*keys, "iterations", "final_free_energy", "auc"])
