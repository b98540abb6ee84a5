"""The free energy F of a tool use: goal error and control confidence.

F = sum_t [ E_t - c_t ] with

* E_t = 1/2 (X_t - X^g)^T P^X (X_t - X^g), P^X = p^X I_3 (``goal_precision``);
* c_t = 1/2 log|Pi_U,t| made finite: 1/2 sum_k log(1 + max(lambda_k, 0) / eps) over the
  eigenvalues lambda_k of Pi_U,t = J_t^T J_t + sum_i (X_t - X^g)_i H_t,i, where J = dX/dU (3 x 7)
  and H_i = d2X_i/dU2 (7 x 7). As in the paper's equation for log|Pi_U|, P^X is left out of Pi_U,
  so p^X = 0 (pure confidence) is well defined.

J and H come from a pluggable :class:`SensitivityEstimator`. This module does not import PyBullet:
the re-simulation estimator asks a ``replay`` callable for the box's response to torque offsets.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, cast

import numpy as np

from tooldesign_env.specs import ObjectiveSpec

__all__ = [
    "ContactEstimator",
    "ObjectiveTerms",
    "ReplayFn",
    "ResimulationEstimator",
    "Sensitivities",
    "SensitivityEstimator",
    "TrajectoryEstimator",
    "control_confidence",
    "free_energy",
    "goal_error",
    "make_estimator",
    "mean_terms",
    "scene_offsets",
]

#: ``replay(k, offsets (m, 7)) -> (m, 3)``: box positions after replaying the recorded torques of
#: control steps k .. k + horizon - 1 plus each constant offset, from the snapshot before step k.
ReplayFn = Callable[[int, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Per-step sensitivities of the box position to the joint torques.

    Attributes:
        jacobian: (T, 3, 7) dX/dU, m / N m.
        hessian: (T, 3, 7, 7) d2X/dU2, m / (N m)^2, or None when the estimator gives none.
    """

    jacobian: np.ndarray
    hessian: np.ndarray | None


class SensitivityEstimator(Protocol):
    """Estimates dX/dU (and d2X/dU2) along a trajectory."""

    @property
    def name(self) -> str:
        """The estimator's name (``ObjectiveSpec.estimator``)."""
        ...

    def estimate(
        self, box_position: np.ndarray, torques: np.ndarray, replay: ReplayFn | None
    ) -> Sensitivities:
        """Sensitivities for a (T, 3) box trajectory under (T, 7) torques."""
        ...


