"""The lean copies of the Panda's collision meshes load into the same shapes as the originals."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pybullet
import pytest

import tooldesign_env.lean_meshes as lean_meshes
from tooldesign_env.bullet import BulletWorld
from tooldesign_env.lean_meshes import lean_collision_mesh, lean_collision_meshes
from tooldesign_env.robot_model import panda_urdf_with_tool

# Two groups, a quad (cut into triangles by position), corners with texture coordinates and
# normals, a negative (relative) index, a repeated vertex, a point inside the second group's
# hull and what the collision import drops.
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
v 2.5 2.5 2.2
f 6 7 11
"""


def test_a_lean_copy_keeps_each_shapes_hull_candidates_once_and_its_groups():
    lean = lean_collision_mesh(OBJ)
    assert lean == (
        "o first\n"  # four points span a tetrahedron: all of them stay
        "v 0.0 0.0 0.0\n"
        "v 1.0 0.0 0.0\n"
        "v 0.0 1.0 0.0\n"
        "v 0.0 0.0 1.0\n"
        "f 1 2 3\n"
        "f 4 4 4\n"  # triangles only name the points; a repeated one changes no hull
        "g second\n"  # a pyramid: its five corners stay, the point inside it goes
        "v 2.0 2.0 2.0\n"
        "v 3.0 2.0 2.0\n"
        "v 3.0 3.0 2.0\n"
        "v 2.0 3.0 2.0\n"
        "v 2.5 2.5 3.0\n"
        "f 5 6 7\n"
        "f 8 9 9\n"
    )
    # The fifth vertex repeats the second one's text: written once, referred to by its index.
    assert lean_collision_mesh("v 1 2 3\nv 1 2 3\nf 1 2 2\n") == "v 1 2 3\nf 1 1 1\n"


def test_points_on_a_flat_shape_all_stay(tmp_path):
    # Qhull has no hull of coplanar points: none is dropped, so PyBullet sees all of them.
    text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 0\nv 0.2 0.7 0\nf 1 2 3 4 5 6\n"
    lean = lean_collision_mesh(text)
    assert lean.count("\nv ") + lean.startswith("v ") == 6
    _assert_same_shapes(text, lean, tmp_path)


@pytest.mark.parametrize("depth", [1e-5, 1e-4, 3e-4])
def test_a_point_just_inside_a_slanted_face_stays(tmp_path, depth):
    # Bullet truncates points to a grid of about 1e-4 of the extent before building the hull,
    # so a point this close inside can become a vertex: it must stay in the copy.
    inside = (np.array([1.0, 1.0, 1.0]) / 3.0) * (1.0 - depth)  # below the face x + y + z = 1
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n" + "v {!r} {!r} {!r}\n".format(*inside.tolist())
    text += "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\nf 1 2 5\n"
    lean = lean_collision_mesh(text)
    assert lean.count("v ") == 5
    _assert_same_shapes(text, lean, tmp_path)


def test_a_point_deep_inside_goes(tmp_path):
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 0.1 0.1 0.1\n"
    text += "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\nf 1 2 5\n"
    lean = lean_collision_mesh(text)
    assert lean.count("v ") == 4
    _assert_same_shapes(text, lean, tmp_path)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("f 1 2", "three corners"),  # Bullet skips it: its points are not the shape's
        ("v 1 2", "three decimal numbers"),
        ("v", "three decimal numbers"),
        ("v 1_0 0 0", "three decimal numbers"),  # Python reads 10, atof 1
        ("v nan 0 0", "three decimal numbers"),
        ("v 1e39 0 0\nf 1 2 5", "not finite"),  # beyond a float
        ("v 1 0 0 \u00e9", "printable ASCII"),
        ("f 1 2 3x", "not an index"),
        ("# " + "x" * 1000, "longer than"),
        ("v 1 0 0\r", "longer than"),
    ],
)
def test_a_file_pybullet_might_read_otherwise_is_refused(line, message):
    body = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n"
    with pytest.raises(ValueError, match=message):
        lean_collision_mesh(body + line + "\n")


def test_the_copies_replace_collision_meshes_only(tmp_path):
    # link0's and link7's visuals load the collision files too; a lean copy is no mesh to draw.
    meshes = lean_collision_meshes(tmp_path)
    assert meshes is not None
    lean = str(tmp_path / "meshes")
    for merge in (False, True):
        text = panda_urdf_with_tool(None, visuals=True, meshes=meshes, merge_hand=merge)
        visuals = "".join(re.findall(r"<visual\b.*?</visual>", text, flags=re.S))
        collisions = "".join(re.findall(r"<collision\b.*?</collision>", text, flags=re.S))
        assert lean not in visuals and "collision/link0.obj" in visuals
        assert re.findall(r'filename="([^"]+)"', collisions)
        assert all(f.startswith(lean) for f in re.findall(r'filename="([^"]+)"', collisions))


