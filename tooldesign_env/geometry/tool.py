"""The tool: its fixed constants, the geometry a design makes, and the function that makes it.

``ToolSpec`` holds the non-designed constants (arc length, handle, section, density, segments,
degree); ``make_tool`` runs the arc-length solve, the sweep, the mass properties and the
buildability check in turn and returns a ``ToolGeometry``. Only the exporters sit above this
module in the package.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from tooldesign_env.geometry.arclength import (
    _curve_parameters,
    _min_radius_of_curvature,
    _poly,
)
from tooldesign_env.geometry.intersection import _buildability
from tooldesign_env.geometry.sweep import Box, _boxes, _frozen, _mass_properties, _sweep
from tooldesign_env.geometry.validation import (
    FloatArray,
    _check_int,
    _check_positive,
    validate_coefficients,
)

__all__ = ["ToolGeometry", "ToolSpec", "make_tool"]


# --------------------------------------------------------------------------------------------
# Specification and input validation
# --------------------------------------------------------------------------------------------


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
