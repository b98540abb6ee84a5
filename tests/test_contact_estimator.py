"""The contact estimator of Pi_U: its physics against hand-computed values, and its stability."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tooldesign_env.mobility import contact_mobility
from tooldesign_env.objective import ContactEstimator, Rollout, control_confidence, free_energy
from tooldesign_env.specs import ObjectiveSpec

BOX = (0.1, 0.1, 0.2)


def one_point(normal, point, box_center, mass=0.5, linear=None, angular=None, minv=None):
    linear = np.eye(3, 7) if linear is None else linear
    angular = np.zeros((3, 7)) if angular is None else angular
    minv = np.eye(7) if minv is None else minv
    return contact_mobility(
        np.array([point], float),
        np.array([normal], float),
        np.zeros((1, 3)),
        linear[None],
        angular[None],
        minv[None],
        np.array([box_center], float),
        mass,
        BOX,
    )[0]


def test_central_push_shares_the_push_between_arm_and_box():
    # Unit arm inertia along x at the point, a push through the box's centre: the box's
    # acceleration per unit torque on joint 1 is 1 / (m + 1) (arm and box move together).
    a = one_point((1, 0, 0), (0, 0, 0), (0.05, 0, 0), mass=0.5)
    expected = np.zeros((3, 7))
    expected[0, 0] = 1.0 / (0.5 + 1.0)
    np.testing.assert_allclose(a, expected, rtol=1e-12)


def test_off_centre_push_also_turns_the_box():
    # Lever s x n = -0.04 about z: the box's inverse effective mass gains lever^2 / I_zz.
    m = 0.5
    a = one_point((1, 0, 0), (0, 0, 0), (0.05, 0.04, 0), mass=m)
    izz = m * (0.1**2 + 0.1**2) / 12
    force = 1.0 / (1.0 + 1.0 / m + 0.04**2 / izz)
    assert a[0, 0] == pytest.approx(force / m, rel=1e-12)
    assert a[0, 0] < 1.0 / (m + 1.0)


def test_only_the_horizontal_part_of_the_normal_moves_the_box():
    n = np.array([0.6, 0.0, 0.8])
    a = one_point(n, (0, 0, 0), (0.06, 0, 0))
    assert np.all(a[2] == 0.0)
    assert a[0, 0] > 0 and a[0, 2] > 0  # the push along n uses joints 1 and 3


def test_heavier_box_or_arm_responds_less():
    light = one_point((1, 0, 0), (0, 0, 0), (0.05, 0, 0), mass=0.1)[0, 0]
    heavy = one_point((1, 0, 0), (0, 0, 0), (0.05, 0, 0), mass=0.9)[0, 0]
    stiff = one_point((1, 0, 0), (0, 0, 0), (0.05, 0, 0), mass=0.1, minv=0.1 * np.eye(7))[0, 0]
    assert heavy < light and stiff < light


def test_rotation_of_the_tool_moves_an_offset_contact_point():
    # The point 1 m along y from the tool's centre of mass; joint 1 turns the tool about z.
    angular = np.zeros((3, 7))
    angular[2, 0] = 1.0
    a = one_point((1, 0, 0), (0, 1, 0), (0.05, 1, 0), linear=np.zeros((3, 7)), angular=angular)
    # v = w x r = (0, 0, 1) x (0, 1, 0) = (-1, 0, 0): pushes along -x, so n^T J = -1.
    assert a[0, 0] == pytest.approx(-1.0 / (0.5 + 1.0), rel=1e-12)


def _rollout(x, u, *, mobility, control_dt):
    return Rollout(box_position=x, torques=u, contact_mobility=mobility, control_dt=control_dt)


def moving_box(n, speed=0.2, dt=1 / 120):
    x = np.zeros((n, 3))
    x[:, 0] = speed * dt * np.arange(n)
    return x


def test_constant_mobility_gives_half_tau_squared():
    n, dt = 40, 1 / 120
    a = np.zeros((n, 3, 7))
    a[:, 0, 0] = 2.0
    est = ContactEstimator(response_time=0.05)
    jac = est.estimate(
        _rollout(moving_box(n), np.zeros((n, 7)), mobility=a, control_dt=dt)
    ).jacobian
    # (Step 0 has no speed yet: the box is not sliding there.)
    np.testing.assert_allclose(jac[1 : n - 6, 0, 0], 0.5 * 0.05**2 * 2.0, rtol=1e-12)
    # The window is cut by the end of the episode.
    assert jac[-1, 0, 0] < jac[1, 0, 0]


def test_window_weights_sum_to_half_tau_squared_for_any_tau():
    n, dt = 60, 1 / 120
    a = np.ones((n, 3, 7))
    for tau in (0.004, 0.05, 0.0731, 0.2):
        est = ContactEstimator(response_time=tau)
        jac = est.estimate(
            _rollout(moving_box(n), np.zeros((n, 7)), mobility=a, control_dt=dt)
        ).jacobian
        assert jac[1, 0, 0] == pytest.approx(0.5 * tau**2, rel=1e-12)


def test_a_box_at_rest_is_held_by_friction():
    n, dt = 30, 1 / 120
    a = np.ones((n, 3, 7))
    est = ContactEstimator(response_time=0.05, slip_speed=0.01)
    still = est.estimate(_rollout(np.zeros((n, 3)), np.zeros((n, 7)), mobility=a, control_dt=dt))
    assert np.all(still.jacobian == 0.0)
    slow = est.estimate(
        _rollout(moving_box(n, speed=0.005), np.zeros((n, 7)), mobility=a, control_dt=dt)
    )
    fast = est.estimate(
        _rollout(moving_box(n, speed=0.05), np.zeros((n, 7)), mobility=a, control_dt=dt)
    )
    # Half the slip speed: half the response (away from the first step, which has no speed).
    np.testing.assert_allclose(slow.jacobian[5:20], 0.5 * fast.jacobian[5:20], rtol=1e-9)


def test_no_contact_no_confidence():
    n = 25
    terms = free_energy(
        moving_box(n),
        np.zeros((n, 7)),
        np.zeros(3),
        ObjectiveSpec(estimator="contact"),
        mobility=np.zeros((n, 3, 7)),
        control_dt=1 / 120,
    )
    assert terms.confidence == 0.0
    assert np.all(terms.confidence_t == 0.0)


def test_confidence_of_a_known_push_by_hand():
    n, dt, tau, eps = 20, 1 / 120, 0.05, 1e-6
    a = np.zeros((n, 3, 7))
    a[:, 0, 0] = 3.0  # one direction: rank 1
    est = ContactEstimator(response_time=tau)
    sens = est.estimate(_rollout(moving_box(n), np.zeros((n, 7)), mobility=a, control_dt=dt))
    c = control_confidence(sens, moving_box(n), np.zeros(3), eps=eps, form="clamped")
    j = 0.5 * tau**2 * 3.0
    assert c[1] == pytest.approx(0.5 * math.log(1 + j * j / eps), rel=1e-12)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"mobility": None, "control_dt": 1 / 120}, "record_mobility"),
        ({"mobility": np.zeros((5, 3, 7)), "control_dt": 1 / 120}, "shape"),
        ({"mobility": np.zeros((4, 3, 7)), "control_dt": 0.0}, "control_dt"),
        ({"mobility": np.zeros((4, 3, 7)), "control_dt": math.nan}, "control_dt"),
    ],
)
def test_contact_estimator_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ContactEstimator().estimate(_rollout(np.zeros((4, 3)), np.zeros((4, 7)), **kwargs))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"response_time": 0.0},
        {"response_time": math.inf},
        {"slip_speed": -1.0},
        {"slip_speed": math.nan},
        {"estimator": "contacts"},
    ],
)
def test_objective_spec_rejects_bad_contact_settings(kwargs):
    with pytest.raises(ValueError):
        ObjectiveSpec(**kwargs)


NUDGES = ((0.0, 0.0, 0.0), (1e-4, 0.0, 0.0), (0.0, -7e-5, 1e-4), (-5e-5, 5e-5, -1e-4))


@pytest.mark.slow
@pytest.mark.parametrize("design", [(0.0, 0.0, 0.0), (0.0, 1.5, 0.0), (0.4, 1.4, 0.18)])
def test_confidence_is_stable_under_nudges_that_leave_the_motion_alone(design):
    # The same design in scenes whose box differs by <= 0.1 mm and 1e-4 rad: the contact
    # estimator's confidence must move little, and less than the trajectory estimator's.
    from dataclasses import replace

    from tooldesign_env import SceneSpec, ToolDesignEnv

    base = SceneSpec()
    conf: dict[str, list[float]] = {"contact": [], "trajectory": []}
    for dx, dy, dyaw in NUDGES:
        x, y = base.box_position
        scene = replace(base, box_position=(x + dx, y + dy), box_yaw=dyaw)
        for estimator, values in conf.items():
            env = ToolDesignEnv(scene=scene, estimator=estimator)
            env.reset(seed=0)
            values.append(env.step(design)[4]["confidence"])
            env.close()
    spread = {k: (max(v) - min(v)) / np.mean(v) for k, v in conf.items()}
    assert spread["contact"] < 0.03, spread
    assert spread["contact"] < spread["trajectory"], spread


def test_the_recorded_contact_point_is_on_the_tool() -> None:
    """PyBullet's contact tuple as the loops read it: [6] is on body B, [7] points from B to A.

    Both loops ask ``getContactPoints(box, robot, -1, tool_link)`` (A the box, B the tool) and
    keep [6] and [7] (the C loop: ``position_on_b`` and ``normal_on_b``): the point on the tool's
    surface and the normal from the tool into the box, as ``contact_mobility`` expects. Two
    overlapping spheres show which index is which.
    """
    import pybullet

    client = pybullet.connect(pybullet.DIRECT)
    try:
        shape = pybullet.createCollisionShape(
            pybullet.GEOM_SPHERE, radius=0.5, physicsClientId=client
        )
        box = pybullet.createMultiBody(1.0, shape, basePosition=[0, 0, 0], physicsClientId=client)
        tool = pybullet.createMultiBody(
            1.0, shape, basePosition=[0.9, 0, 0], physicsClientId=client
        )
        pybullet.performCollisionDetection(physicsClientId=client)
        (point,) = pybullet.getContactPoints(box, tool, physicsClientId=client)
    finally:
        pybullet.disconnect(client)
    assert point[1:3] == (box, tool)
    assert point[6] == pytest.approx((0.4, 0.0, 0.0))  # the tool's surface: 0.9 - 0.5
    assert point[5] == pytest.approx((0.5, 0.0, 0.0))  # the box's surface
    assert point[7] == pytest.approx((-1.0, 0.0, 0.0))  # from the tool into the box
