"""Tool geometry: pure functions from polynomial coefficients to shapes, mass and files.

Nothing here touches PyBullet. The design is a coefficient vector ``C = (c1, ..., cn)`` meaning
``p(u) = c1 u^n + ... + cn u`` (highest power first, constant term fixed at 0, as in the paper's
section "Tool parametrization and generation"). The tool is a straight handle followed by the graph
of ``p`` cut at a fixed arc length ``L0``, both swept with a square section.

Tool frame (all outputs): origin at the grasp point (the centre of the straight handle), x along the
handle toward the curve, y lateral, z up; SI units (m, kg, kg m^2). The handle runs from
``x = -handle_length / 2`` to ``x0 = +handle_length / 2`` at ``y = 0``; the curve is the point set
``(x0 + u, p(u))`` for ``u`` in ``[0, u_end]``, where the arc length of ``p`` over ``[0, u_end]`` is
``L0``.

One polyline drives everything: the handle plus ``n_segments`` chords of equal arc length on the
curve. The mesh is the mitred sweep of that polyline; the collision boxes are its segments, each
lengthened at a bend so that their union is exactly the mesh's solid; the mass properties are those
of the mesh. Collision, inertia and the printed part therefore describe one and the same solid.

See ``docs/geometry.md`` for the derivations (arc-length solve, overlap rule, buildability rule).
"""

from __future__ import annotations

import math
import numbers
import os
import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MITRE_LIMIT",
    "Box",
    "ToolGeometry",
    "ToolSpec",
    "curve_arc_length",
    "curve_points",
    "export_mesh",
    "make_tool",
    "solve_curve_extent",
    "tool_link_xml",
    "tool_mesh",
    "tool_urdf",
    "validate_coefficients",
]

FloatArray = NDArray[np.float64]

#: Largest mitre scale ``1 / cos(turn / 2)`` used at a joint (SVG's ``stroke-miterlimit`` default).
#: It caps turns at about 151 degrees so that no offset runs to infinity; a joint that needs more is
#: reported as not buildable, and its mesh and boxes are clamped (finite, watertight, but inexact).
MITRE_LIMIT = 4.0

# Relative accuracy asked of the arc-length quadrature, per panel. Panels are positive, so the
# integral over any [0, u] inherits it. 1e-13 sits well above the round-off of a 16-point sum.
_ARC_RTOL = 1e-13
# Arc-length inversion stops when |s(u) - target| <= this times the largest target.
_INVERT_ATOL = 1e-13
# The promise on the curve end, checked after every solve by a second quadrature rule.
_EXTENT_RTOL = 1e-6
# Non-adjacent pieces of the sweep may touch but must not overlap by more than this (m).
_OVERLAP_TOL = 1e-9

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
_GL24_NODES, _GL24_WEIGHTS = np.polynomial.legendre.leggauss(24)
_EPS = float(np.finfo(np.float64).eps)


# --------------------------------------------------------------------------------------------
# Specification and input validation
# --------------------------------------------------------------------------------------------


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


@dataclass(frozen=True, kw_only=True)
class ToolSpec:
    """The fixed, non-designed constants of a tool (defaults: the paper's scene).

    Attributes:
        arc_length: L0, arc length of the curved part in m (the paper's fixed curve length).
        handle_length: Length of the straight handle in m; the grasp point is its centre.
        section: Side of the square cross-section in m.
        density: Material density in kg/m^3 (250 is light wood or a porous print).
        n_segments: Number of chords of equal arc length that approximate the curve (>= 1); one
            collision box per chord plus one for the handle.
        degree: Polynomial degree n, i.e. the number of coefficients (c1, ..., cn) (>= 1).
    """

    arc_length: float = 1.1
    handle_length: float = 0.15
    section: float = 0.03
    density: float = 250.0
    n_segments: int = 30
    degree: int = 3

    def __post_init__(self) -> None:
        units = {"arc_length": "m", "handle_length": "m", "section": "m", "density": "kg/m^3"}
        for name, unit in units.items():
            value = _check_positive(f"ToolSpec.{name}", getattr(self, name), unit)
            object.__setattr__(self, name, value)
        for name in ("n_segments", "degree"):
            object.__setattr__(self, name, _check_int(f"ToolSpec.{name}", getattr(self, name), 1))


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


# --------------------------------------------------------------------------------------------
# The polynomial and its arc length
# --------------------------------------------------------------------------------------------


def _derivative(coeffs: FloatArray) -> FloatArray:
    """Coefficients of p'(u), highest power first (``np.polyval`` order)."""
    n = coeffs.shape[0]
    return coeffs * np.arange(n, 0, -1, dtype=np.float64)


def _poly(coeffs: FloatArray) -> FloatArray:
    """Coefficients of p(u) with its zero constant term, for ``np.polyval``."""
    return np.append(coeffs, 0.0)


def _horner(coeffs: FloatArray, u: FloatArray) -> FloatArray:
    """The polynomial ``coeffs`` (highest power first) at ``u``.

    It is ``np.polyval`` without its per-call overhead, which dominates on the small arrays here.
    """
    result = np.full_like(u, coeffs[0], dtype=np.float64)
    for coefficient in coeffs[1:].tolist():
        result = result * u + coefficient
    return result


def _speed(dcoeffs: FloatArray, u: FloatArray) -> FloatArray:
    # ds/du = sqrt(1 + p'^2); hypot avoids overflow of p'^2 for steep curves.
    return np.hypot(1.0, _horner(dcoeffs, u))


