"""One interface for every estimator and every objective, and the factories that pick them.

An **estimator** (:class:`SensitivityEstimator`) turns one rollout into the sensitivities J = dX/dU
(and H = d2X/dU2) along it. It declares what the rollout must record for it
(:class:`~tooldesign_env.rollout.Recording`: the contact log, world snapshots for re-simulation);
the simulator honours that, and hands every estimator the same record,
:class:`~tooldesign_env.rollout.Rollout`.

An **objective** (:class:`Objective`) scores a design. It names the scenes the tool is used in
(:meth:`Objective.scenes`), scores each rollout (:meth:`Objective.score`, called while the world
still holds that rollout, so that an estimator may replay it) and combines the scenes' terms
(:meth:`Objective.combine`). The env runs that sequence and never asks which objective or
estimator it holds.

Both are registered by name (:mod:`tooldesign_env.objective.registry`); :func:`make_estimator` and
:func:`make_objective` build the one an :class:`~tooldesign_env.specs.ObjectiveSpec` names.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, cast

import numpy as np

from tooldesign_env.objective.registry import estimator_factory, objective_factory
from tooldesign_env.objective.terms import (
    ObjectiveTerms,
    Sensitivities,
    mean_terms,
    scene_offsets,
)
from tooldesign_env.rollout import Recording, Rollout, Trajectory
from tooldesign_env.specs import ObjectiveSpec

__all__ = [
    "Objective",
    "Scene",
    "SceneAveraged",
    "Score",
    "SensitivityEstimator",
    "make_estimator",
    "make_objective",
]


class SensitivityEstimator(Protocol):
    """Estimates dX/dU (and d2X/dU2) along a rollout."""

    @property
    def name(self) -> str:
        """The estimator's name (``ObjectiveSpec.estimator``)."""
        ...

    @property
    def recording(self) -> Recording:
        """What the rollout must record for :meth:`estimate`."""
        ...

    def estimate(self, rollout: Rollout) -> Sensitivities:
        """Sensitivities for each of the rollout's T control steps."""
        ...


@dataclass(frozen=True, kw_only=True)
class Scene:
    """One scene a design is used in: the episode's, or one with the box moved or made heavier.

    Attributes:
        box_mass: the box's mass, kg; None for the episode's.
        box_offset: (dx m, dy m, dyaw rad) added to the box's start pose; None for none.
        shown: the ``info``'s trajectories are this scene's (one scene of an objective's).
        averaged: its terms enter the objective's value (False for a scene run only to show).
    """

    box_mass: float | None = None
    box_offset: tuple[float, float, float] | None = None
    shown: bool = False
    averaged: bool = True

    @property
    def is_nominal(self) -> bool:
        """Whether this is the episode's own scene (its mass, the box where the scene puts it)."""
        return self.box_mass is None and self.box_offset is None


@dataclass(frozen=True, eq=False, kw_only=True)
class Score:
    """An objective's verdict on a design.

    Attributes:
        terms: the objective's value (``terms.free_energy``, the env's reward is minus it) and
            its named terms.
        trajectory: the trajectories the ``info`` shows (the :attr:`Scene.shown` scene's).
        free_energy_std: the standard deviation of the value over the averaged scenes (0 with
            one scene).
    """

    terms: ObjectiveTerms
    trajectory: Trajectory
    free_energy_std: float = 0.0


class Objective(Protocol):
    """What the env minimizes: scenes to use a design in, a score per rollout, and their mix."""

    @property
    def name(self) -> str:
        """The objective's kind (``ObjectiveSpec.kind``)."""
        ...

    @property
    def recording(self) -> Recording:
        """What each rollout must record (its estimator's needs)."""
        ...

    def scenes(self, box_mass: float) -> tuple[Scene, ...]:
        """The scenes to use the design in, for an episode whose box weighs ``box_mass`` kg.

        The env builds the episode's scene first to check the tool; a first scene that
        :attr:`Scene.is_nominal` is run in that world, every other one is built anew.
        """
        ...

    def score(self, rollout: Rollout, goal: np.ndarray) -> ObjectiveTerms:
        """The terms of one rollout toward the (3,) ``goal``, m (the world still holds it)."""
        ...

    def combine(
        self,
        scenes: Sequence[Scene],
        rollouts: Sequence[Rollout],
        terms: Sequence[ObjectiveTerms],
    ) -> Score:
        """The design's :class:`Score` from every scene's rollout and terms, in order."""
        ...


