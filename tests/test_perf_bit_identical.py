"""Speed-ups that claim to leave results bit for bit the same are checked against a fixture.

``tests/fixtures/perf_reference.json`` holds, for a few fixed designs, F and its terms (as exact
float64 hex strings) and SHA-256 digests of the recorded arrays. The square section's entries
were computed with the code as it was before the performance work (commit a23515b on main); the
round section's (keys starting "round"), when it became the default. Those keys keep the arm of
13 links they were recorded with (``SceneSpec(merge_fixed_links=False)``); the keys starting
"merged" are the same designs in today's default scene, the hand merged into the last arm link
(recorded when that became the default: the model is the same, its rounding is not; a platform
recorded before has the 13-link keys alone, and skips the merged ones). A speed-up of the
simulation loop must reproduce them exactly; a change of the physics must not pass this test
and needs its own, documented, side-by-side comparison instead (perf/speed/physics_options.py).

The last bits of PyBullet's physics depend on the machine: glibc and NumPy pick their maths
routines by the CPU's features at run time (an FMA sin/cos gives other bits), so the fixture keeps
one set of values per platform (``tests/platforms.py``). On a platform with no set of its own the
test passes if the outcomes equal a recorded set, and is skipped (saying why) otherwise. The C
and Python control loops are compared with each other on every machine by
``tests/test_native_loop.py``.

Record the set of this platform, with the code *before* the change to be checked (or when the
physics is meant to change, and say so in the commit):
``PYTHONPATH=$PWD python tests/test_perf_bit_identical.py --record``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from platforms import platform_id, skip_reason

from tooldesign_env import ToolDesignEnv

FIXTURE = Path(__file__).parent / "fixtures" / "perf_reference.json"

#: The straight tool, a hook, and three others that touch the box in different ways.
DESIGNS = (
    (0.0, 0.0, 0.0),
    (0.0, 1.5, 0.0),
    (0.3, -0.7, 0.2),
    (-1.1, 0.4, -0.3),
    (0.9, 1.2, 0.45),
)
ESTIMATORS = ("contact", "trajectory")
SCALARS = ("free_energy", "goal_error", "confidence", "final_distance")
ARRAYS = (
    "box_trajectory",
    "torques",
    "joint_positions",
    "tool_position",
    "tool_yaw",
    "contact",
    "confidence_t",
    "jacobian_norm_t",
)


def recorded() -> dict[str, dict[str, dict[str, object]]]:
    """The fixture's sets of outcomes, by platform."""
    variants: dict[str, dict[str, dict[str, object]]]
    variants = json.loads(FIXTURE.read_text(encoding="utf-8"))["variants"]
    return variants


def _digest(array: np.ndarray) -> str:
    a = np.ascontiguousarray(array)
    return hashlib.sha256(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes()).hexdigest()


#: The tool's sections, with the prefix of their keys in the fixture.
SECTIONS = {"square": "", "round": "round "}


#: Whether the hand is merged into the last arm link, with the prefix of their keys.
MERGED = {False: "", True: "merged "}


def outcomes(merged: tuple[bool, ...] = tuple(MERGED)) -> dict[str, dict[str, object]]:
    """What the fixture records (of the arms in ``merged``), computed with the code as it is now."""
    from tooldesign_env import SceneSpec, ToolSpec

    out: dict[str, dict[str, object]] = {}
    for merge, (shape, second), estimator in itertools.product(
        merged, SECTIONS.items(), ESTIMATORS
    ):
        first = MERGED[merge]
        prefix = first + second
        tool = ToolSpec(section_shape=shape)
        scene = SceneSpec(merge_fixed_links=merge)
        env = ToolDesignEnv(estimator=estimator, tool=tool, scene=scene, info_series=True)
        env.reset(seed=0)
        try:
            for design in DESIGNS:
                info = env.step(np.asarray(design))[4]
                row: dict[str, object] = {"valid": bool(info["valid"])}
                row.update({k: float(info[k]).hex() for k in SCALARS})
                row["fast_forward_from"] = int(info["fast_forward_from"])
                row.update({k: _digest(np.asarray(info[k])) for k in ARRAYS})
                out[f"{prefix}{estimator} {design}"] = row
        finally:
            env.close()
    return out


def _of_arm(rows: dict[str, dict[str, object]], merged: bool) -> dict[str, dict[str, object]]:
    """The rows of ``rows`` recorded with the hand merged (``merged``) or not."""
    return {k: v for k, v in rows.items() if k.startswith("merged ") == merged}


