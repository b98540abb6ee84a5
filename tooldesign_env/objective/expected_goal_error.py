"""The robust-design baseline: the summed goal error averaged over box masses, no confidence."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tooldesign_env.objective.base import Scene, Score, shown
from tooldesign_env.objective.terms import ObjectiveTerms, goal_error, scene_offsets
from tooldesign_env.rollout import Recording, Rollout
from tooldesign_env.specs import ObjectiveSpec

__all__ = ["ExpectedGoalError"]


class ExpectedGoalError:
    """The mean over ``spec.expected_masses`` (and the K scenes) of sum_t E_t.

    ``kind="expected-goal-error"``: it asks for robustness directly. Its ``info`` holds the
    mean goal error as ``free_energy`` and ``goal_error``, a confidence of 0, the mean final
    distance, and the trajectories of the episode's own box mass (a rollout of its own when
    that mass is not among ``expected_masses``).

    Args:
        spec: the objective's settings.
    """

    name = "expected-goal-error"

    def __init__(self, spec: ObjectiveSpec) -> None:
        self.spec = spec

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> ExpectedGoalError:
        """The objective of ``spec`` (the registry's factory)."""
        return cls(spec)

    @property
    def recording(self) -> Recording:
        """Nothing beyond the trajectory: there is no confidence term."""
        return Recording()

    def scenes(self, box_mass: float) -> tuple[Scene, ...]:
        """Every mass in each of the K scenes; the episode's own mass too if it is not one."""
        offsets = [(float(a), float(b), float(c)) for a, b, c in scene_offsets(self.spec)]
        out: list[Scene] = []
        seen: set[tuple[float, int]] = set()
        for m in self.spec.expected_masses:
            for k, offset in enumerate(offsets):
                # A mass given twice is used twice but counted once.
                first = (m, k) not in seen
                seen.add((m, k))
                nominal = first and m == box_mass and k == 0
                out.append(Scene(box_mass=m, box_offset=offset, shown=nominal, averaged=first))
        if (box_mass, 0) not in seen:
            out.append(Scene(shown=True, averaged=False))
        return tuple(out)

    def score(self, rollout: Rollout, goal: np.ndarray) -> ObjectiveTerms:
        """The goal error of one rollout, with no confidence."""
        goal = np.asarray(goal, dtype=float)
        e_t = goal_error(rollout.box_position, goal, self.spec.goal_precision)
        zeros = np.zeros_like(e_t)
        return ObjectiveTerms(
            free_energy=float(np.sum(e_t)),
            goal_error=float(np.sum(e_t)),
            confidence=0.0,
            final_distance=float(np.linalg.norm(rollout.box_position[-1] - goal)),
            goal_error_t=e_t,
            confidence_t=zeros,
            free_energy_t=e_t,
            jacobian_norm_t=zeros,
        )

    def combine(
        self,
        scenes: Sequence[Scene],
        rollouts: Sequence[Rollout],
        terms: Sequence[ObjectiveTerms],
    ) -> Score:
        """The mean goal error per step over the averaged scenes, summed."""
        averaged = [t for s, t in zip(scenes, terms, strict=True) if s.averaged]
        e_t = np.mean([t.goal_error_t for t in averaged], 0)
        distance = np.mean([t.final_distance for t in averaged])
        zeros = np.zeros_like(e_t)
        mean = ObjectiveTerms(
            free_energy=float(np.sum(e_t)),
            goal_error=float(np.sum(e_t)),
            confidence=0.0,
            final_distance=float(distance),
            goal_error_t=e_t,
            confidence_t=zeros,
            free_energy_t=e_t,
            jacobian_norm_t=zeros,
        )
        return Score(terms=mean, trajectory=shown(scenes, rollouts))