@dataclass(frozen=True)
class ContactEstimator:
    """dX/dU from a model-based linearization of the contact along the recorded trajectory.

    The simulator records, at every control step in contact, the box's acceleration per unit
    joint torque through the tool, A_t (``Trajectory.contact_mobility``, from PyBullet's contact
    manifold, link Jacobian and mass matrix; see
    :func:`tooldesign_env.simulation.contact_mobility`). A torque offset dU applied at step t and
    held for ``response_time`` tau moves the box by

        dX = integral_0^tau (tau - s) A(t + s) ds dU,

    so J_t is that integral, taken over the control steps of the window (J_t = tau^2/2 A_t while
    A is constant). J depends only on the joint configuration and the contact geometry, which
    are stable under tiny changes of the scene, not on a regression over the torques' small
    fluctuations, and it is exactly zero when the tool does not touch the box within tau. It
    gives no second derivative: Pi_U is the Gauss-Newton J^T J (docs/model.md).

    Attributes:
        response_time: tau, how long a torque perturbation acts before the box's response is
            read, s. The default 0.1 s is the controller's correction time, 2 / omega_n with
            omega_n = sqrt(kp) = 20 rad/s: past it, feedback has undone most of a disturbance.
        slip_speed: the box's speed over the floor at which it counts as sliding, m/s. Below
            it the floor's friction is regularized (as in soft-contact simulators): a box moving
            at speed v follows a push by the fraction v / slip_speed, and a box at rest not at
            all, since static friction holds it against a small push.
    """

    response_time: float = 0.1
    slip_speed: float = 0.01
    name: str = "contact"

    def estimate(
        self,
        box_position: np.ndarray,
        torques: np.ndarray,
        replay: ReplayFn | None = None,
        *,
        mobility: np.ndarray | None = None,
        control_dt: float | None = None,
    ) -> Sensitivities:
        """Sensitivities from a rollout's (T, 3, 7) contact mobility and control period (s)."""
        n = box_position.shape[0]
        if mobility is None or control_dt is None:
            raise ValueError(
                "the contact estimator needs the rollout's contact mobility and control period: "
                "run the simulator with record_mobility=True"
            )
        mobility = np.asarray(mobility, dtype=float)
        if mobility.shape != (n, 3, 7):
            raise ValueError(f"mobility must have shape ({n}, 3, 7), got {mobility.shape}")
        if not (math.isfinite(control_dt) and control_dt > 0):
            raise ValueError(f"control_dt must be a finite number > 0 s, got {control_dt!r}")
        # The window's weights (tau - s_j) dt at the midpoints s_j of its control steps; the
        # last step is cut so that the weights sum to tau^2 / 2 for any tau.
        tau = self.response_time
        steps = max(int(math.ceil(tau / control_dt - 1e-9)), 1)
        widths = np.minimum(control_dt, tau - np.arange(steps) * control_dt)
        mids = np.arange(steps) * control_dt + 0.5 * widths
        weights = (tau - mids) * widths
        # Regularized Coulomb friction between box and floor: a box at rest is held by static
        # friction, so a small push does not move it; a sliding box follows a push in full.
        speed = np.linalg.norm(np.diff(box_position, axis=0, prepend=box_position[:1]), axis=1)
        sliding = np.minimum(speed / (self.slip_speed * control_dt), 1.0)
        driven = mobility * sliding[:, None, None]
        jac = np.zeros_like(mobility)
        for j, w in enumerate(weights):
            jac[: n - j] += w * driven[j:]
        return Sensitivities(jac, None)