class SceneAveraged:
    """An objective that averages its terms over ``ObjectiveSpec.scene_samples`` scenes.

    The first scene is the episode's own; the others move the box by the fixed offsets of
    :func:`~tooldesign_env.objective.terms.scene_offsets` (common random numbers). Every term
    and series is the scenes' mean (:func:`~tooldesign_env.objective.terms.mean_terms`), the
    trajectories shown are the episode scene's. A subclass sets :attr:`name` and writes
    :meth:`score`; an estimator given to it sets what the rollouts record.

    Args:
        spec: the objective's settings.
        estimator: the estimator :meth:`score` uses, if any.
    """

    name = "scene-averaged"

    def __init__(self, spec: ObjectiveSpec, estimator: SensitivityEstimator | None = None) -> None:
        self.spec = spec
        self.estimator = estimator

    @classmethod
    def from_spec(cls, spec: ObjectiveSpec) -> SceneAveraged:
        """The objective with the estimator ``spec.estimator`` names (the registry's factory)."""
        return cls(spec, make_estimator(spec))

    @property
    def recording(self) -> Recording:
        """The estimator's needs, or nothing beyond the trajectory without one."""
        return Recording() if self.estimator is None else self.estimator.recording

    def scenes(self, box_mass: float) -> tuple[Scene, ...]:
        """The episode's scene, then one per further offset of ``spec.scene_samples``."""
        _, *others = scene_offsets(self.spec)
        moved = [Scene(box_offset=(float(dx), float(dy), float(dyaw))) for dx, dy, dyaw in others]
        return (Scene(shown=True), *moved)

    def score(self, rollout: Rollout, goal: np.ndarray) -> ObjectiveTerms:
        """The terms of one rollout (a subclass's)."""
        raise NotImplementedError(f"{type(self).__name__} must define score()")

    def combine(
        self,
        scenes: Sequence[Scene],
        rollouts: Sequence[Rollout],
        terms: Sequence[ObjectiveTerms],
    ) -> Score:
        """The mean of the averaged scenes' terms and the standard deviation of their value."""
        averaged = [t for s, t in zip(scenes, terms, strict=True) if s.averaged]
        std = float(np.std([t.free_energy for t in averaged], ddof=1)) if len(averaged) > 1 else 0.0
        return Score(
            terms=mean_terms(averaged), trajectory=shown(scenes, rollouts), free_energy_std=std
        )


def shown(scenes: Sequence[Scene], rollouts: Sequence[Rollout]) -> Trajectory:
    """The trajectory of the scene marked :attr:`Scene.shown`.

    Raises:
        ValueError: no scene, or more than one, is marked, or its rollout holds no trajectory.
    """
    marked = [r for s, r in zip(scenes, rollouts, strict=True) if s.shown]
    if len(marked) != 1 or marked[0].trajectory is None:
        raise ValueError(
            f"exactly one scene must be marked shown and hold a trajectory, got {len(marked)}"
        )
    return marked[0].trajectory


def make_estimator(spec: ObjectiveSpec) -> SensitivityEstimator:
    """The estimator named by ``spec.estimator``, with its settings."""
    estimator = estimator_factory(spec.estimator)(spec)
    _check_recording(estimator, f"estimator {spec.estimator!r}")
    return cast("SensitivityEstimator", estimator)


def make_objective(spec: ObjectiveSpec) -> Objective:
    """The objective named by ``spec.kind``, with its settings (and its estimator)."""
    objective = objective_factory(spec.kind)(spec)
    _check_recording(objective, f"objective {spec.kind!r}")
    for method in ("scenes", "score", "combine"):
        if not callable(getattr(objective, method, None)):
            raise TypeError(f"the objective {spec.kind!r} has no method {method}()")
    return cast("Objective", objective)


def _check_recording(strategy: object, label: str) -> None:
    recording = getattr(strategy, "recording", None)
    if not isinstance(recording, Recording):
        raise TypeError(
            f"the {label} must declare what it needs recorded: a .recording that is a "
            f"tooldesign_env.rollout.Recording, got {recording!r}"
        )


def finite_control_dt(rollout: Rollout, who: str) -> float:
    """The rollout's control period, or an error naming ``who`` needs it."""
    dt = rollout.control_dt
    if dt is None or not (math.isfinite(dt) and dt > 0):
        raise ValueError(
            f"{who} needs the rollout's control period: a finite number > 0 s, got {dt!r}"
        )
    return float(dt)
