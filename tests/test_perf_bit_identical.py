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
import warnings
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


@pytest.mark.slow
def test_keeping_the_arm_off_the_floor_changes_nothing_in_the_default_scene():
    # The arm and the tool stay >= 5 cm above the floor with the default plan, so dropping
    # their collision tests against it must leave every bit of the outcome as it was.
    from dataclasses import replace

    from tooldesign_env import SceneSpec

    outcome = {}
    for flag in (True, False):
        env = ToolDesignEnv(scene=replace(SceneSpec(), arm_floor_contacts=flag), info_series=True)
        env.reset(seed=0)
        try:
            for design in DESIGNS[:3]:
                info = env.step(np.asarray(design))[4]
                outcome[flag, design] = (
                    float(info["free_energy"]).hex(),
                    _digest(np.asarray(info["box_trajectory"])),
                )
        finally:
            env.close()
    for design in DESIGNS[:3]:
        assert outcome[False, design] == outcome[True, design], design


def test_the_arm_passes_through_the_floor_only_when_asked():
    import pybullet

    from tooldesign_env import SceneSpec, ToolSimulator, make_tool

    counts = {}
    for flag in (True, False):
        sim = ToolSimulator(scene=SceneSpec(arm_floor_contacts=flag))
        try:
            sim.build(make_tool(np.zeros(3)))
            robot, cid = sim._robot, sim.world.client_id
            q = np.array(sim.reference.q0)
            q[1] += 0.6  # lean forward: the tool goes into the floor
            q[3] += 0.3
            sim.world.set_joint_positions(robot, q)
            sim.world.step(1)
            floor = 0  # the first body of every build
            arm = len(pybullet.getContactPoints(floor, robot.body, physicsClientId=cid))
            box = len(pybullet.getContactPoints(floor, sim._box, physicsClientId=cid))
            counts[flag] = (arm, box)
        finally:
            sim.close()
    assert counts[True][0] > 0 and counts[False][0] == 0
    assert counts[True][1] > 0 and counts[False][1] > 0  # the box rests on the floor either way


@pytest.mark.parametrize("value", ["no", "AUTO", None, 1, 0.0])
def test_arm_floor_contacts_must_be_a_bool_or_auto(value):
    from tooldesign_env import SceneSpec

    with pytest.raises(TypeError, match=r"arm_floor_contacts must be True, False or 'auto'"):
        SceneSpec(arm_floor_contacts=value)


@pytest.mark.parametrize("value", [0.02, 0.0, -0.1, 1.5])
def test_floor_clearance_must_exceed_the_contact_threshold(value):
    from tooldesign_env import SceneSpec

    with pytest.raises(
        ValueError, match=r"floor_clearance must be a number of metres in \(0.02, 1\]"
    ):
        SceneSpec(floor_clearance=value)


@pytest.mark.parametrize(
    ("value", "error"),
    [
        (float("nan"), ValueError),
        (float("inf"), ValueError),
        (10**400, ValueError),
        (True, TypeError),
        ("0.1", TypeError),
        (None, TypeError),
    ],
)
def test_floor_clearance_must_be_a_finite_real_number(value, error):
    from tooldesign_env import SceneSpec

    with pytest.raises(error, match=r"SceneSpec.floor_clearance must be a (real|finite) number"):
        SceneSpec(floor_clearance=value)


def test_auto_is_the_default_and_keeps_its_clearance_as_a_float():
    from tooldesign_env import SceneSpec

    scene = SceneSpec(floor_clearance=np.float32(0.05))
    assert scene.arm_floor_contacts == "auto" and type(scene.floor_clearance) is float
    # NumPy's booleans are stored as Python's: the simulator tests `is True`.
    assert SceneSpec(arm_floor_contacts=np.bool_(True)).arm_floor_contacts is True
    assert SceneSpec(arm_floor_contacts=np.bool_(False)).arm_floor_contacts is False


# ------------------------------------------------------------------ the floor guard ("auto")


def _flat(z, n=4):
    """n recorded steps of a frame at height z, axes aligned with the world's."""
    return np.tile([0.0, 0.0, z], (n, 1)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))


