"""The terms of an objective: goal error, control confidence, and their sums and means.

F = sum_t [ E_t - c_t ] with

* E_t = 1/2 (X_t - X^g)^T P^X (X_t - X^g), P^X = p^X I_3 (``goal_precision``);
* c_t = 1/2 log|Pi_U,t| made finite: 1/2 sum_k log(1 + max(lambda_k, 0) / eps) over the
  eigenvalues lambda_k of Pi_U,t = J_t^T J_t + sum_i (X_t - X^g)_i H_t,i, where J = dX/dU (3 x 7)
  and H_i = d2X_i/dU2 (7 x 7). As in the paper's equation for log|Pi_U|, P^X is left out of Pi_U,
  so p^X = 0 (pure confidence) is well defined.

J and H come from an estimator (:class:`~tooldesign_env.objective.base.SensitivityEstimator`).
Arithmetic only: nothing here runs the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from tooldesign_env.rollout import Rollout
from tooldesign_env.specs import ObjectiveSpec

__all__ = [
    "ObjectiveTerms",
    "Sensitivities",
    "check_rollout",
    "control_confidence",
    "goal_error",
    "mean_terms",
    "scene_offsets",
]


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Per-step sensitivities of the box position to the joint torques.

    Attributes:
        jacobian: (T, 3, 7) dX/dU, m / N m.
        hessian: (T, 3, 7, 7) d2X/dU2, m / (N m)^2, or None when the estimator gives none.
    """

    jacobian: np.ndarray
    hessian: np.ndarray | None


def check_rollout(rollout: Rollout) -> None:
    """Refuse a rollout whose box positions or torques have the wrong shape or are not finite.

    Raises:
        ValueError: naming the array and what it must be.
    """
    box_position, torques = rollout.box_position, rollout.torques
    if box_position.ndim != 2 or box_position.shape[1] != 3:
        raise ValueError(f"box_position must have shape (T, 3), got {box_position.shape}")
    if torques.shape != (box_position.shape[0], 7):
        raise ValueError(
            f"torques must have shape ({box_position.shape[0]}, 7), got {torques.shape}"
        )
    if not (np.all(np.isfinite(box_position)) and np.all(np.isfinite(torques))):
        raise ValueError("box_position and torques must be finite")


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
    gram: str = "joints",
) -> np.ndarray:
    """c_t = 1/2 sum_k log(1 + max(lambda_k, 0) / eps) per step, (T,).

    lambda_k are the eigenvalues of Pi_U,t = J^T J + sum_i (X - X^g)_i H_i (``form="clamped"``)
    or of J^T J alone (``form="gauss-newton"``, or when the estimator gives no H). This equals
    1/2 log|Pi_U + eps I| - 7/2 log(eps) for positive semi-definite Pi_U: finite although J^T J
    has rank <= 3, and zero when the torques do not move the box.

    With ``gram="box"`` and no second-order term, the eigenvalues are those of the 3 x 3
    J J^T instead of the 7 x 7 J^T J: the non-zero ones are the same (J is 3 x 7) and the
    other four of J^T J add log(1 + 0) = 0, so c_t is the same up to rounding, for a cheaper
    decomposition. ``"joints"`` (the default) decomposes J^T J.
    """
    if gram not in ("joints", "box"):
        raise ValueError(f"gram must be 'joints' or 'box', got {gram!r}")
    jac = sens.jacobian
    second_order = form == "clamped" and sens.hessian is not None
    if gram == "box" and not second_order:
        pi = jac @ np.swapaxes(jac, -1, -2)
    else:
        pi = np.swapaxes(jac, -1, -2) @ jac
    if second_order:
        assert sens.hessian is not None
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
