"""The floor guard: the arm and the tool kept off the floor, and re-simulated when they may touch.

``SceneSpec.arm_floor_contacts`` drops the collision tests of the arm and the tool against the
floor (``False``), keeps them (``True``), or, by default (``"auto"``), drops them and bounds from
below how close the tool's group and the arm came to the floor over the rollout; an episode
whose bound falls under ``floor_clearance`` is simulated again with the floor. Unit tests of the
bound and of the specs' fields first; the rollouts that check "auto" gives the results of
``True`` bit for bit are ``slow``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_perf_bit_identical import DESIGNS, _digest

from tooldesign_env import ToolDesignEnv


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
    from tooldesign_env.floor_guard import breaking_threshold

    straight = breaking_threshold(make_tool(np.zeros(3)))
    long = breaking_threshold(make_tool(np.zeros(3), ToolSpec(arc_length=3.0)))
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
        levers, plan_floor, fixed = sim._guard.arm_floor
        last = robot.joints[-1]
        assert levers[0] == 0.0 and levers[-1] == 0.0 and np.all(levers[1:-1] > 0.1)
        # Between records every joint but the first moves the tool's group too.
        substep = sim._guard.substep_levers
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
