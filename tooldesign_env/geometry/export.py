"""Shape export: the tool as a ``trimesh.Trimesh``, STL/OBJ files and URDF text.

Everything is read from a :class:`ToolGeometry`, so the mesh, the files and the URDF's collision
shapes and inertia describe the one solid ``make_tool`` computed. Files are written atomically
(a temporary file in the same folder, then ``os.replace``), and numbers with ``repr``, so the
same geometry gives the same bytes in every process.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape, quoteattr

import numpy as np
import trimesh
from numpy.typing import NDArray

from tooldesign_env.files import write_atomic
from tooldesign_env.geometry.sweep import _round_mesh, _sweep
from tooldesign_env.geometry.tool import ToolGeometry
from tooldesign_env.geometry.validation import FloatArray, _check_positive

__all__ = ["export_mesh", "tool_link_xml", "tool_mesh", "tool_urdf"]


def _check_geometry(geometry: object) -> ToolGeometry:
    if not isinstance(geometry, ToolGeometry):
        raise TypeError(
            f"geometry must be a ToolGeometry from make_tool, got {type(geometry).__name__}"
        )
    return geometry


def _mesh_arrays(geometry: ToolGeometry) -> tuple[FloatArray, NDArray[np.int64]]:
    """Vertices and faces of the tool's mesh, for its section shape."""
    centerline = np.asarray(geometry.centerline)
    sweep = _sweep(centerline, geometry.spec.section)
    if geometry.spec.section_shape == "round":
        return _round_mesh(centerline, sweep, geometry.spec.section)
    return sweep.vertices, sweep.faces


def tool_mesh(geometry: ToolGeometry) -> trimesh.Trimesh:
    """The whole tool (handle and curve) as one watertight triangle mesh.

    A square section is swept along ``geometry.centerline`` (the same polyline as the boxes) with
    mitred joints and closed by end caps; triangles wind counter-clockwise seen from outside.
    At centreline point k the section's corners are vertices 4k to 4k + 3: (right, bottom),
    (left, bottom), (left, top), (right, top), "left" being +y for a segment along +x. At an
    interior point they sit on the mitre: section / 2 from both neighbouring segments' lines.
    A round section is a ``ROUND_SIDES``-gon of the circle's area swept the same way, closed by
    polygonal hemispheres (the capsules' rounded ends).

    Args:
        geometry: From :func:`make_tool`.

    Returns:
        A new mesh in m in the tool frame (square: 4 (n_segments + 2) vertices, 8 (n_segments +
        1) + 4 faces), density set to ``spec.density`` (so ``mesh.mass_properties`` equals the
        geometry's).
    """
    geometry = _check_geometry(geometry)
    vertices, faces = _mesh_arrays(geometry)
    # process=False keeps the vertex order and so the exported bytes independent of trimesh's
    # merging heuristics; the sweep has no duplicate vertices to merge anyway.
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    mesh.density = geometry.spec.density
    return mesh


# --------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------


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
    return header + len(faces).to_bytes(4, "little") + packed.tobytes()


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
    vertices, faces = _mesh_arrays(geometry)
    writer = _stl_bytes if suffix == ".stl" else _obj_bytes
    write_atomic(target, writer(vertices, faces, factor))
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
    box per entry of ``geometry.boxes``, or capsule per entry of ``geometry.capsules`` (a URDF
    capsule's axis is its frame's z, turned onto the segment by ``rpy = (0, pi/2, yaw)``).
    Numbers are written with ``repr`` (exact, reproducible).

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
    shapes = [
        (
            f"{name}_box_{index}",
            f'<origin xyz="{_numbers(box.center)}" rpy="0 0 {_number(box.yaw)}"/>',
            f'<geometry><box size="{_numbers(2.0 * box.half_extents)}"/></geometry>',
        )
        for index, box in enumerate(geometry.boxes)
    ]
    shapes += [
        (
            f"{name}_capsule_{index}",
            f'<origin xyz="{_numbers(capsule.center)}" '
            f'rpy="0 {_number(np.pi / 2)} {_number(capsule.yaw)}"/>',
            f'<geometry><capsule radius="{_number(capsule.radius)}" '
            f'length="{_number(2.0 * capsule.half_length)}"/></geometry>',
        )
        for index, capsule in enumerate(geometry.capsules)
    ]
    for shape_name, origin, shape in shapes:
        lines += [
            f"  <visual name={quoteattr(shape_name)}>",
            f"    {origin}",
            f"    {shape}",
            f'    <material name={material}><color rgba="{_numbers(rgba)}"/></material>',
            "  </visual>",
            f"  <collision name={quoteattr(shape_name)}>",
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