@pytest.mark.parametrize("face", ["f 1 2 4", "f 1 2 -4", "f 0 1 2"])
def test_a_face_that_refers_to_a_missing_vertex_is_refused(face):
    with pytest.raises(ValueError, match=r"line 4: face corner .* but 3 are defined so far"):
        lean_collision_mesh(f"v 0 0 0\nv 1 0 0\nv 0 1 0\n{face}\n")


def _hull_vertices(urdf: str, folder: Path) -> list[tuple[np.ndarray | None, Any, Any]]:
    """Per link: PyBullet's vertices of its collision shape, its bounding box and dynamics."""
    path = folder / "robot.urdf"
    path.write_text(urdf, encoding="utf-8")
    world = BulletWorld(renderer=False)
    try:
        c = world.client
        body = c.loadURDF(str(path), [0, 0, 0], useFixedBase=True)
        out: list[tuple[np.ndarray | None, Any, Any]] = []
        for link in range(-1, c.getNumJoints(body)):
            try:
                vertices = np.array(c.getMeshData(body, link)[1], dtype=float)
            except pybullet.error:
                vertices = None  # a link without a mesh
            out.append((vertices, c.getAABB(body, link), c.getDynamicsInfo(body, link)))
        return out
    finally:
        world.close()
        path.unlink()


def test_the_arm_loads_with_the_same_hulls_from_the_lean_copies(tmp_path):
    meshes = lean_collision_meshes(tmp_path)
    assert meshes is not None and len(meshes) >= 10
    original = _hull_vertices(panda_urdf_with_tool(None, visuals=False), tmp_path)
    lean = _hull_vertices(panda_urdf_with_tool(None, visuals=False, meshes=meshes), tmp_path)
    assert sum(v is not None and len(v) > 0 for v, _, _ in original) >= 10
    assert len(original) == len(lean)
    for (a, a_box, a_dynamics), (b, b_box, b_dynamics) in zip(original, lean, strict=True):
        if a is None:
            assert b is None
        else:  # every vertex bit for bit; PyBullet lists them in another order
            assert b is not None and a.shape == b.shape and _same_points(a, b)
        assert a_box == b_box  # the broadphase's boxes
        assert a_dynamics == b_dynamics  # mass, inertia (from the boxes), friction
    # Fewer points to read and to build the hull of: interior ones and repeated corners go.
    assert sum(Path(p).stat().st_size for p in meshes.values()) < 0.2 * sum(
        Path(p).stat().st_size for p in meshes
    )


def _same_points(a: np.ndarray, b: np.ndarray) -> bool:
    """The same vertices, bit for bit, in any order (PyBullet lists a link's shapes' together)."""
    return a.shape == b.shape and (
        a.size == 0 or bool(np.array_equal(a[np.lexsort(a.T)], b[np.lexsort(b.T)]))
    )


def _assert_same_shapes(original: str, lean: str, folder: Path) -> None:
    """PyBullet makes shapes of the same vertices, boxes and dynamics from both OBJ texts."""
    paths = folder / "original.obj", folder / "lean.obj"
    for path, text in zip(paths, (original, lean), strict=True):
        path.write_text(text, encoding="utf-8")
    (a, a_box, a_dynamics), (b, b_box, b_dynamics) = (
        _hull_vertices(_one_link(path), folder)[0] for path in paths
    )
    assert a is not None and b is not None and len(a) >= 4
    assert _same_points(a, b)
    assert a_box == b_box
    assert a_dynamics == b_dynamics


def test_a_cloud_with_interior_points_gives_the_same_hull(tmp_path):
    rng = np.random.default_rng(5)
    points = rng.normal(size=(300, 3)) * [0.05, 0.02, 0.1]
    text = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in points.tolist())
    text += "".join(f"f {i + 1} {i + 2} {i + 3}\n" for i in range(0, 300, 3))
    original, lean = tmp_path / "original.obj", tmp_path / "lean.obj"
    original.write_text(text, encoding="utf-8")
    lean.write_text(lean_collision_mesh(text), encoding="utf-8")
    assert lean.read_text(encoding="utf-8").count("v ") < 100
    a, b = _hull_vertices(_one_link(original), tmp_path), _hull_vertices(_one_link(lean), tmp_path)
    assert a[0][0] is not None and len(a[0][0]) > 10
    assert b[0][0] is not None and _same_points(a[0][0], b[0][0])
    assert a[0][1:] == b[0][1:]


def _one_link(mesh: Path) -> str:
    return (
        '<robot name="r"><link name="base"><inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
        f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>'
        "</link></robot>"
    )


def test_a_mesh_of_two_groups_and_a_quad_gives_the_same_hulls(tmp_path):
    original, lean = tmp_path / "original.obj", tmp_path / "lean.obj"
    original.write_text(OBJ, encoding="utf-8")
    lean.write_text(lean_collision_mesh(OBJ), encoding="utf-8")

    a, b = _hull_vertices(_one_link(original), tmp_path), _hull_vertices(_one_link(lean), tmp_path)
    assert a[0][0] is not None and len(a[0][0]) > 0
    assert b[0][0] is not None and _same_points(a[0][0], b[0][0])
    assert a[0][1:] == b[0][1:]


