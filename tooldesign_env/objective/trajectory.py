"""The trajectory estimator: dX/dU and d2X/dU2 by a sliding regression over the recorded run."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from tooldesign_env.objective.terms import Sensitivities
from tooldesign_env.rollout import Recording, Rollout
from tooldesign_env.specs import ObjectiveSpec

__all__ = ["TrajectoryEstimator"]


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

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> TrajectoryEstimator:
        """The estimator with ``spec``'s window and ridge; H with ``form="clamped"`` only."""
        return cls(window=spec.window, ridge=spec.ridge, second_order=spec.form == "clamped")

    @property
    def recording(self) -> Recording:
        """Nothing beyond the trajectory."""
        return Recording()

    def estimate(self, rollout: Rollout) -> Sensitivities:
        """Sensitivities for the rollout's (T, 3) box trajectory under its (T, 7) torques."""
        box_position, torques = rollout.box_position, rollout.torques
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