@pytest.mark.slow
@pytest.mark.parametrize("merged", [False, True], ids=["13-links", "merged-hand"])
def test_fixed_designs_give_bit_identical_results(merged: bool):
    # A platform recorded before the hand was merged by default has the 13-link rows alone:
    # they are still checked there, the merged ones are skipped (saying how to record them).
    variants = {
        name: rows
        for name, rows in ((n, _of_arm(r, merged)) for n, r in recorded().items())
        if rows
    }
    actual = outcomes((merged,))
    here = platform_id()
    if here not in variants:
        if not any(rows == actual for rows in variants.values()):
            pytest.skip(
                skip_reason(
                    "outcomes", len(variants), "python tests/test_perf_bit_identical.py --record"
                )
            )
        return
    expected = variants[here]
    assert actual.keys() == expected.keys()
    for key, row in expected.items():
        for name, value in row.items():
            assert actual[key][name] == value, f"{key}: {name} changed"


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        raise SystemExit("usage: python tests/test_perf_bit_identical.py --record")
    variants = recorded() if FIXTURE.exists() else {}
    variants[platform_id()] = outcomes()
    FIXTURE.write_text(
        json.dumps({"variants": variants}, indent=1, sort_keys=True) + "\n", encoding="utf-8"
    )
    print(f"wrote the outcomes of {platform_id()} to {FIXTURE}")


@pytest.mark.parametrize("shape", ["square", "round"])
def test_without_rendering_no_visual_shape_is_loaded(shape):
    # Visuals only cost load time (a round tool's capsules are tessellated at load); physics
    # never reads them, which the fixture above checks bit for bit for both sections.
    from tooldesign_env import ToolSpec, make_tool
    from tooldesign_env.geometry import tool_link_xml
    from tooldesign_env.robot_model import panda_urdf_with_tool

    link = tool_link_xml(make_tool((0.3, -0.7, 0.2), ToolSpec(section_shape=shape)))
    assert "<visual" in link
    bare = panda_urdf_with_tool(link, visuals=False)
    assert "<visual" not in bare and bare.count("<collision") == link.count("<collision") + (
        panda_urdf_with_tool(None, visuals=False).count("<collision")
    )
    full = panda_urdf_with_tool(link, visuals=True)
    assert full.count("<visual") == link.count("<visual") + panda_urdf_with_tool(
        None, visuals=True
    ).count("<visual")


def _pushed_box(renderer: bool) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Roll the default evaluation of a hook in a simulator whose world has or lacks a renderer."""
    import tooldesign_env.simulation as simulation
    from tooldesign_env import make_tool

    sim = simulation.ToolSimulator()
    try:
        if renderer:  # the simulator drops the renderer when not rendering; put it back
            sim.world.close()
            sim.world = simulation.BulletWorld(
                time_step=sim.scene.time_step,
                solver_iterations=sim.scene.solver_iterations,
                renderer=True,
            )
        sim.build(make_tool((0.0, 1.5, 0.0)))
        traj = sim.run(record_mobility=True)
        assert traj.contact.any()
        return tuple(traj.box_position.ravel()), tuple(traj.contact_mobility.ravel())
    finally:
        sim.close()


def test_dropping_the_renderer_changes_nothing():
    # Without a render mode the simulator's world has no software renderer, which makes
    # loading the arm cheaper; the physics never reads visuals, so nothing may change.
    assert _pushed_box(renderer=False) == _pushed_box(renderer=True)


def test_a_world_without_its_renderer_refuses_to_render_and_stays_without_it(monkeypatch):
    import gc
    import sys

    import pybullet

    from tooldesign_env.bullet import BulletWorld
    from tooldesign_env.robot_model import panda_urdf_with_tool

    # The refused world is collected cleanly: its __del__ must not raise (it once did, on an
    # attribute the refusal had not set yet).
    unraisable: list[object] = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    with pytest.raises(ValueError, match="renderer=False needs render_mode=None"):
        BulletWorld(render_mode="rgb_array", renderer=False)
    gc.collect()
    assert unraisable == []
    monkeypatch.undo()
    world = BulletWorld(renderer=False)
    try:
        with pytest.raises(RuntimeError, match="renderer=False"):
            world.render(width=8, height=8)
        for _ in range(2):  # and again on a fresh physics server
            robot = world.load_robot(panda_urdf_with_tool(None, visuals=False))
            # PyBullet keeps visual shapes in its renderer: without one it has none to give.
            with pytest.raises(pybullet.error, match="visual shape"):
                world.client.getVisualShapeData(robot.body)
            world.reconnect()
    finally:
        world.close()
    with_renderer = BulletWorld()
    try:
        robot = with_renderer.load_robot(panda_urdf_with_tool(None, visuals=False))
        assert len(with_renderer.client.getVisualShapeData(robot.body)) > 0
    finally:
        with_renderer.close()