def test_the_bound_is_the_lowest_point_of_the_tools_group():
    from tooldesign_env.simulation import floor_clearance_bound

    points = np.array([[0.3, 0.0, -0.02], [0.0, 0.0, 0.1]])
    position, orientation = _flat(0.08)
    bound = floor_clearance_bound(
        position, orientation, points, np.ones(4), np.zeros(4), np.zeros(4)
    )
    assert bound == pytest.approx(0.06)
    # Turned upside down (180 degrees about x): the point 10 cm above the frame is now below it.
    flipped = np.tile([1.0, 0.0, 0.0, 0.0], (4, 1))
    bound = floor_clearance_bound(position, flipped, points, np.ones(4), np.zeros(4), np.zeros(4))
    assert bound == pytest.approx(-0.02)
    # Tilted by 0.1 rad about y: the point 30 cm along x goes down by 0.3 sin(0.1).
    half = 0.05
    tilted = np.tile([0.0, np.sin(half), 0.0, np.cos(half)], (4, 1))
    bound = floor_clearance_bound(position, tilted, points, np.ones(4), np.zeros(4), np.zeros(4))
    expected = 0.08 - 0.3 * np.sin(0.1) - 0.02 * np.cos(0.1)
    assert bound == pytest.approx(expected)


def test_the_bound_takes_the_arms_tracking_error_and_the_steps_between_records():
    from tooldesign_env.simulation import floor_clearance_bound

    points = np.array([[0.0, 0.0, -0.01]])
    position, orientation = _flat(0.5)
    # The other links: 14-20 cm above the floor along the plan, strayed by up to 4 cm.
    plan = np.array([0.20, 0.18, 0.14, 0.16])
    strayed = np.array([0.0, 0.0, 0.04, 0.0])
    bound = floor_clearance_bound(position, orientation, points, plan, strayed, np.zeros(4))
    assert bound == pytest.approx(0.14 - 0.04)
    # The physics steps before each record: taken at the record they precede.
    between = np.array([0.0, 0.05, 0.0, 0.03])
    bound = floor_clearance_bound(position, orientation, points, plan, strayed, between)
    assert bound == pytest.approx(min(0.10, 0.18 - 0.05, 0.16 - 0.03))
    # The tool's group: its lowest point, less what it may have moved before the record.
    position[2, 2] = 0.05
    bound = floor_clearance_bound(position, orientation, points, np.ones(4), np.zeros(4), between)
    assert bound == pytest.approx(0.04)


def test_the_guard_raises_its_limit_for_a_tool_whose_contact_threshold_is_larger():
    # PyBullet keeps contact points within 0.02 m times a shape's angular-motion disc: for a
    # long tool that exceeds floor_clearance, and the guard must use it instead.
    from tooldesign_env import ToolSpec, make_tool
    from tooldesign_env.simulation import _breaking_threshold

    straight = _breaking_threshold(make_tool(np.zeros(3)))
    long = _breaking_threshold(make_tool(np.zeros(3), ToolSpec(arc_length=3.0)))
    assert 0.02 < straight < 0.03 < long
    assert long > 2.0 * straight


def test_the_levers_bound_the_arm_and_the_base_joint_has_none():
    # A rotation of joint i by dq moves no point of the links before the last joint by more
    # than lever_i dq: checked against PyBullet by turning each joint alone.
    from tooldesign_env import SceneSpec, ToolSimulator, make_tool

    sim = ToolSimulator(scene=SceneSpec())
    try:
        sim.build(make_tool(np.zeros(3)))
        robot, world = sim._robot, sim.world
        levers, plan_floor, fixed = sim._arm_floor
        last = robot.joints[-1]
        assert levers[0] == 0.0 and levers[-1] == 0.0 and np.all(levers[1:-1] > 0.1)
        # Between records every joint but the first moves the tool's group too.
        substep = sim._substep_levers
        assert substep[0] == 0.0 and np.all(substep[1:] >= levers[1:]) and substep[-1] > 1.0
        assert plan_floor.shape == sim.reference.times.shape and 0.1 < fixed < plan_floor.min()
        q0 = np.array(sim.reference.q[900])
        world.set_joint_positions(robot, q0)
        before = world.link_boxes(robot, range(1, last))
        for i in range(7):
            q = q0.copy()
            q[i] += 0.05
            world.set_joint_positions(robot, q)
            after = world.link_boxes(robot, range(1, last))
            dropped = np.max(before[:, 0, 2] - after[:, 0, 2])
            assert dropped <= levers[i] * 0.05 + 1e-9, (i, dropped)
    finally:
        sim.close()