def _window_sums(values: np.ndarray, window: int) -> np.ndarray:
    """Centred moving sums over the first axis (edges use the part of the window inside)."""
    n = values.shape[0]
    csum = np.concatenate([np.zeros((1, *values.shape[1:])), np.cumsum(values, axis=0)])
    lo = np.clip(np.arange(n) - window // 2, 0, n)
    hi = np.clip(np.arange(n) - window // 2 + window, 0, n)
    return cast("np.ndarray", csum[hi] - csum[lo])


@dataclass(frozen=True)
class TrajectoryEstimator:
    """dX/dU and d2X/dU2 from the recorded trajectory alone (noisy; kept for comparison).

    Over a centred window of ``window`` control steps, the box's step-to-step motion dX is
    regressed on the torque changes dU with an intercept (ridge regression on centred moments):
    J = cov(dX, dU) (cov(dU, dU) + r I)^-1. How J itself changes is regressed on dU the same way
    to give H. The ridge r is ``ridge``
    times the episode's mean torque-change energy, so where the torques barely change (holds) the
    estimate shrinks to zero instead of dividing noise by noise.

    Attributes:
        window: control steps per window.
        ridge: ridge penalty relative to the mean of |dU|^2.
        second_order: also estimate H.
    """

    window: int = 24
    ridge: float = 0.1
    second_order: bool = True
    name: str = "trajectory"

    def estimate(
        self, box_position: np.ndarray, torques: np.ndarray, replay: ReplayFn | None = None
    ) -> Sensitivities:
        """Sensitivities for a (T, 3) box trajectory under (T, 7) torques."""
        dx = np.diff(box_position, axis=0, prepend=box_position[:1])
        du = np.diff(torques, axis=0, prepend=torques[:1])
        scale = float(np.mean(np.sum(du * du, axis=1)))
        n = box_position.shape[0]
        if scale <= 0.0:
            hess = np.zeros((n, 3, 7, 7)) if self.second_order else None
            return Sensitivities(np.zeros((n, 3, 7)), hess)
        # Past the last step in which anything moved (a fast-forwarded hold), every window sum
        # is exactly zero and so are J and H: compute up to there and zero-fill the rest.
        moving = np.flatnonzero(np.any(dx != 0.0, axis=1) | np.any(du != 0.0, axis=1))
        m = min(n, int(moving[-1]) + 1 + self.window) if moving.size else 0
        jac_full = np.zeros((n, 3, 7))
        hess_full = np.zeros((n, 3, 7, 7)) if self.second_order else None
        if m == 0:
            return Sensitivities(jac_full, hess_full)
        dx, du, n = dx[:m], du[:m], m
        count = _window_sums(np.ones((n, 1)), self.window)[:, 0]  # (T,)
        mean_du = _window_sums(du, self.window) / count[:, None]
        # Centred moments: the regression has an intercept, so a steady drift of the box (PyBullet
        # lets a resting box creep by about 0.4 um per step) is not read as a sensitivity.
        gram = _window_sums(du[:, :, None] * du[:, None, :], self.window)
        gram -= count[:, None, None] * mean_du[:, :, None] * mean_du[:, None, :]
        gram += (self.ridge * scale) * np.eye(7)
        inv = np.linalg.inv(gram)  # (T, 7, 7), symmetric positive definite
        jac = self._regress(dx, du, mean_du, count) @ inv
        if self.second_order:
            djac = np.diff(jac, axis=0, prepend=jac[:1]).reshape(n, 21)
            hess = (self._regress(djac, du, mean_du, count) @ inv).reshape(n, 3, 7, 7)
            hess_full[:m] = 0.5 * (hess + np.swapaxes(hess, -1, -2))  # type: ignore[index]
        jac_full[:m] = jac
        return Sensitivities(jac_full, hess_full)

    def _regress(
        self, y: np.ndarray, du: np.ndarray, mean_du: np.ndarray, count: np.ndarray
    ) -> np.ndarray:
        """Centred windowed cross moments sum (y - mean y)(du - mean du)^T, (T, m, 7)."""
        cross = _window_sums(y[:, :, None] * du[:, None, :], self.window)
        mean_y = _window_sums(y, self.window) / count[:, None]
        return cast(
            "np.ndarray", cross - count[:, None, None] * mean_y[:, :, None] * mean_du[:, None, :]
        )


@dataclass(frozen=True)
class ResimulationEstimator:
    """dX/dU and the diagonal of d2X/dU2 by re-simulating small torque perturbations.

    Every ``horizon`` control steps the simulator restores a snapshot and replays the recorded
    torques for ``horizon`` steps, unperturbed and with +-``perturbation`` on each joint in turn
    (15 replays). Central differences of the responses give J and the diagonal of each H_i; the
    off-diagonal second derivatives would take 4 replays per joint pair and are left at zero.
    Differences are always taken between replays from the same restore, never against the
    recorded run, because PyBullet's restore is not exact while in contact. The result holds for
    the ``horizon`` steps that follow each snapshot.

    Attributes:
        horizon: control steps between snapshots and per replay.
        perturbation: torque offset, N m.
    """

    horizon: int = 6
    perturbation: float = 0.5
    name: str = "resimulation"

    def estimate(
        self, box_position: np.ndarray, torques: np.ndarray, replay: ReplayFn | None
    ) -> Sensitivities:
        """Sensitivities for a (T, 3) box trajectory under (T, 7) torques."""
        if replay is None:
            raise ValueError("the resimulation estimator needs a simulator to replay torques")
        n = box_position.shape[0]
        delta = self.perturbation
        offsets = np.zeros((15, 7))
        for j in range(7):
            offsets[1 + 2 * j, j] = delta
            offsets[2 + 2 * j, j] = -delta
        jac = np.zeros((n, 3, 7))
        hess = np.zeros((n, 3, 7, 7))
        diag = np.arange(7)
        for k in range(0, n, self.horizon):
            response = replay(k, offsets)
            plus, minus = response[1::2], response[2::2]  # (7, 3) each
            jac[k : k + self.horizon] = ((plus - minus) / (2 * delta)).T
            second = ((plus + minus - 2 * response[0]) / delta**2).T  # (3, 7)
            hess[k : k + self.horizon, :, diag, diag] = second
        return Sensitivities(jac, hess)


def make_estimator(spec: ObjectiveSpec) -> SensitivityEstimator:
    """The estimator named by ``spec.estimator``, with its settings."""
    if spec.estimator == "contact":
        return ContactEstimator(response_time=spec.response_time, slip_speed=spec.slip_speed)
    if spec.estimator == "trajectory":
        return TrajectoryEstimator(
            window=spec.window, ridge=spec.ridge, second_order=spec.form == "clamped"
        )
    return ResimulationEstimator(horizon=spec.horizon, perturbation=spec.perturbation)


def goal_error(box_position: np.ndarray, goal: np.ndarray, goal_precision: float) -> np.ndarray:
    """E_t = 1/2 p^X |X_t - X^g|^2 per step: (T,) from (T, 3) positions and a (3,) goal."""
    err = box_position - np.asarray(goal, dtype=float)
    return cast("np.ndarray", 0.5 * goal_precision * np.sum(err * err, axis=1))


def control_confidence(
    sens: Sensitivities,
    box_position: np.ndarray,
    goal: np.ndarray,
    *,
    eps: float,
    form: str = "clamped",
) -> np.ndarray:
    """c_t = 1/2 sum_k log(1 + max(lambda_k, 0) / eps) per step, (T,).

    lambda_k are the eigenvalues of Pi_U,t = J^T J + sum_i (X - X^g)_i H_i (``form="clamped"``)
    or of J^T J alone (``form="gauss-newton"``, or when the estimator gives no H). This equals
    1/2 log|Pi_U + eps I| - 7/2 log(eps) for positive semi-definite Pi_U: finite although J^T J
    has rank <= 3, and zero when the torques do not move the box.
    """
    jac = sens.jacobian
    pi = np.swapaxes(jac, -1, -2) @ jac
    if form == "clamped" and sens.hessian is not None:
        err = box_position - np.asarray(goal, dtype=float)
        pi = pi + np.einsum("ti,tijk->tjk", err, sens.hessian)
    # A zero Pi_U (the torques do not move the box) has zero confidence: only the other steps
    # need an eigendecomposition.
    nonzero = np.any(pi != 0.0, axis=(1, 2))
    out = np.zeros(pi.shape[0])
    sub = pi[nonzero]
    lam = np.linalg.eigvalsh(0.5 * (sub + np.swapaxes(sub, -1, -2)))
    out[nonzero] = 0.5 * np.sum(np.log1p(np.maximum(lam, 0.0) / eps), axis=1)
    return out


@dataclass(frozen=True, eq=False)
class ObjectiveTerms:
    """The free energy of one tool use and its named terms.

    Attributes:
        free_energy: F = goal_error - confidence.
        goal_error: sum_t E_t.
        confidence: sum_t c_t (1/2 log|Pi_U| summed over time).
        final_distance: |X_T - X^g|, m.
        goal_error_t: (T,) E_t.
        confidence_t: (T,) c_t.
        free_energy_t: (T,) E_t - c_t.
        jacobian_norm_t: (T,) Frobenius norm of dX/dU, m / N m.
    """

    free_energy: float
    goal_error: float
    confidence: float
    final_distance: float
    goal_error_t: np.ndarray
    confidence_t: np.ndarray
    free_energy_t: np.ndarray
    jacobian_norm_t: np.ndarray


def free_energy(
    box_position: np.ndarray,
    torques: np.ndarray,
    goal: np.ndarray,
    spec: ObjectiveSpec,
    *,
    estimator: SensitivityEstimator | None = None,
    replay: ReplayFn | None = None,
    mobility: np.ndarray | None = None,
    control_dt: float | None = None,
) -> ObjectiveTerms:
    """F and its terms for a recorded trajectory.

    Args:
        box_position: (T, 3) box positions X, m.
        torques: (T, 7) joint torques U, N m.
        goal: (3,) goal X^g, m.
        spec: weights and estimator settings.
        estimator: overrides ``make_estimator(spec)``.
        replay: the simulator's replay function (needed by the resimulation estimator).
        mobility: (T, 3, 7) the rollout's contact mobility (needed by the contact estimator).
        control_dt: the rollout's control period, s (needed by the contact estimator).
    """
    box_position = np.asarray(box_position, dtype=float)
    torques = np.asarray(torques, dtype=float)
    if box_position.ndim != 2 or box_position.shape[1] != 3:
        raise ValueError(f"box_position must have shape (T, 3), got {box_position.shape}")
    if torques.shape != (box_position.shape[0], 7):
        raise ValueError(
            f"torques must have shape ({box_position.shape[0]}, 7), got {torques.shape}"
        )
    if not (np.all(np.isfinite(box_position)) and np.all(np.isfinite(torques))):
        raise ValueError("box_position and torques must be finite")
    goal = np.asarray(goal, dtype=float)
    est = estimator or make_estimator(spec)
    if isinstance(est, ContactEstimator):
        sens = est.estimate(box_position, torques, replay, mobility=mobility, control_dt=control_dt)
    else:
        sens = est.estimate(box_position, torques, replay)
    e_t = goal_error(box_position, goal, spec.goal_precision)
    c_t = control_confidence(sens, box_position, goal, eps=spec.eps, form=spec.form)
    f_t = e_t - c_t
    return ObjectiveTerms(
        free_energy=float(np.sum(f_t)),
        goal_error=float(np.sum(e_t)),
        confidence=float(np.sum(c_t)),
        final_distance=float(np.linalg.norm(box_position[-1] - goal)),
        goal_error_t=e_t,
        confidence_t=c_t,
        free_energy_t=f_t,
        jacobian_norm_t=np.linalg.norm(sens.jacobian, axis=(1, 2)),
    )


def scene_offsets(spec: ObjectiveSpec) -> np.ndarray:
    """The box's offsets (dx m, dy m, dyaw rad) in the ``spec.scene_samples`` scenes, (K, 3).

    The first row is zero (the nominal scene); the others are normal draws with standard
    deviations ``spec.scene_jitter`` from ``spec.scene_seed``, so every design is scored in the
    same K scenes (common random numbers) and K = 1 is the nominal scene alone.
    """
    shift, turn = spec.scene_jitter
    rng = np.random.default_rng(spec.scene_seed)
    draws = rng.standard_normal((spec.scene_samples - 1, 3)) * np.array([shift, shift, turn])
    return np.vstack([np.zeros((1, 3)), draws])


def mean_terms(terms: list[ObjectiveTerms]) -> ObjectiveTerms:
    """The mean of the terms of F over scenes: every number and every per-step series."""
    if not terms:
        raise ValueError("mean_terms needs the terms of at least one scene")
    if len(terms) == 1:
        return terms[0]

    def mean(name: str) -> np.ndarray:
        return np.asarray(np.mean([getattr(t, name) for t in terms], axis=0))

    return ObjectiveTerms(
        free_energy=float(mean("free_energy")),
        goal_error=float(mean("goal_error")),
        confidence=float(mean("confidence")),
        final_distance=float(mean("final_distance")),
        goal_error_t=mean("goal_error_t"),
        confidence_t=mean("confidence_t"),
        free_energy_t=mean("free_energy_t"),
        jacobian_norm_t=mean("jacobian_norm_t"),
    )
