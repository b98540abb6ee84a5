"""Links held by fixed joints, merged into one (tooldesign_env.rigid_groups,
SceneSpec.merge_fixed_links): the same rigid body, fewer links for PyBullet.

The merged model must be the same model: the same mass matrix, the same inverse dynamics and the
same shapes in the same places, to rounding. Its rollouts differ from the unmerged model's by
rounding amplified by the pushes' chaos; perf/speed/physics_options.py compares the two on
32 designs against the noise floor (docs/performance.md, "Fewer links").
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tooldesign_env import SceneSpec, ToolDesignEnv, make_tool
from tooldesign_env.bullet import BulletWorld
from tooldesign_env.rigid_groups import (
    Inertial,
    combine_inertials,
    fixed_subtree,
    matrix_rpy,
    merge_fixed_links,
    principal_axes,
    rpy_matrix,
)
from tooldesign_env.robot_model import HAND_LINKS, HAND_ROOT, panda_urdf_with_tool
from tooldesign_env.simulation import ToolSimulator


def test_two_point_masses_combine_by_the_parallel_axis_theorem():
    a = Inertial(1.0, np.array([1.0, 0.0, 0.0]), np.zeros((3, 3)))
    b = Inertial(3.0, np.array([-1.0, 0.0, 0.0]), np.diag([0.1, 0.2, 0.3]))
    whole = combine_inertials([a, b])
    assert whole.mass == 4.0
    np.testing.assert_allclose(whole.center, [-0.5, 0.0, 0.0])
    # About the centre: 1 kg at 1.5 m and 3 kg at 0.5 m, both on x: 3 kg m^2 about y and z.
    np.testing.assert_allclose(whole.tensor, np.diag([0.1, 3.2, 3.3]), atol=1e-15)


def test_moving_a_part_turns_its_tensor_and_carries_its_centre():
    turn = rpy_matrix((0.0, 0.0, math.pi / 2))
    part = Inertial(2.0, np.array([1.0, 0.0, 0.0]), np.diag([1.0, 2.0, 3.0]))
    moved = part.moved(turn, np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(moved.center, [0.0, 1.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(moved.tensor, np.diag([2.0, 1.0, 3.0]), atol=1e-15)


@pytest.mark.parametrize("parts", [[], [Inertial(0.0, np.zeros(3), np.zeros((3, 3)))]])
def test_parts_without_mass_are_refused(parts):
    with pytest.raises(ValueError, match="at least one part|total mass"):
        combine_inertials(parts)


@pytest.mark.parametrize(
    "rpy",
    [
        (0.1, -0.7, 2.9),
        (-3.0, 1.2, 0.4),
        (0.0, 0.0, -math.pi / 4),
        (0.3, math.pi / 2, 0.0),
        (0.3, math.pi / 2, 0.5),  # gimbal lock: roll and yaw fold into one angle
        (0.3, -math.pi / 2, 0.5),
        (0.3, math.pi / 2 - 1e-6, 0.5),  # near the lock
        (-1.1, -math.pi / 2 + 1.3e-6, 2.0),
    ],
)
def test_rpy_round_trips_through_the_matrix(rpy):
    matrix = rpy_matrix(rpy)
    np.testing.assert_allclose(matrix @ matrix.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(rpy_matrix(matrix_rpy(matrix)), matrix, atol=1e-12)


def test_principal_axes_are_a_rotation_that_diagonalises_the_tensor():
    rng = np.random.default_rng(3)
    for _ in range(20):
        turn = rpy_matrix(rng.uniform(-3, 3, 3))
        tensor = turn @ np.diag(rng.uniform(0.1, 1.0, 3)) @ turn.T
        moments, axes = principal_axes(tensor)
        assert np.linalg.det(axes) == pytest.approx(1.0)
        np.testing.assert_allclose(axes.T @ tensor @ axes, np.diag(moments), atol=1e-14)


def test_the_hand_hangs_from_the_last_arm_link_where_the_urdf_puts_it():
    frames = fixed_subtree(panda_urdf_with_tool(None, visuals=False), HAND_ROOT)
    assert set(HAND_LINKS) | {"panda_grasptarget"} <= set(frames)
    # The flange is 0.107 m along link 7's z, the grasp target 0.105 m beyond the hand.
    np.testing.assert_allclose(frames["panda_grasptarget"][1], [0.0, 0.0, 0.212], atol=1e-15)


def test_merging_a_link_that_a_joint_moves_is_refused():
    text = panda_urdf_with_tool(None, visuals=False)
    whole = Inertial(1.0, np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match="'panda_link6'.*allowed"):
        merge_fixed_links(text, HAND_ROOT, ["panda_hand", "panda_link6"], whole)
    with pytest.raises(ValueError, match="root must be a link"):
        fixed_subtree(text, "no_such_link")


def test_the_merged_urdf_keeps_every_shape_and_the_grasp_target():
    text = panda_urdf_with_tool('<link name="tool"/>', visuals=False)
    merged = panda_urdf_with_tool('<link name="tool"/>', visuals=False, merge_hand=True)
    assert merged.count("<collision") == text.count("<collision")
    for name in HAND_LINKS:
        assert f'name="{name}"' not in merged
    assert 'link="panda_grasptarget"' in merged and 'name="tool"' in merged


@pytest.mark.parametrize("value", ["yes", 1, None])
def test_scene_spec_refuses_a_merge_flag_that_is_not_a_bool(value):
    with pytest.raises(TypeError, match="merge_fixed_links must be True or False"):
        SceneSpec(merge_fixed_links=value)


def _simulators():
    sims = {m: ToolSimulator(scene=SceneSpec(merge_fixed_links=m)) for m in (False, True)}
    geometry = make_tool(np.array([0.5, 1.0, -0.3]))
    for sim in sims.values():
        sim.build(geometry)
    return sims


def test_the_merged_arm_has_the_same_dynamics_to_rounding():
    sims = _simulators()
    try:
        counts = {m: s.world.link_count(s._robot) for m, s in sims.items()}
        assert counts[False] - counts[True] == len(HAND_LINKS)
        rng = np.random.default_rng(0)
        q = rng.uniform(-1.0, 1.0, (6, 7))
        (jac_a, mass_a), (jac_b, mass_b) = (
            sims[m]._loops.arm_matrices(sims[m].world, sims[m]._robot, q) for m in (False, True)
        )
        np.testing.assert_allclose(mass_b, mass_a, rtol=0, atol=1e-14 * np.abs(mass_a).max())
        # The tool's centre-of-mass Jacobians: the tool is a link of its own in both models.
        np.testing.assert_allclose(jac_b, jac_a, rtol=0, atol=1e-13)
        for row in q:
            qd = rng.uniform(-1.0, 1.0, 7).tolist()
            qdd = rng.uniform(-1.0, 1.0, 7).tolist()
            a, b = (
                np.array(sims[m].world.inverse_dynamics(sims[m]._robot, row.tolist(), qd, qdd))
                for m in (False, True)
            )
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-13 * np.abs(a).max())
    finally:
        for sim in sims.values():
            sim.close()


@pytest.mark.slow
def test_a_merged_episode_ends_where_the_unmerged_one_does():
    # The straight tool pushes smoothly: rounding does not grow into a different push.
    infos = {}
    for merge in (False, True):
        env = ToolDesignEnv(scene=SceneSpec(merge_fixed_links=merge))
        env.reset(seed=0)
        infos[merge] = env.step(np.zeros(3))[4]
        env.close()
    assert infos[True]["free_energy"] == pytest.approx(infos[False]["free_energy"], rel=1e-3)
    assert infos[True]["goal_error"] == pytest.approx(infos[False]["goal_error"], rel=1e-3)


@pytest.mark.slow
def test_load_robot_refuses_inertias_for_a_link_it_lacks():
    world = BulletWorld(renderer=False)
    try:
        with pytest.raises(ValueError, match="link the robot lacks: 'panda_hand'"):
            world.load_robot(
                panda_urdf_with_tool(None, visuals=False, merge_hand=True),
                link_inertias={"panda_hand": (0.8, (0.01, 0.01, 0.01))},
            )
    finally:
        world.close()
