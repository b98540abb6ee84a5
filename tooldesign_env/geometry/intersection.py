"""Buildability: whether the swept tube is a simple solid, and if not, the first reason why.

The rules, in the order they are checked: the curve's minimum radius of curvature must exceed
section / 2 (else the inner wall folds over itself); no joint may need a mitre beyond
``MITRE_LIMIT``; no piece of the sweep may be turned inside out; and no two non-adjacent pieces may
overlap (separating-axis test on their in-plane quadrilaterals). A round tool also needs its end
caps clear of the rest of it (``_caps_clear``). See ``docs/geometry.md``.
"""

from __future__ import annotations

import math

import numpy as np

from tooldesign_env.geometry.sweep import MITRE_LIMIT, _Sweep
from tooldesign_env.geometry.validation import FloatArray

# Non-adjacent pieces of the sweep may touch but must not overlap by more than this (m).
_OVERLAP_TOL = 1e-9


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


def _segment_distances(point: FloatArray, polyline: FloatArray) -> FloatArray:
    """(k,) distances in the plane from ``point`` to each segment of ``polyline``."""
    start, delta = polyline[:-1], np.diff(polyline, axis=0)
    length2 = np.einsum("kd,kd->k", delta, delta)
    t = np.clip(
        np.einsum("kd,kd->k", point - start, delta) / np.where(length2 > 0, length2, 1), 0, 1
    )
    gap = start + t[:, None] * delta - point
    distances: FloatArray = np.hypot(gap[:, 0], gap[:, 1])
    return distances


def _caps_clear(polyline: FloatArray, section: float) -> str:
    """Empty string if a round tool's end caps stay clear of the rest of it, else why not.

    A round section lies inside the square one, whose rules ``_buildability`` checks, except for
    the hemispheres that close its two ends: each reaches section / 2 past its end point. It
    touches the tube of a segment that is not its own or its neighbour iff its centre (the end
    point) is closer than a section (two radii) to that segment.
    """
    count = polyline.shape[0] - 1  # segments
    for name, point, far in (
        ("tip", polyline[-1], slice(0, max(count - 2, 0))),
        ("handle's end", polyline[0], slice(2, count)),
    ):
        distances = _segment_distances(point, polyline)[far]
        if distances.size and distances.min() < section:
            segment = int(np.argmin(distances)) + (far.start or 0)
            return (
                f"the round tool's {name} cap reaches segment {segment} "
                f"({distances.min():.4g} m from its axis, under a section of {section:.4g} m)"
            )
    return ""
