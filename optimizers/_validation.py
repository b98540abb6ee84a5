"""Checks of the public arguments.

Each error names the argument, what was wrong and what is allowed.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "BATCH_SIZE_MAX",
    "BOUND_MAX",
    "SEED_MAX",
    "VALUE_MAX",
    "check_bounds",
    "check_batch_size",
    "check_ids",
    "check_path",
    "check_values",
    "make_rng",
]

#: Largest magnitude of a bound. A wider box makes high - low or its square overflow float64
#: inside the backends (every optimizer asked for 1e308 with bounds of +-1e308).
BOUND_MAX = 1e15

#: Largest batch accepted; backends build (batch, d) matrices and some are quadratic in the
#: batch (optuna-cmaes with 10^6 hung for over 10 minutes).
BATCH_SIZE_MAX = 10_000

#: Seeds are stored as signed 64-bit integers (SQLite, Parquet), so larger ones are refused here.
SEED_MAX = 2**63 - 1

#: Largest magnitude of a told value. Backends square and normalize the values (a Gaussian
#: process fitted to 1e308 and 1 sees NaN); a failed evaluation is told as None, nan or inf.
VALUE_MAX = 1e100

SeedLike = int | np.integer | np.random.Generator | np.random.SeedSequence | None


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, (numbers.Real, np.floating, np.integer)) and not isinstance(
        value, (bool, np.bool_)
    )


def _real_array(value: Any, name: str, what: str) -> np.ndarray:
    """``value`` as a float64 array; TypeError for anything that is not real numbers."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be {what}, got a {type(value).__name__}")
    try:
        raw = np.asarray(value)
        items = np.asarray(value, dtype=object).ravel().tolist()
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be {what}, got {value!r} ({error})") from None
    flags = [v for v in items if isinstance(v, (bool, np.bool_))]
    if flags:
        # numpy turns [0, True] into ints; a bool among numbers is a mistake.
        raise TypeError(f"{name} must be {what}, got the bool {flags[0]!r} in {value!r}")
    if raw.dtype.kind == "O":
        # A ragged nesting or a list with non-numbers: say which.
        flat = list(raw.ravel())
        if any(isinstance(v, (list, tuple, np.ndarray)) for v in flat):
            raise ValueError(f"{name} must be {what}, got a ragged nesting {value!r}")
        if not all(_is_real(v) for v in flat):
            raise TypeError(f"{name} must be {what}, got {value!r}")
    elif raw.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be {what}, got dtype {raw.dtype} in {value!r}")
    try:
        return raw.astype(np.float64)
    except OverflowError:
        raise ValueError(f"{name} must be {what} that fit a float64, got {value!r}") from None


