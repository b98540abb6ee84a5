"""Lean copies of the Panda's collision meshes: the same convex shapes, loaded twice as fast.

An asset cache: :func:`lean_collision_meshes` writes, once per folder (the plan cache's), copies of
the arm's OBJ collision meshes that hold only the points PyBullet keeps, and an index of which copy
was made from which original. :func:`tooldesign_env.robot_model.panda_urdf_with_tool` loads them
in place of the originals. Nothing here imports PyBullet.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
from pathlib import Path

import numpy as np

from tooldesign_env.files import write_atomic
from tooldesign_env.plan import source_digest
from tooldesign_env.robot_model import panda_urdf_with_tool

__all__ = ["LEAN_MESH_FORMAT", "lean_collision_mesh", "lean_collision_meshes"]


#: Bumped whenever :func:`lean_collision_mesh` writes something else.
LEAN_MESH_FORMAT = 3

#: A point farther inside its shape's convex hull than this fraction of the shape's largest
#: extent is dropped by :func:`lean_collision_mesh`. Bullet's hull builder
#: (``btConvexHullInternal::compute``) first truncates every point to a grid of 1/10216 of
#: each axis's extent (about 1e-4), so a point inside the hull by less than a cell or two may
#: land on it and become a vertex; ten cells keeps every such point.
_INTERIOR_TOLERANCE = 1e-3

# What Bullet's OBJ reader (tiny_obj_loader) reads as PyBullet builds it: a keyword then
# fields separated by spaces or tabs, numbers read by atof. The lean copy is made only from
# files in which every line read is plain: anything else raises ValueError, and
# lean_collision_meshes then loads the original.
_PLAIN_LINE = re.compile(r"[ -~\t]*")  # printable ASCII and tabs
_LONGEST_LINE = 999  # Bullet reads lines with fgets into 1,024 bytes and cuts them at "\r"
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_CORNER = re.compile(r"(-?\d+)(?:/\d*(?:/\d*)?)?")

_LEAN_MESHES: dict[str, dict[str, str] | None] = {}  # per folder, once per process


def lean_collision_mesh(text: str) -> str:
    """An OBJ text from which PyBullet makes collision shapes of the same vertices, faster.

    PyBullet makes a mesh's collision shape from OBJ text in three steps (Bullet's
    ``tiny_obj_loader`` and ``BulletURDFImporter``): it reads the vertex positions (as floats,
    ``(float)atof``) and the faces, splitting shapes at ``g`` and ``o`` lines; it adds, for
    every corner of every face (polygons cut into triangles by their positions), that corner's
    position to a point list; and it replaces each shape's point list by the vertices of its
    convex hull (``btConvexHullShape::optimizeConvexHull``), which is all it keeps.

    So this keeps, per shape, only the points that can be vertices of that hull, each once:
    the positions of its faces' corners, less those inside their convex hull by more than
    ``_INTERIOR_TOLERANCE`` of the shape's extent (by Qhull), written with their numbers' text
    unchanged (so each parses to the same float) and named by triangles ``f i j k`` that exist
    for nothing else, with the shapes' ``g``/``o`` lines. Normals, texture coordinates,
    materials, lines, comments, repeated corners and interior points, which the collision
    shape never holds, go. The copy is no mesh to draw: use it for collision shapes only. The
    Panda's collision meshes shrink from 430 KB to 52 KB and the arm loads in about 2.2 ms
    instead of 4.6 ms.

    PyBullet then holds the same hull vertices, bit for bit, but not in the same order: the
    order its hull builder lists them in depends on the points it was given. Nothing the
    simulation computes without a contact depends on that order (bounding boxes and inertia
    take the extreme coordinate, whichever vertex has it); in a contact of an arm link the
    order decides only between vertices tied exactly for the farthest along a direction.
    ``tests/test_lean_meshes.py`` compares PyBullet's vertices, bounding boxes and dynamics
    link by link, and whole episodes.

    Raises:
        ValueError: a face refers to a vertex that does not exist, or a line that PyBullet
            reads (``v``, ``f``, ``g``, ``o``) is not plain: characters other than printable
            ASCII and tabs, a vertex without three plain decimal numbers or not finite as a
            float, a face with fewer than three corners or a corner that is not an index; or
            any line is 1,000 characters or longer or holds a carriage return (Bullet would
            split it).
    """
    positions: list[str] = []  # the text "x y z" of every vertex, in file order
    groups: list[tuple[str | None, list[int]]] = [(None, [])]  # (g/o line, corner vertices)
    for number, raw in enumerate(text.split("\n"), start=1):
        if len(raw) > _LONGEST_LINE or "\r" in raw:
            raise ValueError(f"line {number}: longer than {_LONGEST_LINE} characters, or a \\r")
        fields = raw.split()
        if not fields or fields[0] not in ("v", "f", "g", "o"):
            continue  # comments, normals, materials...: the collision import skips them
        if not _PLAIN_LINE.fullmatch(raw):
            raise ValueError(f"line {number}: not a plain line of printable ASCII: {raw[:80]!r}")
        kind = fields[0]
        if kind == "v":
            coordinates = fields[1:4]
            if len(coordinates) < 3 or not all(_NUMBER.fullmatch(c) for c in coordinates):
                raise ValueError(f"line {number}: a vertex needs three decimal numbers: {raw!r}")
            positions.append(" ".join(coordinates))
        elif kind == "f":
            if len(fields) < 4:
                raise ValueError(f"line {number}: a face needs three corners or more: {raw!r}")
            corners = groups[-1][1]
            for corner in fields[1:]:
                match = _CORNER.fullmatch(corner)
                if match is None:
                    raise ValueError(f"line {number}: face corner {corner!r} is not an index")
                i = int(match.group(1))
                i = i - 1 if i > 0 else len(positions) + i  # OBJ counts from 1, or from the end
                if not 0 <= i < len(positions):
                    raise ValueError(
                        f"line {number}: face corner {corner!r} refers to vertex {i + 1}, "
                        f"but {len(positions)} are defined so far"
                    )
                corners.append(i)
        else:
            groups.append((raw.strip(), []))
    out: list[str] = []
    index: dict[str, int] = {}  # position text -> its 1-based index in the copy
    for line, corners in groups:
        if line is not None:
            out.append(line)
        # Each distinct position once, in the order of first use.
        kept = _hull_candidates(list(dict.fromkeys(positions[i] for i in corners)))
        for position in kept:
            if position not in index:
                index[position] = len(index) + 1
                out.append(f"v {position}")
        numbers = [str(index[p]) for p in kept]
        while len(numbers) % 3:
            numbers.append(numbers[-1])  # a repeated point changes no hull
        out += [f"f {' '.join(numbers[k : k + 3])}" for k in range(0, len(numbers), 3)]
    return "\n".join(out) + "\n"


def _hull_candidates(texts: list[str]) -> list[str]:
    """The positions of ``texts`` not inside their convex hull by more than the tolerance.

    In their order; all of them if they span less than three dimensions (Qhull has no hull to
    offer).

    Raises:
        ValueError: a position is not finite as a float.
    """
    from scipy.spatial import ConvexHull, QhullError  # once per process: lean_collision_meshes

    # As PyBullet reads them: (float)atof, a double rounded to a float.
    doubles = np.array([[float(v) for v in t.split()] for t in texts], dtype=np.float64)
    if not (np.abs(doubles) <= np.finfo(np.float32).max).all():
        raise ValueError("a vertex position is not finite as a float")
    points = doubles.astype(np.float32).astype(np.float64)
    if len(texts) < 5:
        return texts
    extent = float(np.ptp(points, axis=0).max())
    try:
        hull = ConvexHull(points)
    except QhullError:
        return texts  # flat or degenerate: every point may be on the surface
    # Signed distance to the farthest facet plane: <= 0 inside, about 0 on the surface.
    outside = (points @ hull.equations[:, :3].T + hull.equations[:, 3]).max(axis=1)
    keep = outside >= -_INTERIOR_TOLERANCE * extent
    return [t for t, k in zip(texts, keep, strict=True) if k]


def lean_collision_meshes(folder: Path | None) -> dict[str, str] | None:
    """Lean copies (:func:`lean_collision_mesh`) of the Panda's collision meshes in ``folder``.

    Returns {original path: copy path}, for :func:`panda_urdf_with_tool`'s ``meshes``; None if
    ``folder`` is None or cannot be written, in which case the original meshes are loaded
    (slower, the same shapes). The copies are in ``folder/meshes``, named by a digest of their
    text; a copy whose text is not the one made from the original now (left over, corrupt,
    written by another version) is written again, atomically (a temporary file renamed over
    it). Checked once per process and folder.

    Making a copy parses the original and runs Qhull (about 35-50 ms for the eleven meshes), so
    an index in the same folder (``lean-index-v{LEAN_MESH_FORMAT}-{tag}.json``, the tag a digest
    of this module's source, SciPy's and NumPy's versions and the machine) records which copy
    was made from which original, by a digest of the original's bytes. A process then reads
    each original and its copy and hashes both (a few ms): an original whose bytes changed, or
    a copy whose bytes no longer match the digest in its name, is made again.
    """
    if folder is None:
        return None
    key = str(folder)
    if key not in _LEAN_MESHES:
        _LEAN_MESHES[key] = _write_lean_meshes(folder / "meshes")
    return _LEAN_MESHES[key]


def _lean_index_tag() -> str:
    """What makes a copy from an original besides the original: this code, Qhull, the CPU.

    An index of another tag is not read (its copies are made again, and the copy of the
    same text keeps its name), so a change of these never reuses a copy made otherwise.
    """
    import scipy

    material = [source_digest(__name__), scipy.__version__, np.__version__, platform.machine()]
    return hashlib.sha256(json.dumps(material).encode()).hexdigest()[:12]


def _lean_digest(lean: bytes) -> str:
    """The digest in a lean copy's name: of the format and the copy's bytes."""
    return hashlib.sha256(f"{LEAN_MESH_FORMAT}\n".encode() + lean).hexdigest()[:20]


def _write_lean_meshes(folder: Path) -> dict[str, str] | None:
    urdf = panda_urdf_with_tool(None, visuals=False)
    originals = sorted(set(re.findall(r'<mesh filename="([^"]+\.obj)"', urdf)))
    index_path = folder / f"lean-index-v{LEAN_MESH_FORMAT}-{_lean_index_tag()}.json"
    try:
        index = json.loads(index_path.read_text(encoding="utf-8"))
        if not isinstance(index, dict):
            index = {}
    except (OSError, ValueError):
        index = {}
    copies, changed = {}, False
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for original in originals:
            with open(original, "rb") as f:
                source = f.read()
            source_digest = hashlib.sha256(source).hexdigest()
            stem = os.path.splitext(os.path.basename(original))[0]
            name = index.get(source_digest)
            if isinstance(name, str) and _is_lean_copy_name(name, stem):
                path = folder / name
                try:
                    if _lean_digest(path.read_bytes()) == name[-24:-4]:
                        copies[original] = str(path)
                        continue
                except OSError:
                    pass
            # As open(..., encoding="utf-8") reads it: universal newlines.
            text = source.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")
            lean = lean_collision_mesh(text).encode("utf-8")
            path = folder / f"panda-{stem}-{_lean_digest(lean)}.obj"
            try:
                current = path.read_bytes()
            except OSError:
                current = None
            if current != lean:
                write_atomic(path, lean)
            copies[original] = str(path)
            index[source_digest] = path.name
            changed = True
    except (OSError, ValueError, UnicodeDecodeError):
        return None  # the originals load too, only slower
    if changed:
        try:  # only a shortcut: a lost race or a read-only folder costs the next process time
            write_atomic(index_path, json.dumps(index, indent=1, sort_keys=True).encode())
        except OSError:
            pass
    return copies


def _is_lean_copy_name(name: str, stem: str) -> bool:
    """Whether ``name`` is a file name :func:`_write_lean_meshes` gives a copy of ``stem``."""
    return re.fullmatch(rf"panda-{re.escape(stem)}-[0-9a-f]{{20}}\.obj", name) is not None
