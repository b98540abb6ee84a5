"""The free energy F of a tool use, the paper's objective: goal error less control confidence."""

from __future__ import annotations

import numpy as np

from tooldesign_env.objective.base import SceneAveraged, SensitivityEstimator, make_estimator
from tooldesign_env.objective.terms import (
    ObjectiveTerms,
    check_rollout,
    control_confidence,
    goal_error,
)
from tooldesign_env.rollout import Replay, Rollout
from tooldesign_env.specs import ObjectiveSpec

__all__ = ["FreeEnergy", "free_energy", "free_energy_terms"]


class FreeEnergy(SceneAveraged):
    """F = sum_t [E_t - c_t], averaged over ``spec.scene_samples`` scenes (``kind="free-energy"``).

    ``goal_precision=0`` is pure confidence (F = -confidence); a large one approaches pure
    performance. The estimator named by ``spec.estimator`` gives c_t.
    """

    name = "free-energy"

    def score(self, rollout: Rollout, goal: np.ndarray) -> ObjectiveTerms:
        """F and its terms for one rollout."""
        assert self.estimator is not None
        return free_energy_terms(rollout, goal, self.spec, self.estimator)


def free_energy_terms(
    rollout: Rollout, goal: np.ndarray, spec: ObjectiveSpec, estimator: SensitivityEstimator
) -> ObjectiveTerms:
    """F and its terms for a rollout, with c_t from ``estimator``.

    Raises:
        ValueError: the rollout's arrays have the wrong shape or are not finite, or it lacks
            what the estimator needs.
    """
    check_rollout(rollout)
    goal = np.asarray(goal, dtype=float)
    box_position = rollout.box_position
    sens = estimator.estimate(rollout)
    e_t = goal_error(box_position, goal, spec.goal_precision)
    c_t = control_confidence(sens, box_position, goal, eps=spec.eps, form=spec.form, gram=spec.gram)
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


def free_energy(
    box_position: np.ndarray,
    torques: np.ndarray,
    goal: np.ndarray,
    spec: ObjectiveSpec,
    *,
    estimator: SensitivityEstimator | None = None,
    replay: Replay | None = None,
    mobility: np.ndarray | None = None,
    control_dt: float | None = None,
) -> ObjectiveTerms:
    """F and its terms for a recorded trajectory given as arrays (see :func:`free_energy_terms`).

    Args:
        box_position: (T, 3) box positions X, m.
        torques: (T, 7) joint torques U, N m.
        goal: (3,) goal X^g, m.
        spec: weights and estimator settings.
        estimator: overrides ``make_estimator(spec)``.
        replay: the simulator's replay handle, ``replay(k, horizon, offsets)`` (needed by the
            resimulation estimator; :data:`tooldesign_env.rollout.Replay`).
        mobility: (T, 3, 7) the rollout's contact mobility (needed by the contact estimator).
        control_dt: the rollout's control period, s (needed by the contact estimator).
    """
    rollout = Rollout(
        box_position=np.asarray(box_position, dtype=float),
        torques=np.asarray(torques, dtype=float),
        control_dt=control_dt,
        contact_mobility=mobility,
        replay=replay,
    )
    check_rollout(rollout)
    return free_energy_terms(rollout, goal, spec, estimator or make_estimator(spec))
