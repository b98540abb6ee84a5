"""The registries of estimators and objectives: a name, and the factory that makes one from a spec.

A factory takes the :class:`~tooldesign_env.specs.ObjectiveSpec` and returns the estimator (a
:class:`~tooldesign_env.objective.base.SensitivityEstimator`) or the objective (an
:class:`~tooldesign_env.objective.base.Objective`). It is given as a callable, or as a
``"module:attribute"`` string that is imported on first use (as Gymnasium's entry points are), so
that the names are known, and ``ObjectiveSpec`` can check them, without importing any estimator.

This module imports nothing of the project: :mod:`tooldesign_env.specs` reads it.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

__all__ = [
    "estimator_factory",
    "estimator_names",
    "objective_factory",
    "objective_names",
    "register_estimator",
    "register_objective",
    "unregister_estimator",
    "unregister_objective",
]

#: ``factory(spec: ObjectiveSpec) -> estimator or objective``, or its ``"module:attribute"``.
Factory = Callable[[Any], Any]

_ESTIMATORS: dict[str, Factory | str] = {}
_OBJECTIVES: dict[str, Factory | str] = {}


def _register(table: dict[str, Factory | str], what: str, name: str, factory: Any) -> None:
    if not isinstance(name, str) or not name.strip() or name != name.strip():
        raise ValueError(
            f"an {what} name must be a non-empty string without spaces around it, got {name!r}"
        )
    if not (callable(factory) or (isinstance(factory, str) and _is_entry_point(factory))):
        raise TypeError(
            f"the {what} {name!r} needs a factory: a callable taking the ObjectiveSpec, or a "
            f"'module:attribute' string naming one, got {factory!r}"
        )
    if name in table:
        raise ValueError(
            f"an {what} named {name!r} is registered already ({table[name]!r}); pick another "
            f"name, or unregister_{what.split()[-1]}({name!r}) first"
        )
    table[name] = factory


def _is_entry_point(text: str) -> bool:
    module, _, attribute = text.partition(":")
    return bool(module) and bool(attribute) and " " not in text


def _factory(table: dict[str, Factory | str], what: str, name: str) -> Factory:
    try:
        factory = table[name]
    except KeyError:
        raise ValueError(f"no {what} named {name!r}; registered: {tuple(table)}") from None
    if isinstance(factory, str):
        module, _, attribute = factory.partition(":")
        value: Any = importlib.import_module(module)
        for part in attribute.split("."):
            value = getattr(value, part)
        table[name] = factory = value
    return factory


def register_estimator(name: str, factory: Factory | str) -> None:
    """Register an estimator of control confidence under ``name`` (``ObjectiveSpec.estimator``).

    Args:
        name: the name specs and the env's ``estimator=`` take.
        factory: ``factory(spec) -> SensitivityEstimator``, or its ``"module:attribute"``.

    Raises:
        ValueError: ``name`` is taken (registries never replace silently) or empty.
        TypeError: ``factory`` is neither callable nor a ``"module:attribute"`` string.
    """
    _register(_ESTIMATORS, "estimator", name, factory)


def register_objective(kind: str, factory: Factory | str) -> None:
    """Register an objective under ``kind`` (``ObjectiveSpec.kind``).

    Args:
        kind: the name specs and the env's ``objective_kind=`` take.
        factory: ``factory(spec) -> Objective``, or its ``"module:attribute"``.

    Raises:
        ValueError: ``kind`` is taken or empty.
        TypeError: ``factory`` is neither callable nor a ``"module:attribute"`` string.
    """
    _register(_OBJECTIVES, "objective", kind, factory)


def _unregister(
    table: dict[str, Factory | str], builtin: tuple[str, ...], what: str, name: str
) -> None:
    if name in builtin:
        raise ValueError(f"the built-in {what} {name!r} cannot be unregistered")
    if name not in table:
        raise ValueError(f"no {what} named {name!r}; registered: {tuple(table)}")
    del table[name]


def unregister_estimator(name: str) -> None:
    """Remove an estimator registered with :func:`register_estimator` (not a built-in one)."""
    _unregister(_ESTIMATORS, BUILTIN_ESTIMATORS, "estimator", name)


def unregister_objective(kind: str) -> None:
    """Remove an objective registered with :func:`register_objective` (not a built-in one)."""
    _unregister(_OBJECTIVES, BUILTIN_OBJECTIVES, "objective", kind)


def estimator_names() -> tuple[str, ...]:
    """The registered estimators' names, built-in ones first."""
    return tuple(_ESTIMATORS)


def objective_names() -> tuple[str, ...]:
    """The registered objectives' kinds, built-in ones first."""
    return tuple(_OBJECTIVES)


def estimator_factory(name: str) -> Factory:
    """The factory of the estimator ``name`` (imported now if registered by its path)."""
    return _factory(_ESTIMATORS, "estimator", name)


def objective_factory(kind: str) -> Factory:
    """The factory of the objective ``kind`` (imported now if registered by its path)."""
    return _factory(_OBJECTIVES, "objective", kind)


# The built-in estimators and objectives: one line each.
register_estimator("contact", "tooldesign_env.objective.contact:ContactEstimator.from_spec")
register_estimator(
    "trajectory", "tooldesign_env.objective.trajectory:TrajectoryEstimator.from_spec"
)
register_estimator(
    "resimulation", "tooldesign_env.objective.resimulation:ResimulationEstimator.from_spec"
)
register_objective("free-energy", "tooldesign_env.objective.energy:FreeEnergy.from_spec")
register_objective(
    "expected-goal-error",
    "tooldesign_env.objective.expected_goal_error:ExpectedGoalError.from_spec",
)

BUILTIN_ESTIMATORS: tuple[str, ...] = estimator_names()
BUILTIN_OBJECTIVES: tuple[str, ...] = objective_names()
