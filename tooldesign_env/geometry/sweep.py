"""The mitred sweep, boxes and mass properties: one polyline, one solid.

A square section is swept along the tool's polyline (handle plus curve chords) with mitred joints;
the collision boxes are the polyline's segments, lengthened at each bend so that their union is
the swept solid; the volume, centre of mass and inertia are those of the sweep's mesh. A round
section gives the set of points within section / 2 of the polyline instead: one capsule per
segment, whose union is that solid exactly, and a mesh (a mitred polygonal tube with hemispherical
end caps) for its mass properties and files. Pure functions of a polyline in m (tool frame);
nothing here knows the polynomial.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tooldesign_env.geometry.validation import FloatArray

__all__ = ["CAP_RINGS", "MITRE_LIMIT", "ROUND_SIDES", "Box", "Capsule"]

#: Largest mitre scale ``1 / cos(turn / 2)`` used at a joint (SVG's ``stroke-miterlimit`` default).
#: It caps turns at about 151 degrees so that no offset runs to infinity; a joint that needs more is
#: reported as not buildable, and its mesh and boxes are clamped (finite, watertight, but inexact).
MITRE_LIMIT = 4.0

#: Sides of the polygon that stands for a round section in the mesh of a round tool. Its
#: circumradius is chosen so that its area is the circle's; the collision shapes are exact capsules.
ROUND_SIDES = 32

#: Latitude steps from the tube's end to the pole of each hemispherical end cap of a round tool's
#: mesh.
CAP_RINGS = 8


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


@dataclass(frozen=True, kw_only=True, eq=False)
class Capsule:
    """One collision capsule of a round tool, in the tool frame.

    The points within ``radius`` of the segment of length ``2 half_length`` through ``center``
    along the capsule's own x axis.

    Attributes:
        center: (3,) centre in m.
        half_length: Half the length of its axis segment (a polyline segment) in m.
        radius: Radius in m (section / 2).
        yaw: Rotation about the tool's z axis in rad (the capsule's x is the segment direction).
    """

    center: FloatArray
    half_length: float
    radius: float
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
    vertices: FloatArray = np.empty((count, 4, 3))
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


# --------------------------------------------------------------------------------------------
# The round section: capsules and the mesh that stands for them
# --------------------------------------------------------------------------------------------


def _capsules(polyline: FloatArray, sweep: _Sweep, section: float) -> tuple[Capsule, ...]:
    """One capsule per polyline segment; their union is the points within section / 2 of it."""
    centers = 0.5 * (polyline[:-1] + polyline[1:])
    yaws = np.arctan2(sweep.directions[:, 1], sweep.directions[:, 0])
    return tuple(
        Capsule(
            center=_frozen((cx, cy, 0.0)),
            half_length=0.5 * chord,
            radius=0.5 * section,
            yaw=float(yaw),
        )
        for (cx, cy), chord, yaw in zip(
            centers.tolist(), sweep.chords.tolist(), yaws.tolist(), strict=True
        )
    )


def _round_mesh(
    polyline: FloatArray, sweep: _Sweep, section: float
) -> tuple[FloatArray, NDArray[np.int64]]:
    """Vertices and faces of a round tool: the capsules' union as a closed triangle mesh.

    A ``ROUND_SIDES``-gon (area pi (section / 2)^2) is swept along the polyline with the square
    sweep's mitres, and each end is closed by a polygonal hemisphere of ``CAP_RINGS`` latitude
    steps. It differs from the capsules' union only at the outer side of each bend, where the
    mitre's corner stands in for the capsules' spherical joint (a few mm^3 per joint), and by the
    polygons' approximation of the circle. Triangles wind counter-clockwise seen from outside.
    """
    sides, rings = ROUND_SIDES, CAP_RINGS
    step = 2.0 * np.pi / sides
    rho = 0.5 * section * np.sqrt(step / np.sin(step))  # the polygon's area is the circle's
    theta = step * (np.arange(sides) + 0.5)
    width, height = rho * np.cos(theta), rho * np.sin(theta)  # (left, up), counter-clockwise

    count = polyline.shape[0]
    offsets = (sweep.scales[:, None, None] * width[None, :, None]) * sweep.normals[:, None, :]
    tube = np.empty((count, sides, 3))
    tube[..., :2] = polyline[:, None, :] + offsets
    tube[..., 2] = height[None, :]

    def cap(
        end: FloatArray, outward: FloatArray, lateral: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """(rings - 1, sides, 3) latitude rings past an end, from the end on, and the pole (3,)."""
        phi = 0.5 * np.pi * np.arange(1, rings) / rings
        ring = np.empty((rings - 1, sides, 3))
        ring[..., :2] = (
            end[None, None, :]
            + (rho * np.sin(phi))[:, None, None] * outward[None, None, :]
            + (np.cos(phi)[:, None] * width[None, :])[..., None] * lateral[None, None, :]
        )
        ring[..., 2] = np.cos(phi)[:, None] * height[None, :]
        return ring, np.array([end[0] + rho * outward[0], end[1] + rho * outward[1], 0.0])

    # Rings in the order of travel: the start cap's pole and rings, the tube's, the end cap's
    # rings and pole. Corner k of every ring lies at the same angle about the centreline.
    start_rings, start_pole = cap(polyline[0], -sweep.directions[0], sweep.normals[0])
    end_rings, end_pole = cap(polyline[-1], sweep.directions[-1], sweep.normals[-1])
    stacked = np.concatenate((start_rings[::-1], tube, end_rings))
    vertices = np.concatenate((start_pole[None], stacked.reshape(-1, 3), end_pole[None]))

    n_rings = stacked.shape[0]
    k = np.arange(sides)
    base = 1 + sides * np.arange(n_rings - 1)[:, None]
    a, b = base + k, base + (k + 1) % sides
    c, d = b + sides, a + sides
    sides_faces = np.stack((np.stack((a, b, c), -1), np.stack((a, c, d), -1)), axis=2)
    first, last_ring = 1, 1 + sides * (n_rings - 1)
    pole_end = vertices.shape[0] - 1
    start_fan = np.stack((np.zeros(sides, int), first + (k + 1) % sides, first + k), -1)
    end_fan = np.stack((last_ring + k, last_ring + (k + 1) % sides, np.full(sides, pole_end)), -1)
    faces = np.concatenate((start_fan, sides_faces.reshape(-1, 3), end_fan)).astype(np.int64)
    return vertices, faces


def _mesh_mass_properties(
    vertices: FloatArray, faces: NDArray[np.int64], density: float
) -> tuple[float, FloatArray, FloatArray]:
    """Volume (m^3), centre of mass (3,) m and inertia (3, 3) kg m^2 about it, of a closed mesh."""
    from trimesh.triangles import mass_properties  # only round tools need it

    props = mass_properties(vertices[faces], density=density)
    return float(props.volume), np.asarray(props.center_mass, float), np.asarray(props.inertia)