def _gauss_legendre(dcoeffs: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """16-point Gauss-Legendre integrals of the speed over each [a_i, b_i]."""
    half = 0.5 * (b - a)
    nodes = (0.5 * (a + b))[..., None] + half[..., None] * _GL_NODES
    return half * _row_sums(_speed(dcoeffs, nodes) * _GL_WEIGHTS)


def _row_sums(values: FloatArray) -> FloatArray:
    """Sums over the last axis in a fixed pairwise order, whatever the number of rows.

    Neither a BLAS matmul nor np.sum promises an order that is independent of the array's
    shape; the curve end must not change with how many points are solved together.
    """
    while values.shape[-1] > 1:
        half = values.shape[-1] // 2
        summed = values[..., :half] + values[..., half : 2 * half]
        if values.shape[-1] % 2:
            summed[..., 0] += values[..., -1]
        values = summed
    return values[..., 0]


def _root_candidates(poly: FloatArray, scale: float) -> list[float]:
    """Real parts of the roots of a polynomial (highest power first) that matter on [0, scale].

    The polynomial is first written in t = u / scale, and leading coefficients below round-off
    of the largest one are dropped: on [0, 1] they change nothing, while a tiny leading
    coefficient (c1 = 1e-38, say) would make np.roots' companion matrix useless for the roots
    that do matter. Degrees 1 and 2 are solved in closed form (np.roots costs tens of
    microseconds), the quadratic in its cancellation-free form. [] if the polynomial is constant.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        scaled = poly * scale ** np.arange(poly.size - 1, -1, -1, dtype=np.float64)
    if not np.all(np.isfinite(scaled)):
        scaled, scale = np.asarray(poly, dtype=np.float64), 1.0
    magnitude = np.abs(scaled)
    significant = np.flatnonzero(magnitude > 4.0 * _EPS * magnitude.max())
    if significant.size == 0:
        return []
    scaled = scaled[significant[0] :]
    if scaled.size <= 1:
        return []
    if scaled.size == 2:
        roots = [-scaled[1] / scaled[0]]
    elif scaled.size == 3:
        a, b, c = scaled.tolist()
        discriminant = b * b - 4.0 * a * c
        if discriminant < 0.0:
            roots = [-b / (2.0 * a)]
        else:
            q = -0.5 * (b + math.copysign(math.sqrt(discriminant), b))
            roots = [q / a, c / q] if q != 0.0 else [0.0]
    else:
        roots = np.real(np.roots(scaled)).tolist()
    return [root * scale for root in roots]


def _breakpoints(dcoeffs: FloatArray, u_max: float) -> FloatArray:
    """Sorted unique points of (0, u_max) where the speed may have a sharp knee.

    The speed sqrt(1 + p'^2) is analytic but turns sharply (over a width ~ 1 / |p''|) where p' is
    near 0; real parts of the roots of p' and p'' mark those places. Splitting there lets every
    panel see a smooth integrand. Spurious points are harmless: they only add panels.
    """
    second = np.polyder(dcoeffs) if dcoeffs.size > 1 else np.zeros(1)
    candidates = _root_candidates(dcoeffs, u_max) + _root_candidates(second, u_max)
    inside = [c for c in candidates if 0.0 < c < u_max and math.isfinite(c)]
    return np.unique(np.asarray(inside, dtype=np.float64))


@dataclass(frozen=True)
class _ArcTable:
    """Adaptive Gauss-Legendre panels of s(u) = int_0^u sqrt(1 + p'^2) on [0, u_max].

    Attributes:
        dcoeffs: p' coefficients, highest power first.
        edges: (k + 1,) panel edges in m, from 0 to u_max.
        cumulative: (k + 1,) arc length at each edge in m.
    """

    dcoeffs: FloatArray
    edges: FloatArray
    cumulative: FloatArray

    @classmethod
    def build(cls, coeffs: FloatArray, u_max: float) -> _ArcTable:
        dcoeffs = _derivative(coeffs)
        magnitude = np.abs(dcoeffs)
        edges = np.concatenate(([0.0], _breakpoints(dcoeffs, u_max), [u_max]))
        a, b = edges[:-1], edges[1:]
        done_a: list[FloatArray] = []
        done_b: list[FloatArray] = []
        done_v: list[FloatArray] = []
        # Bisect until a panel agrees with the sum of its halves. Each accepted panel keeps its
        # own one-panel value, so a partial panel [a, u] is integrated by the same rule and s(u)
        # is continuous at the edges. In practice the loop ends after a few levels; the caps on
        # levels and panels only bound the work for absurd inputs (the result is checked anyway).
        for level in range(60):
            mid = 0.5 * (a + b)
            whole = _gauss_legendre(dcoeffs, a, b)
            halves = _gauss_legendre(dcoeffs, a, mid) + _gauss_legendre(dcoeffs, mid, b)
            # Where p' nearly cancels (steep designs, near a root of p'), its round-off,
            # about eps * sum |d_i u^i|, is the best any rule can do; without this floor the
            # panels there would split forever.
            noise = 64.0 * _EPS * (b - a) * _horner(magnitude, b)
            ok = np.abs(whole - halves) <= _ARC_RTOL * halves + noise
            if level == 59 or a.size > 10_000:
                ok[:] = True
            done_a.append(a[ok])
            done_b.append(b[ok])
            done_v.append(whole[ok])
            if ok.all():
                break
            a, b = (
                np.concatenate((a[~ok], mid[~ok])),
                np.concatenate((mid[~ok], b[~ok])),
            )
        left = np.concatenate(done_a)
        order = np.argsort(left, kind="stable")
        right = np.concatenate(done_b)[order]
        values = np.concatenate(done_v)[order]
        edges = np.concatenate((left[order], right[-1:]))
        cumulative = np.concatenate(([0.0], np.cumsum(values)))
        return cls(dcoeffs=dcoeffs, edges=edges, cumulative=cumulative)

    def __call__(self, u: FloatArray) -> FloatArray:
        """Arc length s(u) in m for each u in [0, u_max]."""
        u = np.asarray(u, dtype=np.float64)
        index = np.clip(np.searchsorted(self.edges, u, side="right") - 1, 0, self.edges.size - 2)
        start = self.edges[index]
        return self.cumulative[index] + _gauss_legendre(self.dcoeffs, start, u)

    def invert(self, targets: FloatArray) -> FloatArray:
        """Parameters u with s(u) = target, by bracketed Newton steps (elementwise).

        Each target is iterated on its own (converged ones are frozen), so a result does not
        depend on which other targets were solved with it: the curve end found by
        ``solve_curve_extent`` is bit-identical to the last point of ``curve_points``.

        Args:
            targets: (k,) arc lengths in m, in [0, u_max].

        Returns:
            (k,) parameters u in m with |s(u) - target| <= 1e-13 max(targets) (or a bracket
            collapsed to a few ulps, which only round-off can cause).
        """
        targets = np.asarray(targets, dtype=np.float64)
        tolerance = _INVERT_ATOL * float(np.max(targets))
        # s(u) >= u, so the root lies in [0, target] (and in [0, u_max]).
        lo = np.zeros_like(targets)
        hi = np.minimum(targets, self.edges[-1])
        # Piecewise-linear inverse of the table: a start a few Newton steps from the root.
        u = np.clip(np.interp(targets, self.cumulative, self.edges), lo, hi)
        active = np.ones(targets.shape, dtype=bool)
        for _ in range(2000):
            residual = self(u) - targets
            below = residual < 0
            lo = np.where(below, u, lo)
            hi = np.where(below, hi, u)
            newton = u - residual / _speed(self.dcoeffs, u)
            # Bisect when Newton leaves the bracket; geometrically across orders of magnitude,
            # as a steep design's curve end can be far below the bracket's upper end.
            outside = (newton <= lo) | (newton >= hi)
            if outside.any():
                wide = (lo > 0) & (hi > 4.0 * lo)
                middle = np.where(wide, np.sqrt(lo * hi), 0.5 * (lo + hi))
                newton = np.where(outside, middle, newton)
            settled = (np.abs(residual) <= tolerance) | (hi - lo <= 4 * _EPS * hi)
            active &= ~settled
            if not active.any():
                break
            u = np.where(active, newton, u)
        return u

    def check(self, u_end: float, arc_length: float) -> None:
        """Raise RuntimeError unless s(u_end) = arc_length to a relative 1e-6.

        s is recomputed with a 24-point Gauss-Legendre rule on the table's panels (the table
        itself uses 16 points), so a panel the adaptive rule had wrongly accepted would show.
        """
        edges = self.edges[self.edges < u_end]
        b = np.append(edges[1:], u_end)
        half = 0.5 * (b - edges)
        nodes = (0.5 * (b + edges))[:, None] + half[:, None] * _GL24_NODES
        value = float(np.sum(half * _row_sums(_speed(self.dcoeffs, nodes) * _GL24_WEIGHTS)))
        error = abs(value - arc_length) / arc_length
        if not error < _EXTENT_RTOL:
            raise RuntimeError(
                f"arc-length solve failed: u_end {u_end!r} gives an arc length of {value!r} "
                f"instead of {arc_length!r} (relative error {error:.3g}); please report the "
                "coefficients"
            )


def curve_arc_length(coeffs: ArrayLike, u: float) -> float:
    """Arc length of the graph of p over [0, u].

    Adaptive 16-point Gauss-Legendre quadrature of sqrt(1 + p'(u)^2), split where p' or p'' vanish;
    relative accuracy about 1e-13 (checked against scipy's QUADPACK and closed forms in the tests).

    Args:
        coeffs: ``(c1, ..., cn)``, highest power first; n = len(coeffs).
        u: Upper limit in m (>= 0), in the polynomial's own coordinate (x - handle_length / 2).

    Returns:
        Arc length in m.
    """
    values = _as_coefficients(coeffs, None)
    limit = _check_real("u", u)
    if not (math.isfinite(limit) and limit >= 0):
        raise ValueError(f"u must be a finite number >= 0 (m), got {limit!r}")
    if limit == 0.0:
        return 0.0
    table = _ArcTable.build(values, limit)
    return float(table.cumulative[-1])


def solve_curve_extent(coeffs: ArrayLike, arc_length: float) -> float:
    """Find u_end such that the arc length of p over [0, u_end] equals ``arc_length``.

    The root is bracketed by [0, arc_length] (arc length >= u) and found by safeguarded Newton
    steps on the quadrature table; the result is then re-integrated with a 24-point rule and a
    relative arc-length error of 1e-6 or more raises (it is about 1e-13 in practice; the tests
    compare with scipy's QUADPACK, mpmath and closed forms).

    Args:
        coeffs: ``(c1, ..., cn)``, highest power first.
        arc_length: L0 in m (> 0).

    Returns:
        u_end in m, in the polynomial's own coordinate.

    Raises:
        RuntimeError: The check disagrees by 1e-6 or more (never seen; a bug to report).
    """
    values = _as_coefficients(coeffs, None)
    length = _check_positive("arc_length", arc_length, "m")
    table = _ArcTable.build(values, length)
    u_end = float(table.invert(np.array([length]))[0])
    table.check(u_end, length)
    return u_end


def _curve_parameters(coeffs: FloatArray, arc_length: float, n: int) -> FloatArray:
    """(n + 1,) parameters u_k with s(u_k) = k arc_length / n, the last one checked."""
    table = _ArcTable.build(coeffs, arc_length)
    targets = arc_length * (np.arange(n + 1, dtype=np.float64) / n)
    targets[-1] = arc_length  # exactly, so the last point is the curve end
    u = table.invert(targets)
    table.check(float(u[-1]), arc_length)
    return u


def curve_points(coeffs: ArrayLike, arc_length: float, n: int) -> FloatArray:
    """Points of the curve evenly spaced along its arc.

    Args:
        coeffs: ``(c1, ..., cn)``, highest power first.
        arc_length: L0 in m (> 0).
        n: Number of intervals (>= 1).

    Returns:
        (n + 1, 2) points ``(u_k, p(u_k))`` in m, in the polynomial's own coordinates (add
        ``handle_length / 2`` to u for the tool frame). Point 0 is (0, 0); the arc length between
        consecutive points is ``arc_length / n`` to about 1e-13 relative (each point is inverted
        to |s(u_k) - k L0 / n| <= 1e-13 L0).
    """
    values = _as_coefficients(coeffs, None)
    length = _check_positive("arc_length", arc_length, "m")
    count = _check_int("n", n, 1)
    u = _curve_parameters(values, length, count)
    return np.column_stack((u, np.polyval(_poly(values), u)))


# --------------------------------------------------------------------------------------------
# Curvature
# --------------------------------------------------------------------------------------------


def _min_radius_of_curvature(coeffs: FloatArray, u_end: float) -> float:
    """Minimum over [0, u_end] of (1 + p'^2)^(3/2) / |p''| in m (inf for a straight line).

    The curvature k = p'' / (1 + p'^2)^(3/2) has k' = 0 where
    q = p''' (1 + p'^2) - 3 p' p''^2 vanishes, so its largest magnitude is at a real root of q or
    at an end. The real parts of all roots are tried: a complex root only adds a harmless
    candidate, and a real root that round-off gave a tiny imaginary part is not lost.

    The work is done in t = u / u_end, with P(t) = p(u_end t) (coefficients c_i u_end^i, the
    size of each term at the curve's end), where q becomes P''' (U^2 + P'^2) - 3 P' P''^2 and
    k = U |P''| / (U^2 + P'^2)^(3/2), U = u_end: steep designs would overflow otherwise.
    """
    scale = u_end
    powers = np.arange(coeffs.size, 0, -1, dtype=np.float64)
    d1 = _derivative(coeffs * scale**powers)
    # np.polyder of a constant is empty; a zero polynomial keeps the products below defined.
    d2 = np.polyder(d1) if d1.size > 1 else np.zeros(1)
    d3 = np.polyder(d2) if d2.size > 1 else np.zeros(1)
    # np.convolve multiplies polynomials; np.polymul does the same at 30 times the cost.
    first = np.convolve(d3, np.convolve(d1, d1))
    first[-1] += d3[-1] * scale * scale  # P''' U^2
    second = 3.0 * np.convolve(d1, np.convolve(d2, d2))
    size = max(first.size, second.size)
    q = np.zeros(size)
    q[size - first.size :] += first
    q[size - second.size :] -= second
    t = np.clip(np.asarray([0.0, 1.0, *_root_candidates(q, 1.0)]), 0.0, 1.0)
    # R = (U^2 + P'^2)^(3/2) / (U |P''|), in logarithms: U^3 underflows for steep designs.
    # log 0 = -inf for P'' = 0 gives R = inf (a straight stretch), as it should.
    with np.errstate(divide="ignore", over="ignore"):
        log_radius = (
            3.0 * np.log(np.hypot(scale, _horner(d1, t)))
            - math.log(scale)
            - np.log(np.abs(_horner(d2, t)))
        )
        return float(np.exp(np.min(log_radius)))


# --------------------------------------------------------------------------------------------
# The mitred sweep, boxes and mass properties
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True, eq=False)
class Box:
    """One collision box of the tool, in the tool frame.

    Attributes:
        center: (3,) centre in m.
        half_extents: (3,) half sizes in m along the box's own x (the segment), y and z.
        yaw: Rotation about the tool's z axis in rad (the box's x is the segment direction).
    """

    center: FloatArray
    half_extents: FloatArray
    yaw: float


def _frozen(array: ArrayLike) -> FloatArray:
    result = np.array(array, dtype=np.float64)
    result.setflags(write=False)
    return result


@dataclass(frozen=True)
class _Sweep:
    """The mitred sweep of a polyline.

    Attributes:
        directions: (k, 2) unit segment directions.
        chords: (k,) segment lengths in m.
        normals: (k + 1, 2) unit in-plane mitre directions at the vertices.
        scales: (k + 1,) offset scale 1 / cos(turn / 2) at the vertices (clamped at MITRE_LIMIT).
        turns: (k + 1,) turn angle in rad at the vertices (0 at the ends), signed (left > 0).
        vertices: (4 (k + 1), 3) mesh vertices in m.
        faces: (8 k + 4, 3) triangles, outward counter-clockwise winding.
    """

    directions: FloatArray
    chords: FloatArray
    normals: FloatArray
    scales: FloatArray
    turns: FloatArray
    vertices: FloatArray
    faces: NDArray[np.int64]


def _sweep(polyline: FloatArray, section: float) -> _Sweep:
    """Sweep a square of side ``section`` along a planar polyline with mitred joints."""
    delta = np.diff(polyline, axis=0)
    chords = np.hypot(delta[:, 0], delta[:, 1])
    directions = delta / chords[:, None]
    seg_normals = np.column_stack((-directions[:, 1], directions[:, 0]))
    normals = np.concatenate(
        (seg_normals[:1], seg_normals[:-1] + seg_normals[1:], seg_normals[-1:])
    )
    norm = np.hypot(normals[:, 0], normals[:, 1])
    # A graph x -> p(x) never reverses (dx > 0), so the summed normals never cancel; guard anyway.
    norm = np.where(norm > 1e-12, norm, 1.0)
    normals = normals / norm[:, None]
    turns = np.zeros(polyline.shape[0])
    cross = directions[:-1, 0] * directions[1:, 1] - directions[:-1, 1] * directions[1:, 0]
    dot = np.einsum("ij,ij->i", directions[:-1], directions[1:])
    turns[1:-1] = np.arctan2(cross, dot)
    # 1 / cos(turn / 2), with cos(turn / 2) = normal . segment normal.
    cos_half = np.ones(polyline.shape[0])
    cos_half[1:-1] = np.einsum("ij,ij->i", normals[1:-1], seg_normals[1:])
    scales = np.minimum(1.0 / np.maximum(cos_half, 1.0 / MITRE_LIMIT), MITRE_LIMIT)

    half = 0.5 * section
    offset = (half * scales)[:, None] * normals
    right, left = polyline - offset, polyline + offset
    count = polyline.shape[0]
    vertices = np.empty((count, 4, 3))
    # Corner order around the section: (right, bottom), (left, bottom), (left, top), (right, top);
    # counter-clockwise seen from ahead, i.e. the section's normal is the direction of travel.
    vertices[:, 0, :2], vertices[:, 0, 2] = right, -half
    vertices[:, 1, :2], vertices[:, 1, 2] = left, -half
    vertices[:, 2, :2], vertices[:, 2, 2] = left, half
    vertices[:, 3, :2], vertices[:, 3, 2] = right, half
    vertices = vertices.reshape(-1, 3)

    base = 4 * np.arange(count - 1)[:, None]
    k = np.arange(4)
    a, b = base + k, base + (k + 1) % 4  # this section's corners k and k + 1
    c, d = b + 4, a + 4  # the next section's corners k + 1 and k
    sides = np.stack((np.stack((a, b, c), -1), np.stack((a, c, d), -1)), axis=2).reshape(-1, 3)
    last = 4 * (count - 1)
    caps = np.array([[0, 2, 1], [0, 3, 2], [last, last + 1, last + 2], [last, last + 2, last + 3]])
    faces = np.concatenate((sides, caps)).astype(np.int64)
    return _Sweep(
        directions=directions,
        chords=chords,
        normals=normals,
        scales=scales,
        turns=turns,
        vertices=vertices,
        faces=faces,
    )


def _boxes(polyline: FloatArray, sweep: _Sweep, section: float) -> tuple[Box, ...]:
    """One box per polyline segment, lengthened at each bend to the mitre's outer corner.

    At a joint turning by t, the mitre plane meets the outer wall (section / 2) tan(t / 2) past
    the joint. Lengthening both neighbouring boxes by that much there closes the wedge-shaped gap
    on the outer side of the bend; the extra length on the inner side lies inside the neighbour,
    so the union of the boxes is exactly the mitred sweep (the mesh).
    """
    half = 0.5 * section
    extension = half * np.sqrt(np.maximum(sweep.scales**2 - 1.0, 0.0))  # tan(t/2) = sqrt(s^2 - 1)
    before, after = extension[:-1], extension[1:]
    centers = 0.5 * (polyline[:-1] + polyline[1:]) + (0.5 * (after - before))[:, None] * (
        sweep.directions
    )
    lengths = 0.5 * sweep.chords + 0.5 * (before + after)
    yaws = np.arctan2(sweep.directions[:, 1], sweep.directions[:, 0])
    return tuple(
        Box(
            center=_frozen((cx, cy, 0.0)),
            half_extents=_frozen((hl, half, half)),
            yaw=float(yaw),
        )
        for (cx, cy), hl, yaw in zip(centers.tolist(), lengths.tolist(), yaws.tolist(), strict=True)
    )


def _piece_outlines(sweep: _Sweep) -> FloatArray:
    """(k, 4, 2) in-plane quadrilaterals of the sweep's pieces (right0, left0, left1, right1)."""
    corners = sweep.vertices.reshape(-1, 4, 3)[:, :2, :2]  # bottom right, bottom left
    return np.concatenate((corners[:-1], corners[1:, ::-1]), axis=1)


def _overlapping_pieces(outlines: FloatArray) -> list[tuple[int, int]]:
    """Pairs (i, j), j >= i + 2, of convex quadrilaterals that overlap (separating axis test).

    Neighbours (j = i + 1) share a mitre face by construction and are not tested.
    """
    centers = outlines.mean(axis=1)
    radii = np.max(np.linalg.norm(outlines - centers[:, None], axis=2), axis=1)
    # Broad phase on bounding circles: along a curve only a few pairs survive it.
    gap = np.linalg.norm(centers[:, None] - centers[None], axis=2) - (radii[:, None] + radii)
    first, second = np.nonzero(np.triu(gap < 0, k=2))
    if first.size == 0:
        return []
    pa, pb = outlines[first], outlines[second]  # (m, 4, 2)
    edges = np.concatenate((np.roll(pa, -1, 1) - pa, np.roll(pb, -1, 1) - pb), axis=1)
    axes = np.stack((-edges[..., 1], edges[..., 0]), axis=-1)  # (m, 8, 2) edge normals
    length = np.hypot(axes[..., 0], axes[..., 1])
    axes = axes / np.where(length > 0, length, 1.0)[..., None]
    proj_a = np.matmul(axes, pa.transpose(0, 2, 1))  # (m, 8 axes, 4 corners)
    proj_b = np.matmul(axes, pb.transpose(0, 2, 1))
    overlap = np.minimum(proj_a.max(-1), proj_b.max(-1)) - np.maximum(
        proj_a.min(-1), proj_b.min(-1)
    )
    overlapping = np.all(overlap > _OVERLAP_TOL, axis=1)
    return list(zip(first[overlapping].tolist(), second[overlapping].tolist(), strict=True))


def _buildability(sweep: _Sweep, radius: float, section: float) -> str:
    """Empty string if the swept tube is a simple solid, else the first reason it is not."""
    if not radius > 0.5 * section:
        return (
            f"the minimum radius of curvature {radius:.6g} m is not above section / 2 = "
            f"{0.5 * section:.6g} m: the inner wall of the swept tube folds over itself"
        )
    clamped = np.flatnonzero(sweep.scales >= MITRE_LIMIT)
    if clamped.size:
        joint = int(clamped[0])
        return (
            f"the centreline turns by {math.degrees(abs(sweep.turns[joint])):.1f} degrees at "
            f"joint {joint}, beyond the mitre limit of "
            f"{math.degrees(2 * math.acos(1 / MITRE_LIMIT)):.1f} degrees"
        )
    outlines = _piece_outlines(sweep)
    # Inner walls shortened by the mitres must keep a non-negative length.
    walls = np.einsum("kd,kd->k", outlines[:, 3] - outlines[:, 0], sweep.directions)
    walls = np.minimum(
        walls, np.einsum("kd,kd->k", outlines[:, 2] - outlines[:, 1], sweep.directions)
    )
    inverted = np.flatnonzero(walls < -_OVERLAP_TOL)
    if inverted.size:
        piece = int(inverted[0])
        return (
            f"piece {piece} of the sweep is turned inside out (inner wall {walls[piece]:.3g} m): "
            "the bends on both of its ends are too sharp for its length; use more segments"
        )
    pairs = _overlapping_pieces(outlines)
    if pairs:
        i, j = pairs[0]
        where = "the handle" if i == 0 else f"curve segment {i}"
        return f"curve segment {j} overlaps {where}: the tube folds back into itself"
    return ""


def _mass_properties(
    sweep: _Sweep, section: float, density: float
) -> tuple[float, FloatArray, FloatArray]:
    """Volume (m^3), centre of mass (3,) m and inertia (3, 3) kg m^2 about it, of the sweep's mesh.

    The mesh is a prism of height ``section`` (z in [-section/2, section/2]) over the outline
    polygon right side forward, left side back; the mitre faces between pieces are internal and
    cancel. So the divergence-theorem integrals that trimesh evaluates over the triangles reduce
    to the polygon's area moments (shoelace formulas) times the height, plus the z^2 term of the
    height. This is exact for the mesh (the tests compare with ``Trimesh.mass_properties`` to
    1e-9) and about ten times faster than integrating the triangles.
    """
    corners = sweep.vertices.reshape(-1, 4, 3)
    outline = np.concatenate((corners[:, 0, :2], corners[::-1, 1, :2]))  # counter-clockwise
    # Moments about a point near the centroid keep the parallel-axis shift free of cancellation.
    reference = outline.mean(axis=0)
    x0, y0 = (outline - reference).T
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    cross = x0 * y1 - x1 * y0
    area = cross.sum() / 2.0
    sx = ((x0 + x1) * cross).sum() / 6.0
    sy = ((y0 + y1) * cross).sum() / 6.0
    sxx = ((x0 * x0 + x0 * x1 + x1 * x1) * cross).sum() / 12.0
    syy = ((y0 * y0 + y0 * y1 + y1 * y1) * cross).sum() / 12.0
    sxy = ((x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * cross).sum() / 24.0
    volume = section * area
    cx, cy = sx / area, sy / area
    # Second moments of the solid about its centre of mass (the z centre is 0 by symmetry).
    xx = section * (sxx - area * cx * cx)
    yy = section * (syy - area * cy * cy)
    xy = section * (sxy - area * cx * cy)
    zz = area * section**3 / 12.0
    inertia = density * np.array([[yy + zz, -xy, 0.0], [-xy, xx + zz, 0.0], [0.0, 0.0, xx + yy]])
    center = np.array([cx + reference[0], cy + reference[1], 0.0])
    return float(volume), center, inertia


@dataclass(frozen=True, kw_only=True, eq=False)
class ToolGeometry:
    """A tool made by :func:`make_tool`: its shape, collision boxes and mass properties.

    All positions are in the tool frame (origin at the grasp point, x along the handle toward the
    curve, z up), in m. Arrays are read-only. Compare designs by ``coeffs`` and ``spec``.

    Attributes:
        coeffs: (degree,) the design ``(c1, ..., cn)``, highest power first.
        spec: The fixed constants the tool was made with.
        curve_extent: u_end in m: the curve spans ``x`` in ``[x0, x0 + u_end]``.
        centerline: (n_segments + 2, 2) polyline (x, y) in m: handle start, handle end (= curve
            start, x0 = handle_length / 2), then the curve points evenly spaced along the arc.
        boxes: One :class:`Box` for the handle, then one per curve segment (n_segments + 1).
        volume: Volume of the mesh in m^3 (section^2 times the centreline's length).
        mass: Mass in kg (density times volume).
        center_of_mass: (3,) centre of mass in m.
        inertia: (3, 3) inertia tensor in kg m^2 about the centre of mass, tool-frame axes.
        min_radius_of_curvature: Minimum radius of curvature of the curve p in m (analytic,
            over [0, u_end]; inf for a straight curve).
        buildable: Whether the swept tube is a simple solid (see ``why_not_buildable``).
        why_not_buildable: Empty if buildable, else the first violated rule in words.
        tip: (3,) the curve's end point in m.
        bounds: (2, 3) axis-aligned bounding box of the mesh in m: (min, max).
    """

    coeffs: FloatArray
    spec: ToolSpec
    curve_extent: float
    centerline: FloatArray
    boxes: tuple[Box, ...]
    volume: float
    mass: float
    center_of_mass: FloatArray
    inertia: FloatArray
    min_radius_of_curvature: float
    buildable: bool
    why_not_buildable: str
    tip: FloatArray
    bounds: FloatArray


def make_tool(coeffs: ArrayLike, spec: ToolSpec | None = None) -> ToolGeometry:
    """Build the tool of a design.

    Args:
        coeffs: ``(c1, ..., cn)`` with n = ``spec.degree``, highest power first.
        spec: Fixed constants; ``ToolSpec()`` (the paper's tool) if None.

    Returns:
        The tool's geometry, collision boxes and mass properties. Mass properties are those of the
        mitred-sweep mesh (:func:`tool_mesh`), integrated by trimesh over the same triangles.
    """
    spec = ToolSpec() if spec is None else spec
    if not isinstance(spec, ToolSpec):
        raise TypeError(f"spec must be a ToolSpec, got {type(spec).__name__}")
    values = validate_coefficients(coeffs, spec.degree)
    u = _curve_parameters(values, spec.arc_length, spec.n_segments)
    u_end = float(u[-1])

    x0 = 0.5 * spec.handle_length
    centerline = np.empty((spec.n_segments + 2, 2))
    centerline[0] = (-x0, 0.0)
    centerline[1:, 0] = x0 + u
    centerline[1:, 1] = np.polyval(_poly(values), u)
    centerline[1, 1] = 0.0  # p(0) = 0 exactly

    sweep = _sweep(centerline, spec.section)
    volume, center_of_mass, inertia = _mass_properties(sweep, spec.section, spec.density)
    radius = _min_radius_of_curvature(values, u_end)
    reason = _buildability(sweep, radius, spec.section)
    return ToolGeometry(
        coeffs=_frozen(values),
        spec=spec,
        curve_extent=u_end,
        centerline=_frozen(centerline),
        boxes=_boxes(centerline, sweep, spec.section),
        volume=volume,
        mass=spec.density * volume,
        center_of_mass=_frozen(center_of_mass),
        inertia=_frozen(inertia),
        min_radius_of_curvature=radius,
        buildable=not reason,
        why_not_buildable=reason,
        tip=_frozen((centerline[-1, 0], centerline[-1, 1], 0.0)),
        bounds=_frozen((sweep.vertices.min(axis=0), sweep.vertices.max(axis=0))),
    )


def _check_geometry(geometry: object) -> ToolGeometry:
    if not isinstance(geometry, ToolGeometry):
        raise TypeError(
            f"geometry must be a ToolGeometry from make_tool, got {type(geometry).__name__}"
        )
    return geometry


def tool_mesh(geometry: ToolGeometry) -> trimesh.Trimesh:
    """The whole tool (handle and curve) as one watertight triangle mesh.

    The square section is swept along ``geometry.centerline`` (the same polyline as the boxes) with
    mitred joints and closed by end caps; triangles wind counter-clockwise seen from outside.
    At centreline point k the section's corners are vertices 4k to 4k + 3: (right, bottom),
    (left, bottom), (left, top), (right, top), "left" being +y for a segment along +x. At an
    interior point they sit on the mitre: section / 2 from both neighbouring segments' lines.

    Args:
        geometry: From :func:`make_tool`.

    Returns:
        A new mesh in m in the tool frame, 4 (n_segments + 2) vertices, 8 (n_segments + 1) + 4
        faces, density set to ``spec.density`` (so ``mesh.mass_properties`` equals the geometry's).
    """
    geometry = _check_geometry(geometry)
    sweep = _sweep(np.asarray(geometry.centerline), geometry.spec.section)
    # process=False keeps the vertex order and so the exported bytes independent of trimesh's
    # merging heuristics; the sweep has no duplicate vertices to merge anyway.
    mesh = trimesh.Trimesh(vertices=sweep.vertices, faces=sweep.faces, process=False)
    mesh.density = geometry.spec.density
    return mesh


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and os.replace."""
    # O_EXCL with a random name rather than mkstemp, whose 0600 would make the mesh unreadable
    # to anyone but its owner; this way the file gets the usual umask permissions.
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    handle = os.open(
        temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666
    )
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def _unit_note(scale: float) -> str:
    return {1.0: "m", 1000.0: "mm"}.get(scale, f"m x {scale!r}")


def _stl_bytes(vertices: FloatArray, faces: NDArray[np.int64], scale: float) -> bytes:
    triangles = (vertices * scale)[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    record = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attributes", "<u2")])
    packed = np.zeros(len(faces), dtype=record)
    packed["normal"] = normals
    packed["vertices"] = triangles
    # The 80-byte header must not start with "solid" (readers would take the file for ASCII STL).
    header = f"tooldesign tool, units: {_unit_note(scale)}".encode("ascii")[:80].ljust(80, b" ")
    return header + np.uint32(len(faces)).astype("<u4").tobytes() + packed.tobytes()


def _obj_bytes(vertices: FloatArray, faces: NDArray[np.int64], scale: float) -> bytes:
    lines = [f"# tooldesign tool, units: {_unit_note(scale)}", "o tool"]
    # repr gives the shortest string that reads back to the same float: exact and reproducible.
    lines.extend(f"v {x!r} {y!r} {z!r}" for x, y, z in (vertices * scale + 0.0).tolist())
    lines.extend(f"f {a} {b} {c}" for a, b, c in (faces + 1).tolist())
    return ("\n".join(lines) + "\n").encode("ascii")


def export_mesh(
    geometry: ToolGeometry, path: str | os.PathLike[str], *, scale: float = 1.0
) -> Path:
    """Write the tool's mesh (:func:`tool_mesh`) to an STL (binary) or OBJ file, atomically.

    Files are in metres by default, like everything in this library. Slicers for 3D printers read
    STL numbers as millimetres: pass ``scale=1000.0`` for a print at real size. The unit is also
    written into the file's header or first comment. The same geometry and scale always give the
    same bytes.

    Args:
        geometry: From :func:`make_tool`.
        path: Target file; its suffix (``.stl`` or ``.obj``, any case) picks the format. The
            folder must exist; an existing file is replaced.
        scale: Factor applied to the coordinates (finite, > 0): 1.0 for m, 1000.0 for mm.

    Returns:
        The path written.

    Raises:
        ValueError: Unknown suffix or bad scale.
    """
    geometry = _check_geometry(geometry)
    target = Path(os.fspath(path))
    suffix = target.suffix.lower()
    if suffix not in (".stl", ".obj"):
        raise ValueError(f"path must end in .stl or .obj, got {str(target)!r}")
    factor = _check_positive("scale", scale, "1.0 for m, 1000.0 for mm")
    sweep = _sweep(np.asarray(geometry.centerline), geometry.spec.section)
    writer = _stl_bytes if suffix == ".stl" else _obj_bytes
    _write_atomic(target, writer(sweep.vertices, sweep.faces, factor))
    return target


def _number(value: float) -> str:
    # repr: shortest exact round trip, the same in every process; + 0.0 turns -0.0 into 0.0.
    return repr(float(value) + 0.0)


def _numbers(values: Sequence[float] | FloatArray) -> str:
    return " ".join(_number(v) for v in np.asarray(values, dtype=np.float64).tolist())


def _check_name(owner: str, name: object) -> str:
    if not isinstance(name, str):
        raise TypeError(f"{owner} must be a string, got {type(name).__name__}")
    if not name or name != name.strip():
        raise ValueError(
            f"{owner} must be a non-empty name without surrounding spaces, got {name!r}"
        )
    return name


def _check_rgba(rgba: Any) -> list[float]:
    try:
        values = [float(v) for v in rgba]
    except TypeError:
        raise TypeError(f"material_rgba must be 4 numbers in [0, 1], got {rgba!r}") from None
    if len(values) != 4 or not all(0.0 <= v <= 1.0 for v in values):
        raise ValueError(f"material_rgba must be 4 numbers in [0, 1], got {rgba!r}")
    return values


def tool_link_xml(
    geometry: ToolGeometry,
    link_name: str = "tool",
    material_rgba: Sequence[float] = (0.8, 0.55, 0.25, 1.0),
) -> str:
    """The tool as one URDF ``<link>`` element, to attach to a robot with a fixed joint.

    The link frame is the tool frame. ``<inertial>`` holds the mesh's mass, centre of mass and
    inertia about it (tool-frame axes, so ``rpy`` is 0); one ``<collision>`` and one ``<visual>``
    box per entry of ``geometry.boxes``. Numbers are written with ``repr`` (exact, reproducible).

    Args:
        geometry: From :func:`make_tool`.
        link_name: The link's name (also prefixes the material's name).
        material_rgba: Visual colour, 4 numbers in [0, 1].

    Returns:
        The ``<link>`` element as an XML string (no XML declaration), ending in a newline.
    """
    geometry = _check_geometry(geometry)
    name = _check_name("link_name", link_name)
    rgba = _check_rgba(material_rgba)
    inertia = np.asarray(geometry.inertia)
    lines = [
        f"<link name={quoteattr(name)}>",
        "  <inertial>",
        f'    <origin xyz="{_numbers(geometry.center_of_mass)}" rpy="0 0 0"/>',
        f'    <mass value="{_number(geometry.mass)}"/>',
        "    <inertia"
        f' ixx="{_number(inertia[0, 0])}" ixy="{_number(inertia[0, 1])}"'
        f' ixz="{_number(inertia[0, 2])}" iyy="{_number(inertia[1, 1])}"'
        f' iyz="{_number(inertia[1, 2])}" izz="{_number(inertia[2, 2])}"/>',
        "  </inertial>",
    ]
    material = quoteattr(f"{name}_material")
    for index, box in enumerate(geometry.boxes):
        origin = f'<origin xyz="{_numbers(box.center)}" rpy="0 0 {_number(box.yaw)}"/>'
        shape = f'<geometry><box size="{_numbers(2.0 * box.half_extents)}"/></geometry>'
        lines += [
            f"  <visual name={quoteattr(f'{name}_box_{index}')}>",
            f"    {origin}",
            f"    {shape}",
            f'    <material name={material}><color rgba="{_numbers(rgba)}"/></material>',
            "  </visual>",
            f"  <collision name={quoteattr(f'{name}_box_{index}')}>",
            f"    {origin}",
            f"    {shape}",
            "  </collision>",
        ]
    lines.append("</link>")
    return "\n".join(lines) + "\n"


def tool_urdf(
    geometry: ToolGeometry,
    name: str = "tool",
    material_rgba: Sequence[float] = (0.8, 0.55, 0.25, 1.0),
) -> str:
    """A standalone URDF of the tool: one link named ``name`` (see :func:`tool_link_xml`).

    Args:
        geometry: From :func:`make_tool`.
        name: Robot and link name.
        material_rgba: Visual colour, 4 numbers in [0, 1].

    Returns:
        The URDF document as a string; the same geometry gives the same string in every process.
    """
    name = _check_name("name", name)
    link = tool_link_xml(geometry, name, material_rgba)
    body = "".join(f"  {line}\n" for line in link.splitlines())
    return (
        '<?xml version="1.0"?>\n'
        f"<!-- tooldesign tool, units: m, kg; coeffs {escape(_numbers(geometry.coeffs))} -->\n"
        f"<robot name={quoteattr(name)}>\n{body}</robot>\n"
    )
