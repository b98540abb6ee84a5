"""Tool geometry: pure functions from polynomial coefficients to shapes, mass and files.

Nothing here touches PyBullet. The design is a coefficient vector ``C = (c1, ..., cn)`` meaning
``p(u) = c1 u^n + ... + cn u`` (highest power first, constant term fixed at 0, as in the paper's
section "Tool parametrization and generation"). The tool is a straight handle followed by the graph
of ``p`` cut at a fixed arc length ``L0``, both swept with a round section (the default) or the
paper's square one (``ToolSpec.section_shape``).

Tool frame (all outputs): origin at the grasp point (the centre of the straight handle), x along the
handle toward the curve, y lateral, z up; SI units (m, kg, kg m^2). The handle runs from
``x = -handle_length / 2`` to ``x0 = +handle_length / 2`` at ``y = 0``; the curve is the point set
``(x0 + u, p(u))`` for ``u`` in ``[0, u_end]``, where the arc length of ``p`` over ``[0, u_end]`` is
``L0``.

One polyline drives everything: the handle plus ``n_segments`` chords of equal arc length on the
curve. The mesh is the mitred sweep of that polyline; the collision boxes are its segments, each
lengthened at a bend so that their union is exactly the mesh's solid; the mass properties are those
of the mesh. Collision, inertia and the printed part therefore describe one and the same solid. A
round section's collision shapes are one capsule per segment; its mesh is the capsules' union up to
the outer corners of the bends and the polygonal circle.

The package is split by concern into modules, listed lowest floor first; each one imports only from
the ones listed before it, so there are no import cycles:

- ``validation``: input checks shared by all (``validate_coefficients``, scalar checks) and the
  ``FloatArray`` type.
- ``arclength``: the polynomial cut at arc length ``L0``: quadrature, its inversion, the curve's
  points, and its minimum radius of curvature (``curve_arc_length``, ``solve_curve_extent``,
  ``curve_points``).
- ``sweep``: the mitred sweep of the polyline, its collision boxes or capsules and mass
  properties (``Box``, ``Capsule``, ``MITRE_LIMIT``).
- ``intersection``: buildability, i.e. whether the swept tube is a simple solid.
- ``tool``: ``ToolSpec``, ``ToolGeometry`` and ``make_tool``, which ties the floors below together.
- ``export``: the mesh, STL/OBJ files and URDF of a tool (``tool_mesh``, ``export_mesh``,
  ``tool_link_xml``, ``tool_urdf``).

Import the public names from ``tooldesign_env.geometry`` itself; the modules are its layout, not
its interface.

See ``docs/geometry.md`` for the derivations (arc-length solve, overlap rule, buildability rule).
"""

from __future__ import annotations

from tooldesign_env.geometry.arclength import curve_arc_length, curve_points, solve_curve_extent
from tooldesign_env.geometry.export import export_mesh, tool_link_xml, tool_mesh, tool_urdf
from tooldesign_env.geometry.sweep import MITRE_LIMIT, Box, Capsule
from tooldesign_env.geometry.tool import SECTION_SHAPES, ToolGeometry, ToolSpec, make_tool
from tooldesign_env.geometry.validation import validate_coefficients

__all__ = [
    "MITRE_LIMIT",
    "SECTION_SHAPES",
    "Box",
    "Capsule",
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
