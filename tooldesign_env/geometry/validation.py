"""Input checks shared by the geometry package: real, positive and integer scalars, and designs.

The ground floor of :mod:`tooldesign_env.geometry`: it imports nothing from the package. It also
names ``FloatArray``, the float64 array type every geometry function takes and returns.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["validate_coefficients"]

FloatArray = NDArray[np.float64]


def _check_real(label: str, value: object) -> float:
    """Return ``value`` as a float, or raise TypeError naming ``label`` if it is not real."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{label} must be a real number, got {type(value).__name__}")
    return float(value)


def _check_positive(label: str, value: object, unit: str) -> float:
    """Return ``value`` as a float if it is finite and > 0, else raise naming ``label``."""
    number = _check_real(label, value)
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{label} must be a finite number > 0 ({unit}), got {number!r}")
    return number


def _check_int(label: str, value: object, minimum: int) -> int:
    """Return ``value`` as an int >= ``minimum`` or raise TypeError/ValueError naming ``label``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{label} must be an integer, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{label} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def validate_coefficients(coeffs: ArrayLike, degree: int) -> FloatArray:
    """Check a coefficient vector and return it as a new float64 array.

    Args:
        coeffs: ``(c1, ..., cn)``, highest power first: a list, tuple or 1-D array of real numbers
            (any real dtype; integers and float32 are converted).
        degree: The polynomial degree n, i.e. the required number of coefficients (>= 1).

    Returns:
        (degree,) float64 array, a copy.

    Raises:
        TypeError: ``coeffs`` is None, a string, or holds non-real items (strings, None, objects,
            complex or boolean values); or ``degree`` is not an integer.
        ValueError: ``coeffs`` is not a flat sequence of exactly ``degree`` numbers, or holds NaN or
            infinite values (or ints too large for float64); or ``degree`` < 1.
    """
    degree = _check_int("degree", degree, 1)
    return _as_coefficients(coeffs, degree)


def _as_coefficients(coeffs: object, degree: int | None) -> FloatArray:
    """Validate ``coeffs`` like :func:`validate_coefficients`; any length >= 1 if degree is None."""
    count = "n >= 1" if degree is None else str(degree)
    allowed = f"allowed: a flat sequence of {count} finite real numbers (c1, ..., cn)"
    if coeffs is None or isinstance(coeffs, (str, bytes)):
        raise TypeError(f"coeffs must be real numbers, got {type(coeffs).__name__}; {allowed}")
    if np.ma.isMaskedArray(coeffs) and np.ma.getmaskarray(coeffs).any():
        # np.asarray would pass on the values under the mask, which the caller meant to hide.
        hidden = np.flatnonzero(np.ma.getmaskarray(coeffs)).tolist()
        raise ValueError(f"coeffs has masked values at index {hidden}; {allowed}")
    if isinstance(coeffs, (list, tuple)):
        # numpy turns [True, 0, 0] into ints; a bool among numbers is a mistake.
        flags = [item for item in coeffs if isinstance(item, (bool, np.bool_))]
        if flags:
            raise TypeError(f"coeffs holds a bool ({flags[0]!r}); {allowed}")
    try:
        array = np.asarray(coeffs)
    except (TypeError, ValueError) as error:  # ragged nesting such as [1, [2, 3]]
        raise ValueError(f"coeffs has an irregular shape ({error}); {allowed}") from None
    kind = array.dtype.kind
    if kind == "O":
        # Python objects: accept real numbers (Fraction, ints beyond int64), name the rest.
        for item in array.flat:
            if isinstance(item, bool) or not isinstance(item, numbers.Real):
                raise TypeError(f"coeffs holds a {type(item).__name__} ({item!r}); {allowed}")
    elif kind == "c":
        raise TypeError(f"coeffs holds complex numbers (dtype {array.dtype}); {allowed}")
    elif kind not in "iuf":
        raise TypeError(
            f"coeffs holds values that are not real numbers (dtype {array.dtype}); {allowed}"
        )
    if array.ndim != 1 or array.shape[0] < 1 or (degree is not None and array.shape[0] != degree):
        expected = "(n,)" if degree is None else f"({degree},)"
        raise ValueError(f"coeffs has shape {array.shape}, expected {expected}; {allowed}")
    try:
        values = np.array([float(item) for item in array.tolist()], dtype=np.float64)
    except OverflowError:
        raise ValueError(f"coeffs holds an integer too large for float64; {allowed}") from None
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise ValueError(
            f"coeffs holds NaN or infinite values at index {bad.tolist()} ({values.tolist()}); "
            f"{allowed}"
        )
    return values
