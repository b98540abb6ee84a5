"""The round section (ToolSpec.section_shape="round"): solid, mass, files, collision, stability.

A round tool is the set of points within section / 2 of the centreline: one capsule per segment.
Its mesh stands in for that solid in the mass properties and the files.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import trimesh

from tooldesign_env import SceneSpec, ToolSimulator
from tooldesign_env.geometry import (
    SECTION_SHAPES,
    Capsule,
    ToolSpec,
    export_mesh,
    make_tool,
    tool_mesh,
    tool_urdf,
)

ROUND = ToolSpec(section_shape="round")
SQUARE = ToolSpec(section_shape="square")
R = 0.5 * ROUND.section
DESIGNS = [(0.0, 0.0, 0.0), (1.5, -1.5, 0.5), (-1.5, 1.5, -0.5), (0.3, 1.2, -0.4)]


def capsule_union_volume(polyline: np.ndarray, radius: float) -> float:
    """Oracle: the volume within ``radius`` of a planar polyline, by quadrature in the plane.

    A point (x, y, z) is inside iff d(x, y)^2 + z^2 <= r^2 with d the in-plane distance to the
    polyline, so the volume is the integral of 2 sqrt(r^2 - d^2) over the plane.
    """
    step = radius / 40
    low, high = polyline.min(axis=0) - radius, polyline.max(axis=0) + radius
    xs = np.arange(low[0], high[0], step) + step / 2
    ys = np.arange(low[1], high[1], step) + step / 2
    total = 0.0
    for x in np.array_split(xs, max(1, len(xs) // 200)):
        px, py = np.meshgrid(x, ys, indexing="ij")
        p = np.stack((px.ravel(), py.ravel()), axis=1)
        d2 = np.full(len(p), np.inf)
        for a, b in zip(polyline[:-1], polyline[1:], strict=True):
            ab = b - a
            t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
            d2 = np.minimum(d2, np.sum((a + t[:, None] * ab - p) ** 2, axis=1))
        total += np.sum(2.0 * np.sqrt(np.maximum(radius**2 - d2, 0.0)))
    return float(total * step * step)


def test_section_shape_is_round_by_default_and_checked():
    assert ToolSpec().section_shape == "round"
    assert SECTION_SHAPES == ("square", "round")
    for bad in ("circle", "", None, 1):
        with pytest.raises(ValueError, match=r"ToolSpec.section_shape must be one of .*square"):
            ToolSpec(section_shape=bad)  # type: ignore[arg-type]


def test_a_straight_round_tool_is_a_capsule_with_the_analytic_mass_properties():
    tool = make_tool((0.0, 0.0, 0.0), ROUND)
    assert tool.boxes == ()
    assert len(tool.capsules) == ROUND.n_segments + 1
    length = ROUND.handle_length + ROUND.arc_length
    cylinder, sphere = math.pi * R**2 * length, 4.0 / 3.0 * math.pi * R**3
    assert tool.volume == pytest.approx(cylinder + sphere, rel=2e-4)
    assert tool.mass == pytest.approx(ROUND.density * tool.volume)
    np.testing.assert_allclose(tool.center_of_mass, [0.55, 0.0, 0.0], atol=1e-12)
    # A cylinder with two hemispherical ends, about its centre: axial, then transverse.
    rho = ROUND.density
    m_c, m_h = rho * cylinder, rho * sphere / 2
    axial = m_c * R**2 / 2 + 2 * m_h * 2 * R**2 / 5
    # A hemisphere's transverse inertia about its centroid (3R/8 from its flat face), moved out.
    hemi = m_h * (83 / 320) * R**2 + m_h * (length / 2 + 3 * R / 8) ** 2
    transverse = m_c * (R**2 / 4 + length**2 / 12) + 2 * hemi
    np.testing.assert_allclose(np.diag(tool.inertia), [axial, transverse, transverse], rtol=2e-3)
    np.testing.assert_allclose(tool.bounds, [[-0.075 - R, -R, -R], [1.175 + R, R, R]], atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("coeffs", DESIGNS[1:])
def test_a_curved_round_tool_has_the_volume_of_its_capsules(coeffs):
    tool = make_tool(coeffs, ROUND)
    oracle = capsule_union_volume(np.asarray(tool.centerline), R)
    # The mesh differs from the capsules' union by its mitre corners and polygons.
    assert tool.volume == pytest.approx(oracle, rel=3e-3)
    square = make_tool(coeffs)
    assert square.buildable == tool.buildable
    np.testing.assert_array_equal(square.centerline, tool.centerline)


@pytest.mark.parametrize("coeffs", DESIGNS)
def test_the_round_mesh_is_closed_and_carries_the_mass_properties(coeffs):
    tool = make_tool(coeffs, ROUND)
    mesh = tool_mesh(tool)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0  # outward normals
    assert mesh.volume == pytest.approx(tool.volume, rel=1e-12)
    np.testing.assert_allclose(mesh.center_mass, tool.center_of_mass, atol=1e-12)
    np.testing.assert_allclose(mesh.mass_properties.inertia, tool.inertia, rtol=1e-9, atol=1e-15)
    # Every vertex lies within the capsules' union (up to the mitre corners at the bends).
    low, high = np.asarray(tool.bounds)
    assert np.all(mesh.vertices >= low - 1e-3) and np.all(mesh.vertices <= high + 1e-3)


def test_capsules_follow_the_centreline():
    tool = make_tool((1.5, -1.5, 0.5), ROUND)
    line = np.asarray(tool.centerline)
    for capsule, a, b in zip(tool.capsules, line[:-1], line[1:], strict=True):
        assert isinstance(capsule, Capsule)
        np.testing.assert_allclose(capsule.center[:2], (a + b) / 2, atol=1e-15)
        assert capsule.half_length == pytest.approx(np.linalg.norm(b - a) / 2, rel=1e-12)
        assert capsule.radius == R
        assert capsule.yaw == pytest.approx(math.atan2(*(b - a)[::-1]), abs=1e-12)


def test_the_urdf_has_one_capsule_per_segment():
    tool = make_tool((1.5, -1.5, 0.5), ROUND)
    link = ET.fromstring(tool_urdf(tool, name="rod")).find("link")
    collisions = link.findall("collision")
    assert len(collisions) == len(link.findall("visual")) == len(tool.capsules)
    assert not link.findall("collision/geometry/box")
    for element, capsule in zip(collisions, tool.capsules, strict=True):
        shape = element.find("geometry/capsule")
        assert float(shape.get("radius")) == capsule.radius
        assert float(shape.get("length")) == 2 * capsule.half_length
        rpy = [float(v) for v in element.find("origin").get("rpy").split()]
        assert rpy == [0.0, math.pi / 2, capsule.yaw]


@pytest.mark.parametrize("suffix", [".stl", ".obj"])
def test_the_round_mesh_exports_and_reloads_watertight(tmp_path, suffix):
    tool = make_tool((0.3, 1.2, -0.4), ROUND)
    path = export_mesh(tool, tmp_path / f"rod{suffix}")
    mesh = trimesh.load(path, force="mesh")
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(tool.volume, rel=1e-6)


@pytest.mark.slow
def test_pybullet_builds_the_capsules_where_the_geometry_puts_them():
    sim = ToolSimulator()
    try:
        tool = make_tool((1.5, -1.5, 0.5), ROUND)
        assert sim.build(tool).overlaps_box is False
        client, robot = sim.world.client, sim._robot
        assert robot is not None
        shapes = client.getCollisionShapeData(robot.body, robot.tool_link)
        assert len(shapes) == len(tool.capsules)
        assert {shape[2] for shape in shapes} == {client.GEOM_CAPSULE}
        # The tool's inertia as PyBullet read it: the principal moments of the geometry's tensor.
        mass, _, inertia, *_ = client.getDynamicsInfo(robot.body, robot.tool_link)
        assert mass == tool.mass
        np.testing.assert_allclose(
            sorted(inertia), sorted(np.linalg.eigvalsh(tool.inertia)), rtol=1e-9
        )
        # The capsules' lowest point is a radius below the tool's plane: in the world, the
        # tool's lowest point at the start pose (tool held level) is its height less a radius.
        low, _ = client.getAABB(robot.body, robot.tool_link)
        position = client.getLinkState(robot.body, robot.tool_link, computeForwardKinematics=1)[4]
        assert low[2] == pytest.approx(position[2] - R, abs=2e-3)
    finally:
        sim.close()


@pytest.mark.slow
def test_a_round_tool_pushes_the_box_and_its_outcome_is_stable_under_nudges():
    """The point of the round section: 0.1 mm nudges of the box barely move the outcome.

    The square section's goal error moved up to 20 % on such nudges (docs/model.md). With a
    square section the box's end of the first design below moves by 2.4 % of its path
    (33 mm); with a round one by 0.2 % (2.6 mm), and the second's by 0.13 %.
    """
    scenes = [
        SceneSpec(),
        SceneSpec(box_position=(1.1691342951089922 + 8e-5, 0.675 + 5e-5)),
        SceneSpec(box_yaw=SceneSpec().box_yaw + 1e-4),
    ]
    for coeffs in [(0.5, 0.9, -0.2), (0.8, -1.2, 0.3)]:
        tool = make_tool(coeffs, ROUND)
        ends = []
        for scene in scenes:
            sim = ToolSimulator(scene=scene)
            try:
                assert sim.build(tool).overlaps_box is False
                trajectory = sim.run()
            finally:
                sim.close()
            assert trajectory.contact.any()
            ends.append(trajectory.box_position[-1])
        ends = np.array(ends)
        start = np.array([*SceneSpec().box_position])
        moved = np.linalg.norm(ends[0, :2] - start)
        assert moved > 0.1
        spread = np.max(np.linalg.norm(ends - ends.mean(axis=0), axis=1))
        assert spread < 0.01 * moved


# ------------------------------------------------------------------------------------------------
# The harness and the command line
# ------------------------------------------------------------------------------------------------


def test_a_design_run_scores_with_the_tool_of_its_section():
    from benchmarks.design import DesignConfig

    assert "tool" not in dict(DesignConfig().task().env_kwargs)  # the env's own default
    assert DesignConfig().tool_spec() == ROUND == ToolSpec()
    config = DesignConfig(section_shape="square")
    assert config.tool_spec() == SQUARE
    assert dict(config.task().env_kwargs)["tool"] == SQUARE
    assert config.to_json()["section_shape"] == "square"
    with pytest.raises(ValueError, match=r"section_shape must be one of .*'square'.*got 'oval'"):
        DesignConfig(section_shape="oval")


def test_a_suite_passes_its_section_to_every_run_and_old_suites_read_as_square():
    from benchmarks.design.config import ADDED_FIELDS as DESIGN_ADDED
    from benchmarks.suites import SuiteConfig
    from benchmarks.suites.config import ADDED_FIELDS as SUITE_ADDED
    from benchmarks.suites.config import SUITE_KIND, suite_of_manifest

    suite = SuiteConfig(name="s", n_seeds=2, section_shape="round")
    runs = suite.runs()
    assert runs and all(run.design.section_shape == "round" for run in runs)
    assert DESIGN_ADDED["section_shape"] == SUITE_ADDED["section_shape"] == "square"
    data = SuiteConfig(name="s").to_json()
    del data["section_shape"]
    assert suite_of_manifest({"extra": {"kind": SUITE_KIND}, "config": data}).section_shape == (
        "square"
    )
    with pytest.raises(ValueError, match="section_shape"):
        SuiteConfig(name="s", section_shape=None)  # type: ignore[arg-type]


def test_the_command_line_offers_the_geometrys_section_shapes_and_default():
    from benchmarks.cli._common import DEFAULT_SECTION_SHAPE
    from benchmarks.cli._common import SECTION_SHAPES as CLI_SHAPES
    from benchmarks.design import DesignConfig
    from benchmarks.suites import SuiteConfig

    assert CLI_SHAPES == SECTION_SHAPES
    assert DEFAULT_SECTION_SHAPE == ToolSpec().section_shape == "round"
    assert DesignConfig().section_shape == SuiteConfig(name="s").section_shape == "round"


@pytest.mark.slow
def test_dense_search_passes_the_section_and_the_scene_samples(monkeypatch, tmp_path):
    import pandas as pd

    from benchmarks.suites import dense_search as cli  # the command imports them when run

    seen = {}

    def fake(out, *, task, **kwargs):
        seen["task"] = task
        return pd.DataFrame({"status": []})

    monkeypatch.setattr(cli, "dense_search", fake)
    monkeypatch.setattr(cli, "best_designs", lambda table: table)
    from benchmarks.cli import build_parser

    args = build_parser().parse_args(
        ["dense-search", "--out", str(tmp_path), "--section-shape", "square"]
        + ["--scene-samples", "3"]
    )
    assert args.run(args) == 0
    assert dict(seen["task"].env_kwargs) == {"scene_samples": 3, "tool": SQUARE}
    args = build_parser().parse_args(["dense-search", "--out", str(tmp_path / "b")])
    assert args.section_shape == "round"


@pytest.mark.slow
def test_evaluate_writes_a_round_tool(tmp_path):
    from benchmarks.design.evaluate import evaluate_coefficients

    info = evaluate_coefficients((0.3, 1.2, -0.4), tmp_path / "rod", section_shape="round")
    assert info["valid"]
    urdf = (tmp_path / "rod" / "tool.urdf").read_text()
    assert "<capsule" in urdf and "<box" not in urdf
    card = (tmp_path / "rod").glob("*.json")
    assert any('"section_shape": "round"' in path.read_text() for path in card)


@pytest.mark.slow
def test_retest_evaluates_a_suites_designs_with_the_suites_tool():
    from benchmarks.suites import SuiteConfig
    from benchmarks.suites.retest import retest_task

    record = {"goal": (0.0, 1.5, 0.1), "goal_precision": 20.0, "box_mass": 0.1}
    assert retest_task(SuiteConfig(name="s"), record).env_kwargs == ()
    task = retest_task(SuiteConfig(name="s", section_shape="square"), record)
    assert dict(task.env_kwargs) == {"tool": SQUARE}
    wide = [[-3.0, 3.0], [-1.5, 1.5], [-0.5, 0.5]]
    task = retest_task(SuiteConfig(name="s", bounds=wide), record)
    assert dict(task.env_kwargs) == {"bounds": ((-3.0, 3.0), (-1.5, 1.5), (-0.5, 0.5))}
    assert (
        retest_task(
            SuiteConfig(name="s", bounds=[[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]]), record
        ).env_kwargs
        == ()
    )


def test_a_round_tools_end_cap_may_not_reach_another_part_of_it():
    from tooldesign_env.geometry.intersection import _caps_clear

    hook = np.array([[-0.075, 0.0], [0.075, 0.0], [0.5, 0.0], [0.5, 0.2], [0.1, 0.2]])
    assert _caps_clear(hook, 0.03) == ""
    # Curled back so that the tip ends 2 cm above the second segment: its cap reaches it.
    curled = np.vstack([hook, [[0.1, 0.02]]])
    assert "tip cap reaches segment 1" in _caps_clear(curled, 0.03)
    assert _caps_clear(curled, 0.019) == ""
    # The handle's end: the curve passes within a section of the handle's start, the tip is far.
    around = np.array(
        [[-0.075, 0.0], [0.075, 0.0], [0.3, 0.0], [0.3, 0.1], [-0.06, 0.015], [-0.06, 0.3]]
    )
    assert "handle's end cap reaches segment" in _caps_clear(around, 0.03)
    assert _caps_clear(around, 0.015) == ""
    # No design in the bounds is affected: the rule agrees with the square's there.
    for coeffs in DESIGNS:
        assert make_tool(coeffs, ROUND).buildable == make_tool(coeffs).buildable
