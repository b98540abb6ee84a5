"""The tool: its fixed constants, the geometry a design makes, and the function that makes it.

``ToolSpec`` holds the non-designed constants (arc length, handle, section and its shape,
density, segments, degree); ``make_tool`` runs the arc-length solve, the sweep, the mass
properties and the buildability check in turn and returns a ``ToolGeometry``. Only the
exporters sit above this module in the package.
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
from tooldesign_env.geometry.intersection import _buildability, _caps_clear
from tooldesign_env.geometry.sweep import (
    Box,
    Capsule,
    _boxes,
    _capsules,
    _frozen,
    _mass_properties,
    _mesh_mass_properties,
    _round_mesh,
    _sweep,
)
from tooldesign_env.geometry.validation import (
    FloatArray,
    _check_int,
    _check_positive,
    validate_coefficients,
)

__all__ = ["SECTION_SHAPES", "ToolGeometry", "ToolSpec", "make_tool"]

#: The sections a tool can have (``ToolSpec.section_shape``).
SECTION_SHAPES = ("square", "round")

#: (lowest, highest, unit) of each real field of ``ToolSpec``: a tool the arm can hold in the
#: workspace, of a real material (the defaults: 1.1 m, 0.15 m, 3 cm, 250 kg/m^3).
TOOL_LIMITS: dict[str, tuple[float, float, str]] = {
    "arc_length": (0.01, 5.0, "m"),
    "handle_length": (0.01, 2.0, "m"),
    "section": (0.001, 0.5, "m"),
    "density": (1.0, 30000.0, "kg/m^3"),
}

#: Most chords of the curve (one collision shape each; 120 is the finest studied) and the
#: highest polynomial degree (the design's dimension).
N_SEGMENTS_MAX = 500
DEGREE_MAX = 20


# --------------------------------------------------------------------------------------------
# Specification and input validation
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, kw_only=True)
class ToolSpec:
    """The fixed, non-designed constants of a tool (defaults: the paper's scene).

    Attributes:
        arc_length: L0, arc length of the curved part in m (the paper's fixed curve length).
        handle_length: Length of the straight handle in m; the grasp point is its centre.
        section: Side of the square cross-section, or diameter of the round one, in m.
        density: Material density in kg/m^3 (250 is light wood or a porous print).
        n_segments: Number of chords of equal arc length that approximate the curve (>= 1); one
            collision box (or capsule) per chord plus one for the handle.
        degree: Polynomial degree n, i.e. the number of coefficients (c1, ..., cn) (>= 1).
        section_shape: ``"round"`` (the default): the points within section / 2 of the
            centreline (a bent round rod with rounded ends), one collision capsule per segment.
            ``"square"`` (the paper's): a square section swept with mitred joints, one
            collision box per segment; its contact with the box is chaotic, a 0.1 mm nudge of
            the box moves F by about 1.5 % (docs/model.md, "The tool's section: where the chaos
            came from"), so the round section is the default.

    Limits (:data:`TOOL_LIMITS`; a ValueError names the field otherwise): ``arc_length`` 1 cm
    to 5 m, ``handle_length`` 1 cm to 2 m, ``section`` 1 mm to 0.5 m, ``density`` 1 to
    30,000 kg/m^3 (aerogel to beyond osmium's 22,590), ``n_segments`` 1 to 500 (each a
    collision shape), ``degree`` 1 to 20. Outside them the simulation fails (a 10^-300 m
    section or a 10^308 kg/m^3 density gave non-finite torques) or runs without bound.
    """

    arc_length: float = 1.1
    handle_length: float = 0.15
    section: float = 0.03
    density: float = 250.0
    n_segments: int = 30
    degree: int = 3
    section_shape: str = "round"

    def __post_init__(self) -> None:
        for name, (low, high, unit) in TOOL_LIMITS.items():
            label = f"ToolSpec.{name}"
            value = _check_positive(label, getattr(self, name), unit)
            if not low <= value <= high:
                raise ValueError(
                    f"{label} must be a number from {low:g} to {high:g} {unit}, got {value!r}"
                )
            object.__setattr__(self, name, value)
        for name, high in (("n_segments", N_SEGMENTS_MAX), ("degree", DEGREE_MAX)):
            label = f"ToolSpec.{name}"
            count = _check_int(label, getattr(self, name), 1)
            if count > high:
                raise ValueError(f"{label} must be an integer from 1 to {high}, got {count!r}")
            object.__setattr__(self, name, count)
        if not isinstance(self.section_shape, str) or self.section_shape not in SECTION_SHAPES:
            raise ValueError(
                f"ToolSpec.section_shape must be one of {SECTION_SHAPES}, "
                f"got {self.section_shape!r}"
            )


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
        boxes: One :class:`Box` for the handle, then one per curve segment (n_segments + 1);
            empty for a round section.
        capsules: One :class:`Capsule` per segment like ``boxes``, for a round section; empty
            for a square one.
        volume: Volume of the mesh in m^3 (square: section^2 times the centreline's length;
            round: about pi section^2 / 4 times it, plus the end caps' sphere).
        mass: Mass in kg (density times volume).
        center_of_mass: (3,) centre of mass in m.
        inertia: (3, 3) inertia tensor in kg m^2 about the centre of mass, tool-frame axes.
        min_radius_of_curvature: Minimum radius of curvature of the curve p in m (analytic,
            over [0, u_end]; inf for a straight curve).
        buildable: Whether the swept tube is a simple solid (see ``why_not_buildable``).
        why_not_buildable: Empty if buildable, else the first violated rule in words.
        tip: (3,) the curve's end point in m.
        bounds: (2, 3) axis-aligned bounding box in m, (min, max): of the mesh (square), of the
            capsules (round: the centreline's, widened by section / 2).
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
    capsules: tuple[Capsule, ...] = ()


def make_tool(coeffs: ArrayLike, spec: ToolSpec | None = None) -> ToolGeometry:
    """Build the tool of a design.

    Args:
        coeffs: ``(c1, ..., cn)`` with n = ``spec.degree``, highest power first.
        spec: Fixed constants; ``ToolSpec()`` (the paper's tool) if None.

    Returns:
        The tool's geometry, collision shapes and mass properties. Mass properties are those of
        the mesh (:func:`tool_mesh`), integrated over its triangles. Buildability follows the
        square sweep's rules for both sections (a round section lies inside the square one but
        for its end caps), plus, for a round one, that neither end cap reaches another part of
        the tool.
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
    radius = _min_radius_of_curvature(values, u_end)
    reason = _buildability(sweep, radius, spec.section)
    if not reason and spec.section_shape == "round":
        reason = _caps_clear(centerline, spec.section)
    boxes: tuple[Box, ...] = ()
    capsules: tuple[Capsule, ...] = ()
    if spec.section_shape == "round":
        vertices, faces = _round_mesh(centerline, sweep, spec.section)
        volume, center_of_mass, inertia = _mesh_mass_properties(vertices, faces, spec.density)
        capsules = _capsules(centerline, sweep, spec.section)
        half = 0.5 * spec.section  # the capsules' bounds: the centreline's, widened by a radius
        low = np.append(centerline.min(axis=0) - half, -half)
        high = np.append(centerline.max(axis=0) + half, half)
    else:
        volume, center_of_mass, inertia = _mass_properties(sweep, spec.section, spec.density)
        boxes = _boxes(centerline, sweep, spec.section)
        low, high = sweep.vertices.min(axis=0), sweep.vertices.max(axis=0)
    return ToolGeometry(
        coeffs=_frozen(values),
        spec=spec,
        curve_extent=u_end,
        centerline=_frozen(centerline),
        boxes=boxes,
        volume=volume,
        mass=spec.density * volume,
        center_of_mass=_frozen(center_of_mass),
        inertia=_frozen(inertia),
        min_radius_of_curvature=radius,
        buildable=not reason,
        why_not_buildable=reason,
        tip=_frozen((centerline[-1, 0], centerline[-1, 1], 0.0)),
        bounds=_frozen((low, high)),
        capsules=capsules,
    )