def test_copies_are_written_once_and_a_changed_copy_is_written_again(tmp_path, monkeypatch):
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
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
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
    assert lean_collision_meshes(tmp_path) == meshes
    assert copies[0].read_text(encoding="utf-8") != "v 0 0 0\n"


def test_a_later_process_reuses_the_copies_through_the_index(tmp_path, monkeypatch):
    real = lean_meshes.lean_collision_mesh
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
    meshes = lean_collision_meshes(tmp_path)
    assert meshes is not None
    index = (
        tmp_path
        / "meshes"
        / f"lean-index-v{lean_meshes.LEAN_MESH_FORMAT}-{lean_meshes._lean_index_tag()}.json"
    )
    assert sorted(json.loads(index.read_text(encoding="utf-8")).values()) == sorted(
        Path(p).name for p in meshes.values()
    )

    def not_again(text):
        raise AssertionError("a copy was made again although the index and the copy are sound")

    monkeypatch.setattr(lean_meshes, "lean_collision_mesh", not_again)
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})  # as a new process
    assert lean_collision_meshes(tmp_path) == meshes

    # Another version of this code, of Qhull or another machine: the copies are made again.
    made = []
    monkeypatch.setattr(
        lean_meshes, "lean_collision_mesh", lambda text: made.append(1) or real(text)
    )
    monkeypatch.setattr(lean_meshes, "_lean_index_tag", lambda: "another-tag")
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
    assert lean_collision_meshes(tmp_path) == meshes  # the same text, so the same names
    assert len(made) == len(meshes)


@pytest.mark.parametrize("damage", ["copy", "index", "index-entry", "index-escape"])
def test_a_damaged_copy_or_index_makes_the_copies_again(tmp_path, monkeypatch, damage):
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
    meshes = lean_collision_meshes(tmp_path)
    assert meshes is not None
    index = (
        tmp_path
        / "meshes"
        / f"lean-index-v{lean_meshes.LEAN_MESH_FORMAT}-{lean_meshes._lean_index_tag()}.json"
    )
    first = Path(next(iter(meshes.values())))
    entries = json.loads(index.read_text(encoding="utf-8"))
    if damage == "copy":  # same name, other bytes: the digest in its name no longer matches
        first.write_text("v 0 0 0\n", encoding="utf-8")
    elif damage == "index":
        index.write_text("[not an index", encoding="utf-8")
    else:
        key = next(k for k, v in entries.items() if v == first.name)
        entries[key] = (
            "panda-link0-0123456789abcdef0123.obj"
            if damage == "index-entry"
            else ("../../outside.obj")
        )
        index.write_text(json.dumps(entries), encoding="utf-8")
    made = []
    real = lean_meshes.lean_collision_mesh
    monkeypatch.setattr(
        lean_meshes, "lean_collision_mesh", lambda text: made.append(1) or real(text)
    )
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
    assert lean_collision_meshes(tmp_path) == meshes
    assert made  # made again, from the original
    assert first.read_text(encoding="utf-8") == real(
        Path(next(iter(meshes))).read_text(encoding="utf-8")
    )
    assert {Path(p).name for p in meshes.values()} <= set(
        json.loads(index.read_text(encoding="utf-8")).values()
    )  # the index points at the sound copies again


def test_without_a_writable_folder_the_originals_are_loaded(tmp_path, monkeypatch):
    monkeypatch.setattr(lean_meshes, "_LEAN_MESHES", {})
    assert lean_collision_meshes(None) is None
    blocker = tmp_path / "a-file"
    blocker.write_text("", encoding="utf-8")
    assert lean_collision_meshes(blocker / "cache") is None
    urdf = panda_urdf_with_tool(None, visuals=False, meshes=None)
    assert urdf == panda_urdf_with_tool(None, visuals=False)


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize("merge", [True, False], ids=["merged-hand", "13-links"])
def test_an_episode_is_the_same_bit_for_bit_with_the_lean_copies(tmp_path, monkeypatch, merge):
    # The hull's vertices come in another order from the lean copies; nothing in an episode
    # may depend on it.
    from tooldesign_env import SceneSpec, make_tool
    from tooldesign_env.simulation import ToolSimulator

    tool = make_tool(np.array([0.0, 1.5, 0.0]))
    runs = []
    for folder in ("", str(tmp_path)):  # the original meshes, then the lean copies
        monkeypatch.setenv("TOOLDESIGN_CACHE_DIR", folder)
        sim = ToolSimulator(scene=SceneSpec(merge_fixed_links=merge))
        try:
            assert (sim._meshes is None) == (folder == "")
            sim.build(tool)
            runs.append(sim.run(record_mobility=True))
        finally:
            sim.close()
    original, lean = runs
    for name in ("box_position", "torques", "joint_positions", "contact_mobility"):
        assert np.array_equal(getattr(original, name), getattr(lean, name)), name