def check_bounds(bounds: Any, low: Any = None, high: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds from ``bounds`` (d, 2) or from ``low`` and ``high`` (d,).

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units, or None.
        low: (d,) lower bounds, only when ``bounds`` is None.
        high: (d,) upper bounds, only when ``bounds`` is None.

    Returns:
        (low, high), two (d,) float64 arrays with finite low < high.

    Raises:
        TypeError: Not numbers.
        ValueError: Wrong shape, both or neither form given, non-finite, or low >= high.
    """
    if bounds is not None:
        if low is not None or high is not None:
            raise ValueError("give either bounds=(d, 2) or low=(d,) and high=(d,), not both")
        array = _real_array(bounds, "bounds", "a (d, 2) array of [low, high] numbers")
        if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < 1:
            raise ValueError(
                f"bounds must have shape (d, 2) with d >= 1, one [low, high] row per dimension; "
                f"got shape {array.shape}"
            )
        lo, hi = array[:, 0].copy(), array[:, 1].copy()
    else:
        if low is None or high is None:
            raise ValueError(
                "bounds are missing: give bounds=(d, 2) [low, high] rows, or low=(d,) and high=(d,)"
            )
        lo = _real_array(low, "low", "a (d,) array of numbers")
        hi = _real_array(high, "high", "a (d,) array of numbers")
        if lo.ndim != 1 or hi.ndim != 1 or lo.shape != hi.shape or lo.size < 1:
            raise ValueError(
                f"low and high must both have shape (d,) with d >= 1; got {lo.shape} and {hi.shape}"
            )
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError(f"bounds must be finite, got low={lo.tolist()} high={hi.tolist()}")
    huge = np.flatnonzero((np.abs(lo) > BOUND_MAX) | (np.abs(hi) > BOUND_MAX))
    if huge.size:
        raise ValueError(
            f"bounds must lie within +-{BOUND_MAX:g} (rescale the problem); dimension(s) "
            f"{huge.tolist()} have low={lo[huge].tolist()} high={hi[huge].tolist()}"
        )
    bad = np.flatnonzero(~(lo < hi))
    if bad.size:
        raise ValueError(
            f"bounds need low < high in every dimension; dimension(s) {bad.tolist()} have "
            f"low={lo[bad].tolist()} high={hi[bad].tolist()} (drop a dimension to fix it)"
        )
    return lo, hi


def check_batch_size(batch_size: Any, minimum: int = 1, who: str = "the optimizer") -> int:
    """``batch_size`` as an int >= ``minimum``.

    Raises:
        TypeError: Not an int (bools are refused).
        ValueError: Below ``minimum`` or above ``BATCH_SIZE_MAX``.
    """
    if not _is_int(batch_size):
        raise TypeError(f"batch_size must be an int, got {batch_size!r}")
    if batch_size < minimum:
        raise ValueError(f"batch_size must be >= {minimum} for {who}, got {batch_size}")
    if batch_size > BATCH_SIZE_MAX:
        raise ValueError(f"batch_size must be <= {BATCH_SIZE_MAX} for {who}, got {batch_size}")
    return int(batch_size)


def make_rng(seed: Any) -> np.random.Generator:
    """The optimizer's generator from ``seed``.

    Args:
        seed: An int >= 0, a ``numpy.random.SeedSequence``, a ``numpy.random.Generator`` (used
            as is, not copied) or None for fresh entropy.

    Returns:
        A ``numpy.random.Generator``.

    Raises:
        TypeError: Another type (floats and bools are refused).
        ValueError: An int outside [0, 2**63 - 1] (seeds are stored as int64).
    """
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None or isinstance(seed, np.random.SeedSequence):
        return np.random.default_rng(seed)
    if _is_int(seed):
        if not 0 <= seed <= SEED_MAX:
            raise ValueError(f"seed must be an int in [0, 2**63 - 1], got {seed}")
        return np.random.default_rng(int(seed))
    raise TypeError(
        "seed must be an int >= 0, a numpy.random.SeedSequence, a numpy.random.Generator or "
        f"None; got {seed!r}"
    )


def check_ids(ids: Any) -> tuple[int, ...]:
    """``ids`` as a tuple of ints.

    Raises:
        TypeError: Not a 1-D sequence of ints.
    """
    if isinstance(ids, np.ndarray):
        if ids.ndim != 1 or (ids.size and ids.dtype.kind not in "iu"):
            raise TypeError(
                f"ids must be a 1-D sequence of ints (e.g. batch.ids), got an array of dtype "
                f"{ids.dtype} and shape {ids.shape}"
            )
        return tuple(int(i) for i in ids)
    if isinstance(ids, (str, bytes)) or not isinstance(ids, Sequence):
        raise TypeError(f"ids must be a sequence of ints (e.g. batch.ids), got {ids!r}")
    bad = [i for i in ids if not _is_int(i)]
    if bad:
        raise TypeError(f"ids must be ints (e.g. batch.ids), got {bad[0]!r} in {list(ids)!r}")
    return tuple(int(i) for i in ids)


def check_values(values: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scores and failure mask from ``values``.

    Args:
        values: n scores; a real number is a result, None or a non-finite number (nan, inf,
            -inf) a failed evaluation.
        n: Number of ids told with them.

    Returns:
        (values, failed): (n,) float64 with NaN at failures, and the (n,) bool failure mask.

    Raises:
        TypeError: Not a 1-D sequence of numbers or None.
        ValueError: Not n of them, a finite value beyond +-``VALUE_MAX``, or a finite value
            too large for float64 (an int, a Fraction or a longdouble; converted it would be
            inf, a failure).
    """
    what = "a 1-D sequence of numbers (None, nan or inf mark a failed evaluation)"
    if isinstance(values, np.ndarray):
        if values.dtype.kind in "iuf":
            # A longdouble beyond float64 turns into inf, which would be told as a failure; it
            # is refused below, so numpy's overflow warning would only repeat the error.
            with np.errstate(over="ignore"):
                array = values.astype(np.float64)
            overflow = np.flatnonzero((np.isfinite(values) & ~np.isfinite(array)).ravel())
            if overflow.size:
                k = int(overflow[0])
                raise ValueError(
                    f"values must fit a float64 (|v| < 1.8e308); entry {k} is "
                    f"{values.ravel()[k]!r}"
                )
        elif values.dtype.kind == "O":
            array = _object_values(list(values.ravel()), what).reshape(values.shape)
        else:
            raise TypeError(f"values must be {what}, got an array of dtype {values.dtype}")
    elif isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        raise TypeError(f"values must be {what}, got {values!r}")
    else:
        array = _object_values(list(values), what)
    if array.ndim != 1:
        raise ValueError(f"values must be 1-D, one per id; got shape {array.shape}")
    if array.shape[0] != n:
        raise ValueError(f"values must have one entry per id: got {array.shape[0]} for {n} ids")
    failed = ~np.isfinite(array)
    huge = np.flatnonzero(~failed & (np.abs(array) > VALUE_MAX))
    if huge.size:
        raise ValueError(
            f"values must lie within +-{VALUE_MAX:g} (tell None, nan or inf for a failed "
            f"evaluation); entry {int(huge[0])} is {array[huge[0]]!r}"
        )
    return np.where(failed, np.nan, array), failed


def _object_values(items: list[Any], what: str) -> np.ndarray:
    out = np.empty(len(items), dtype=np.float64)
    for k, v in enumerate(items):
        if v is None:
            out[k] = np.nan
        elif _is_real(v):
            try:
                out[k] = float(v)
            except OverflowError:
                out[k] = math.inf
            # Ints and Fractions raise OverflowError above, a longdouble silently becomes inf:
            # both are results too large for float64, not failed evaluations.
            given_finite = not isinstance(v, (float, np.floating)) or bool(np.isfinite(v))
            if given_finite and not math.isfinite(out[k]):
                raise ValueError(f"values must fit a float64 (|v| < 1.8e308); entry {k} is {v!r}")
        elif isinstance(v, (Sequence, np.ndarray)) and not isinstance(v, (str, bytes)):
            raise ValueError(f"values must be 1-D, one number per id; entry {k} is {v!r}")
        else:
            raise TypeError(f"values must be {what}; entry {k} is {v!r}")
    return out


def check_path(path: Any, name: str = "path") -> str:
    """``path`` as a str after checking it is a str or os.PathLike.

    Raises:
        TypeError: Another type.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{name} must be a str or os.PathLike, got {path!r}")
    result = os.fspath(path)
    if isinstance(result, bytes):
        raise TypeError(f"{name} must be a str path, got bytes {result!r}")
    return result