@pytest.mark.slow
def test_auto_gives_the_results_of_true_in_the_default_scene():
    from tooldesign_env import SceneSpec, ToolSimulator, make_tool

    sims = {
        flag: ToolSimulator(scene=SceneSpec(arm_floor_contacts=flag)) for flag in (True, "auto")
    }
    try:
        for design in DESIGNS[:3]:
            runs = {}
            for flag, sim in sims.items():
                sim.build(make_tool(np.asarray(design)))
                runs[flag] = sim.run(record_mobility=True)
            auto = runs["auto"]
            assert not auto.floor_contacts and auto.floor_clearance > 0.04
            assert runs[True].floor_contacts and runs[True].floor_clearance is None
            for name in ("box_position", "torques", "joint_positions", "contact_mobility"):
                np.testing.assert_array_equal(getattr(auto, name), getattr(runs[True], name))
    finally:
        for sim in sims.values():
            sim.close()


@pytest.mark.slow
def test_auto_simulates_again_with_the_floor_when_a_plan_lowers_the_tool_onto_it():
    # With the grasp point 1 cm above the floor the tool's 3 cm section goes into it: without
    # the floor contacts the tool would pass through, and the outcome would be False's.
    from tooldesign_env import PlanSpec, SceneSpec, ToolSimulator, make_tool

    plan = PlanSpec(height=0.01)
    tool = make_tool(np.zeros(3))
    sims = [
        ToolSimulator(scene=SceneSpec(arm_floor_contacts=flag), plan=plan)
        for flag in (True, False, "auto")
    ]
    runs = {True: sims[0].rollout(tool), False: sims[1].rollout(tool)}
    with pytest.warns(RuntimeWarning, match="may have come within 0.000 m of the floor"):
        runs["auto"] = sims[2].rollout(tool)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a simulator says it once
        again = sims[2].rollout(tool)
    try:
        auto = runs["auto"]
        assert auto.floor_contacts and auto.floor_clearance < 0.0
        assert not np.array_equal(runs[False].joint_positions, runs[True].joint_positions)
        for run in (auto, again):
            for name in ("box_position", "torques", "joint_positions"):
                np.testing.assert_array_equal(getattr(run, name), getattr(runs[True], name))
    finally:
        for sim in sims:
            sim.close()


@pytest.mark.slow
def test_an_episode_simulated_again_scores_as_with_the_floor_with_re_simulation():
    # The re-simulation estimator replays from snapshots of the rollout: the snapshots of the
    # first rollout (without the floor) must not survive into the second.
    from tooldesign_env import ObjectiveSpec, PlanSpec, SceneSpec

    plan = PlanSpec(height=0.01)
    for estimator in ("resimulation",):  # the contact estimator: the simulator's test above
        objective = ObjectiveSpec(estimator=estimator)
        infos = {}
        for flag in (True, "auto"):
            env = ToolDesignEnv(
                scene=SceneSpec(arm_floor_contacts=flag), plan=plan, objective=objective
            )
            env.reset(seed=0)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    infos[flag] = env.step(np.zeros(3, dtype=np.float32))[4]
            finally:
                env.close()
        for key in ("free_energy", "goal_error", "confidence"):
            assert infos["auto"][key] == infos[True][key], (estimator, key)


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
    from tooldesign_env.bullet import panda_urdf_with_tool
    from tooldesign_env.geometry import tool_link_xml

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

    from tooldesign_env.bullet import BulletWorld, panda_urdf_with_tool

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
