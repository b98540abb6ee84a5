"""Objective math against hand-computed values and synthetic sensitivities (no PyBullet)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tooldesign_env.objective import (
    Recording,
    ResimulationEstimator,
    Rollout,
    Sensitivities,
    TrajectoryEstimator,
    control_confidence,
    free_energy,
    goal_error,
    make_estimator,
)
from tooldesign_env.specs import ObjectiveSpec


def _rollout(x: np.ndarray, u: np.ndarray, replay=None) -> Rollout:
    return Rollout(box_position=x, torques=u, replay=replay)


def test_goal_error_by_hand():
    x = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 2.0]])
    e = goal_error(x, np.array([1.0, 2.0, 2.0]), goal_precision=20.0)
    # 1/2 * 20 * (1 + 4 + 4) = 90 and 0 at the goal.
    np.testing.assert_allclose(e, [90.0, 0.0])


def test_confidence_by_hand_gauss_newton():
    # J with singular values 2e-3 and 1e-3: eigenvalues of J^T J are 4e-6, 1e-6 and five zeros.
    jac = np.zeros((1, 3, 7))
    jac[0, 0, 0] = 2e-3
    jac[0, 1, 1] = 1e-3
    c = control_confidence(
        Sensitivities(jac, None), np.zeros((1, 3)), np.zeros(3), eps=1e-6, form="gauss-newton"
    )
    expected = 0.5 * (math.log(1 + 4.0) + math.log(1 + 1.0))
    np.testing.assert_allclose(c, [expected], rtol=1e-12)


def test_confidence_is_zero_without_sensitivity():
    c = control_confidence(
        Sensitivities(np.zeros((5, 3, 7)), np.zeros((5, 3, 7, 7))),
        np.ones((5, 3)),
        np.zeros(3),
        eps=1e-6,
    )
    np.testing.assert_array_equal(c, np.zeros(5))


def test_second_order_term_and_clamping():
    jac = np.zeros((1, 3, 7))
    hess = np.zeros((1, 3, 7, 7))
    hess[0, 0, 0, 0] = 3e-6  # with an error of +1 m in x: adds +3e-6 on joint 0
    hess[0, 0, 1, 1] = -5e-6  # and -5e-6 on joint 1, which is clamped at 0
    x = np.array([[1.0, 0.0, 0.0]])
    c = control_confidence(Sensitivities(jac, hess), x, np.zeros(3), eps=1e-6, form="clamped")
    np.testing.assert_allclose(c, [0.5 * math.log(1 + 3.0)], rtol=1e-12)
    gn = control_confidence(Sensitivities(jac, hess), x, np.zeros(3), eps=1e-6, form="gauss-newton")
    np.testing.assert_array_equal(gn, [0.0])


def test_confidence_equals_regularized_logdet():
    rng = np.random.default_rng(0)
    jac = rng.normal(scale=1e-3, size=(4, 3, 7))
    eps = 1e-6
    c = control_confidence(
        Sensitivities(jac, None), np.zeros((4, 3)), np.zeros(3), eps=eps, form="gauss-newton"
    )
    for t in range(4):
        pi = jac[t].T @ jac[t]
        _, logdet = np.linalg.slogdet(pi + eps * np.eye(7))
        np.testing.assert_allclose(c[t], 0.5 * logdet - 3.5 * math.log(eps), rtol=1e-9)


def test_trajectory_estimator_recovers_a_linear_system():
    rng = np.random.default_rng(1)
    true_j = rng.normal(scale=1e-3, size=(3, 7))
    du = rng.normal(size=(400, 7))
    u = np.cumsum(du, axis=0)
    x = np.cumsum(du @ true_j.T, axis=0)
    est = TrajectoryEstimator(window=40, ridge=1e-9, second_order=False)
    sens = est.estimate(_rollout(x, u))
    np.testing.assert_allclose(sens.jacobian[200], true_j, atol=1e-9)
    assert sens.hessian is None


def test_trajectory_estimator_gives_zero_when_torques_are_constant():
    x = np.cumsum(np.ones((50, 3)), axis=0)
    sens = TrajectoryEstimator().estimate(_rollout(x, np.ones((50, 7))))
    np.testing.assert_array_equal(sens.jacobian, 0.0)


def test_resimulation_estimator_recovers_gradient_and_curvature():
    rng = np.random.default_rng(2)
    j0 = rng.normal(size=(3, 7))
    h_diag = rng.normal(size=(3, 7))

    def replay(k: int, horizon: int, offsets: np.ndarray) -> np.ndarray:
        assert horizon == 4  # the estimator's own
        # A quadratic response x(du) = J du + 1/2 diag(H) du^2, plus a state-dependent offset.
        return offsets @ j0.T + 0.5 * (offsets**2) @ h_diag.T + k

    est = ResimulationEstimator(horizon=4, perturbation=0.5)
    sens = est.estimate(_rollout(np.zeros((10, 3)), np.zeros((10, 7)), replay))
    np.testing.assert_allclose(sens.jacobian[3], j0, rtol=1e-12)
    for i in range(3):
        np.testing.assert_allclose(np.diag(sens.hessian[7, i]), h_diag[i], rtol=1e-9)


def test_resimulation_needs_a_simulator():
    with pytest.raises(ValueError, match="replay"):
        ResimulationEstimator().estimate(_rollout(np.zeros((4, 3)), np.zeros((4, 7))))


def test_free_energy_terms_add_up_and_pure_confidence_is_defined():
    rng = np.random.default_rng(3)
    u = np.cumsum(rng.normal(size=(120, 7)), axis=0)
    x = np.cumsum(rng.normal(scale=1e-3, size=(120, 3)), axis=0)
    goal = np.array([0.0, 1.5, 0.1])
    mobility = rng.normal(size=(120, 3, 7))
    for p in (0.0, 20.0):
        for estimator in ("contact", "trajectory"):
            spec = ObjectiveSpec(goal_precision=p, estimator=estimator)
            terms = free_energy(x, u, goal, spec, mobility=mobility, control_dt=1 / 120)
            assert terms.free_energy == pytest.approx(terms.goal_error - terms.confidence)
            np.testing.assert_allclose(terms.free_energy_t, terms.goal_error_t - terms.confidence_t)
            assert np.all(np.isfinite(terms.free_energy_t))
            assert terms.confidence > 0
    spec = ObjectiveSpec(goal_precision=0.0, estimator="trajectory")
    assert free_energy(x, u, goal, spec).goal_error == 0.0


@pytest.mark.parametrize(
    ("x", "u", "match"),
    [
        (np.zeros((5, 2)), np.zeros((5, 7)), "shape"),
        (np.zeros((5, 3)), np.zeros((4, 7)), "shape"),
        (np.full((5, 3), np.nan), np.zeros((5, 7)), "finite"),
    ],
)
def test_free_energy_rejects_bad_trajectories(x, u, match):
    with pytest.raises(ValueError, match=match):
        free_energy(x, u, np.zeros(3), ObjectiveSpec())


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"goal_precision": -1.0}, "goal_precision"),
        ({"goal_precision": math.nan}, "goal_precision"),
        ({"eps": 0.0}, "eps"),
        ({"form": "full"}, "form"),
        ({"estimator": "magic"}, "estimator"),
        ({"window": 1}, "window"),
    ],
)
def test_objective_spec_rejects_bad_settings(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ObjectiveSpec(**kwargs)


def test_make_estimator_follows_the_spec():
    assert make_estimator(ObjectiveSpec()).name == "contact"
    assert make_estimator(ObjectiveSpec(estimator="trajectory")).name == "trajectory"
    assert make_estimator(ObjectiveSpec(response_time=0.2)).response_time == 0.2
    assert make_estimator(ObjectiveSpec(estimator="resimulation", horizon=8)).horizon == 8


def test_each_estimator_declares_what_it_needs_recorded():
    assert make_estimator(ObjectiveSpec()).recording == Recording(contact_mobility=True)
    assert make_estimator(ObjectiveSpec(estimator="trajectory")).recording == Recording()
    resim = make_estimator(ObjectiveSpec(estimator="resimulation", horizon=8))
    assert resim.recording == Recording(snapshot_every=8)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"contact_mobility": "yes"}, TypeError, "contact_mobility must be True or False"),
        ({"snapshot_every": 0}, ValueError, "snapshot_every must be None or an int >= 1"),
        ({"snapshot_every": 2.5}, ValueError, "snapshot_every must be None or an int >= 1"),
        ({"snapshot_every": True}, ValueError, "snapshot_every must be None or an int >= 1"),
    ],
)
def test_a_recording_refuses_bad_needs(kwargs, error, match):
    with pytest.raises(error, match=match):
        Recording(**kwargs)


def test_two_recordings_combine_into_one_that_serves_both():
    both = Recording(contact_mobility=True).union(Recording(snapshot_every=6))
    assert both == Recording(contact_mobility=True, snapshot_every=6)
    assert Recording(snapshot_every=6).union(Recording(snapshot_every=4)).snapshot_every == 2
    assert Recording().union(Recording()) == Recording()
