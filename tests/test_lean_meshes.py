"""The lean copies of the Panda's collision meshes load into the same shapes as the originals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet
import pytest

import tooldesign_env.bullet as bullet
from tooldesign_env.bullet import (
    BulletWorld,
    lean_collision_mesh,
    lean_collision_meshes,
    panda_urdf_with_tool,
)

# Two groups, a quad (cut into triangles by position), corners with texture coordinates and
# normals, a negative (relative) index, a repeated vertex and what the collision import drops.
OBJ = """\
# a comment
mtllib box.mtl
o first
v 0.0 0.0 0.0
v 1.0 0.0 0.0
v 0.0 1.0 0.0
v 0.0 0.0 1.0
v 1.0 0.0 0.0
vn 0 0 1
vt 0.5 0.5
usemtl steel
s off
f 1/1/1 2/1/1 3/1/1
f 1//1 -4//1 4//1
f 2 3 4
g second
v 2.0 2.0 2.0
v 3.0 2.0 2.0
v 3.0 3.0 2.0
v 2.0 3.0 2.0
v 2.5 2.5 3.0
l 6 7
f 6 7 8 9
f 6 7 10
f 7 8 10
f 8 9 10
f 9 6 10
"""


def test_a_lean_copy_keeps_positions_faces_and_groups_only():
    lean = lean_collision_mesh(OBJ)
    assert lean == (
        "o first\n"
        "v 0.0 0.0 0.0\n"
        "v 1.0 0.0 0.0\n"
        "v 0.0 1.0 0.0\n"
        "v 0.0 0.0 1.0\n"
        "f 1 2 3\n"
        "f 1 2 4\n"  # -4 is the second of the five vertices defined so far
        "f 2 3 4\n"
        "g second\n"
        "v 2.0 2.0 2.0\n"
        "v 3.0 2.0 2.0\n"
        "v 3.0 3.0 2.0\n"
        "v 2.0 3.0 2.0\n"
        "v 2.5 2.5 3.0\n"
        "f 5 6 7 8\n"
        "f 5 6 9\n"
        "f 6 7 9\n"
        "f 7 8 9\n"
        "f 8 5 9\n"
    )
    # The fifth vertex repeats the second one's text: written once, referred to by its index.
    assert lean_collision_mesh("v 1 2 3\nv 1 2 3\nf 1 2 2\n") == "v 1 2 3\nf 1 1 1\n"


@pytest.mark.parametrize("face", ["f 1 2 4", "f 1 2 -4", "f 0 1 2"])
def test_a_face_that_refers_to_a_missing_vertex_is_refused(face):
    with pytest.raises(ValueError, match=r"line 4: face corner .* but 3 are defined so far"):
        lean_collision_mesh(f"v 0 0 0\nv 1 0 0\nv 0 1 0\n{face}\n")


def _hull_vertices(urdf: str, folder: Path) -> list[np.ndarray | None]:
    """PyBullet's vertices of every link's collision shape, as it holds them."""
    path = folder / "robot.urdf"
    path.write_text(urdf, encoding="utf-8")
    world = BulletWorld(renderer=False)
    try:
        c = world.client
        body = c.loadURDF(str(path), [0, 0, 0], useFixedBase=True)
        out: list[np.ndarray | None] = []
        for link in range(-1, c.getNumJoints(body)):
            try:
                out.append(np.array(c.getMeshData(body, link)[1], dtype=float))
            except pybullet.error:
                out.append(None)  # a link without a mesh
        return out
    finally:
        world.close()
        path.unlink()


def test_the_arm_loads_with_the_same_hulls_from_the_lean_copies(tmp_path):
    meshes = lean_collision_meshes(tmp_path)
    assert meshes is not None and len(meshes) >= 10
    original = _hull_vertices(panda_urdf_with_tool(None, visuals=False), tmp_path)
    lean = _hull_vertices(panda_urdf_with_tool(None, visuals=False, meshes=meshes), tmp_path)
    assert sum(v is not None and len(v) > 0 for v in original) >= 10
    assert len(original) == len(lean)
    for a, b in zip(original, lean, strict=True):
        if a is None:
            assert b is None
        else:  # every vertex, in PyBullet's order, bit for bit
            assert b is not None and a.shape == b.shape and np.array_equal(a, b)


def test_a_mesh_of_two_groups_and_a_quad_gives_the_same_hulls(tmp_path):
    original, lean = tmp_path / "original.obj", tmp_path / "lean.obj"
    original.write_text(OBJ, encoding="utf-8")
    lean.write_text(lean_collision_mesh(OBJ), encoding="utf-8")

    def urdf(mesh: Path) -> str:
        return (
            '<robot name="r"><link name="base"><inertial><mass value="1"/>'
            '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
            f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>'
            "</link></robot>"
        )

    a, b = _hull_vertices(urdf(original), tmp_path), _hull_vertices(urdf(lean), tmp_path)
    assert a[0] is not None and len(a[0]) > 0
    assert b[0] is not None and np.array_equal(a[0], b[0])


def test_copies_are_written_once_and_a_changed_copy_is_written_again(tmp_path, monkeypatch):
    monkeypatch.setattr(bullet, "_LEAN_MESHES", {})
    meshes = lean_collision_meshes(tmp_path)
    assert meshes is not None
    copies = [Path(p) for p in meshes.values()]
    assert all(p.parent == tmp_path / "meshes" for p in copies)
    assert not [p for p in (tmp_path / "meshes").iterdir() if p.name.startswith(".")]
    assert lean_collision_meshes(tmp_path) is meshes  # once per process and folder
    for original, copy in meshes.items():
        assert Path(copy).read_text(encoding="utf-8") == lean_collision_mesh(
            Path(original).read_text(encoding="utf-8")
        )
    copies[0].write_text("v 0 0 0\n", encoding="utf-8")  # damaged, or left by something else
    monkeypatch.setattr(bullet, "_LEAN_MESHES", {})
    assert lean_collision_meshes(tmp_path) == meshes
    assert copies[0].read_text(encoding="utf-8") != "v 0 0 0\n"


def test_without_a_writable_folder_the_originals_are_loaded(tmp_path, monkeypatch):
    monkeypatch.setattr(bullet, "_LEAN_MESHES", {})
    assert lean_collision_meshes(None) is None
    blocker = tmp_path / "a-file"
    blocker.write_text("", encoding="utf-8")
    assert lean_collision_meshes(blocker / "cache") is None
    urdf = panda_urdf_with_tool(None, visuals=False, meshes=None)
    assert urdf == panda_urdf_with_tool(None, visuals=False)


def test_the_simulator_loads_the_lean_copies_from_the_cache_folder(tmp_path, monkeypatch):
    from tooldesign_env.simulation import ToolSimulator

    monkeypatch.setenv("TOOLDESIGN_CACHE_DIR", str(tmp_path))
    sim = ToolSimulator()
    try:
        assert sim._meshes is not None
        assert all(Path(p).parent == tmp_path / "meshes" for p in sim._meshes.values())
    finally:
        sim.close()
    monkeypatch.setenv("TOOLDESIGN_CACHE_DIR", "")  # no disk cache: the originals
    sim = ToolSimulator()
    try:
        assert sim._meshes is None
    finally:
        sim.close()
