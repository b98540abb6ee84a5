"""The resimulation estimator: dX/dU by replaying small torque perturbations in the simulator."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tooldesign_env.objective.terms import Sensitivities
from tooldesign_env.rollout import Recording, Rollout
from tooldesign_env.specs import ObjectiveSpec

__all__ = ["ResimulationEstimator"]


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

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> ResimulationEstimator:
        """The estimator with ``spec``'s horizon and perturbation (the registry's factory)."""
        return cls(horizon=spec.horizon, perturbation=spec.perturbation)

    @property
    def recording(self) -> Recording:
        """A world snapshot every ``horizon`` control steps, to replay from."""
        return Recording(snapshot_every=self.horizon)

    def estimate(self, rollout: Rollout) -> Sensitivities:
        """Sensitivities for each of the rollout's control steps, by replaying its torques."""
        replay = rollout.replay
        if replay is None:
            raise ValueError(
                "the resimulation estimator needs a simulator to replay torques: record the "
                "rollout with Recording(snapshot_every=horizon) (ToolSimulator.record)"
            )
        n = rollout.box_position.shape[0]
        delta = self.perturbation
        offsets = np.zeros((15, 7))
        for j in range(7):
            offsets[1 + 2 * j, j] = delta
            offsets[2 + 2 * j, j] = -delta
        jac = np.zeros((n, 3, 7))
        hess = np.zeros((n, 3, 7, 7))
        diag = np.arange(7)
        for k in range(0, n, self.horizon):
            response = replay(k, self.horizon, offsets)
            plus, minus = response[1::2], response[2::2]  # (7, 3) each
            jac[k : k + self.horizon] = ((plus - minus) / (2 * delta)).T
            second = ((plus + minus - 2 * response[0]) / delta**2).T  # (3, 7)
            hess[k : k + self.horizon, :, diag, diag] = second
        return Sensitivities(jac, hess)
