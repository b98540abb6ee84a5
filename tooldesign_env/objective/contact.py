"""The contact estimator: dX/dU from a linearization of the tool-box contact (the default)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tooldesign_env.objective.terms import Sensitivities
from tooldesign_env.rollout import Recording, Rollout
from tooldesign_env.specs import ObjectiveSpec

__all__ = ["ContactEstimator"]


@dataclass(frozen=True)
class ContactEstimator:
    """dX/dU from a model-based linearization of the contact along the recorded trajectory.

    The simulator records, at every control step in contact, the box's acceleration per unit
    joint torque through the tool, A_t (``Trajectory.contact_mobility``, from PyBullet's contact
    manifold, link Jacobian and mass matrix; see
    :func:`tooldesign_env.mobility.contact_mobility`). A torque offset dU applied at step t and
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

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> ContactEstimator:
        """The estimator with ``spec``'s response time and slip speed (the registry's factory)."""
        return cls(response_time=spec.response_time, slip_speed=spec.slip_speed)

    @property
    def recording(self) -> Recording:
        """The contact log: the contact mobility at every step in contact."""
        return Recording(contact_mobility=True)

    def estimate(self, rollout: Rollout) -> Sensitivities:
        """Sensitivities from a rollout's (T, 3, 7) contact mobility and control period (s)."""
        box_position = rollout.box_position
        mobility, control_dt = rollout.contact_mobility, rollout.control_dt
        n = box_position.shape[0]
        if mobility is None or control_dt is None:
            raise ValueError(
                "the contact estimator needs the rollout's contact mobility and control period: "
                "record it with Recording(contact_mobility=True) (ToolSimulator.record, or "
                "run(record_mobility=True))"
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
