"""What the designer minimizes, and how control confidence is estimated: one interface for each.

* Estimators of control confidence (:class:`SensitivityEstimator`): :class:`ContactEstimator`
  (the default), :class:`TrajectoryEstimator`, :class:`ResimulationEstimator`. Each reads one
  :class:`~tooldesign_env.rollout.Rollout` and declares the
  :class:`~tooldesign_env.rollout.Recording` it needs.
* Objectives (:class:`Objective`): :class:`FreeEnergy` (F of the paper; p^X = 0 is pure
  confidence) and :class:`ExpectedGoalError` (the robust-design baseline).
* The terms (:mod:`tooldesign_env.objective.terms`): :func:`goal_error`,
  :func:`control_confidence`, :class:`ObjectiveTerms`, :func:`mean_terms`, :func:`scene_offsets`.

A new estimator or objective is one module and one registration line::

    from tooldesign_env.objective import register_estimator
    register_estimator("mine", "my_package.my_module:MyEstimator.from_spec")

after which ``ObjectiveSpec(estimator="mine")`` and ``gym.make("ToolDesign-v0",
estimator="mine")`` use it (docs/architecture.md). Names are imported on first use (PEP 562), so
that :mod:`tooldesign_env.specs` can read the registry without importing the estimators.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from tooldesign_env.lazy import lazy_attribute

if TYPE_CHECKING:
    from tooldesign_env.objective.base import (
        Objective,
        Scene,
        SceneAveraged,
        Score,
        SensitivityEstimator,
        make_estimator,
        make_objective,
    )
    from tooldesign_env.objective.contact import ContactEstimator
    from tooldesign_env.objective.energy import FreeEnergy, free_energy, free_energy_terms
    from tooldesign_env.objective.expected_goal_error import ExpectedGoalError
    from tooldesign_env.objective.registry import (
        estimator_names,
        objective_names,
        register_estimator,
        register_objective,
        unregister_estimator,
        unregister_objective,
    )
    from tooldesign_env.objective.resimulation import ResimulationEstimator
    from tooldesign_env.objective.terms import (
        ObjectiveTerms,
        Sensitivities,
        control_confidence,
        goal_error,
        mean_terms,
        scene_offsets,
    )
    from tooldesign_env.objective.trajectory import TrajectoryEstimator
    from tooldesign_env.rollout import Recording, Replay, Rollout

_BASE = "tooldesign_env.objective.base"
_REGISTRY = "tooldesign_env.objective.registry"
_TERMS = "tooldesign_env.objective.terms"
#: Where each public name lives.
_LAZY: dict[str, str] = {
    **dict.fromkeys(
        (
            "Objective",
            "Scene",
            "SceneAveraged",
            "Score",
            "SensitivityEstimator",
            "make_estimator",
            "make_objective",
        ),
        _BASE,
    ),
    "ContactEstimator": "tooldesign_env.objective.contact",
    "TrajectoryEstimator": "tooldesign_env.objective.trajectory",
    "ResimulationEstimator": "tooldesign_env.objective.resimulation",
    **dict.fromkeys(
        ("FreeEnergy", "free_energy", "free_energy_terms"), "tooldesign_env.objective.energy"
    ),
    "ExpectedGoalError": "tooldesign_env.objective.expected_goal_error",
    **dict.fromkeys(
        (
            "estimator_names",
            "objective_names",
            "register_estimator",
            "register_objective",
            "unregister_estimator",
            "unregister_objective",
        ),
        _REGISTRY,
    ),
    **dict.fromkeys(
        (
            "ObjectiveTerms",
            "Sensitivities",
            "control_confidence",
            "goal_error",
            "mean_terms",
            "scene_offsets",
        ),
        _TERMS,
    ),
    **dict.fromkeys(("Recording", "Replay", "Rollout"), "tooldesign_env.rollout"),
}

__all__ = [
    "control_confidence",
    "estimator_names",
    "free_energy",
    "free_energy_terms",
    "goal_error",
    "make_estimator",
    "make_objective",
    "mean_terms",
    "objective_names",
    "register_estimator",
    "register_objective",
    "scene_offsets",
    "unregister_estimator",
    "unregister_objective",
    "ContactEstimator",
    "ExpectedGoalError",
    "FreeEnergy",
    "Objective",
    "ObjectiveTerms",
    "Recording",
    "Replay",
    "ResimulationEstimator",
    "Rollout",
    "Scene",
    "SceneAveraged",
    "Score",
    "Sensitivities",
    "SensitivityEstimator",
    "TrajectoryEstimator",
]


def __getattr__(name: str) -> Any:
    return lazy_attribute(__name__, _LAZY, name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
