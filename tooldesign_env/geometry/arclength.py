"""The polynomial curve cut at a fixed arc length: quadrature, its inversion, and curvature.

``p(u) = c1 u^n + ... + cn u`` (highest power first, no constant term). Its arc length
``s(u) = int_0^u sqrt(1 + p'^2)`` is integrated by adaptive Gauss-Legendre panels and inverted by
bracketed Newton steps, so that ``s(u_end) = L0`` (the curve end) and the curve's points are evenly
spaced along the arc. The minimum radius of curvature over ``[0, u_end]`` is here too: it is a
property of the same curve, and the sweep's buildability rule reads it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from tooldesign_env.geometry.validation import (
    FloatArray,
    _as_coefficients,
    _check_int,
    _check_positive,
    _check_real,
)

__all__ = ["curve_arc_length", "curve_points", "solve_curve_extent"]

# Relative accuracy asked of the arc-length quadrature, per panel. Panels are positive, so the
# integral over any [0, u] inherits it. 1e-13 sits well above the round-off of a 16-point sum.
_ARC_RTOL = 1e-13
# Arc-length inversion stops when |s(u) - target| <= this times the largest target.
_INVERT_ATOL = 1e-13
# The promise on the curve end, checked after every solve by a second quadrature rule.
_EXTENT_RTOL = 1e-6

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
_GL24_NODES, _GL24_WEIGHTS = np.polynomial.legendre.leggauss(24)
_EPS = float(np.finfo(np.float64).eps)


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
    second = np.asarray(np.polyder(dcoeffs), np.float64) if dcoeffs.size > 1 else np.zeros(1)
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
    d2 = np.asarray(np.polyder(d1), np.float64) if d1.size > 1 else np.zeros(1)
    d3 = np.asarray(np.polyder(d2), np.float64) if d2.size > 1 else np.zeros(1)
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
