"""optimizers: ask/tell optimizers in a box of numbers, behind one interface and a registry.

Numbers only: this package never imports PyBullet, Gymnasium or ``tooldesign_env``.

>>> import optimizers
>>> opt = optimizers.make("random", bounds=[[-1.0, 1.0], [0.0, 2.0]], batch_size=4, seed=0)
>>> batch = opt.ask()
>>> opt.tell(batch.ids, [float(sum(x**2)) for x in batch.x])
>>> opt.recommend().value >= 0.0
True

Built-ins: ``cmaes`` (pycma), ``bo`` (scikit-optimize, extra ``bo``), ``pso`` (pyswarms, extra
``pso``), ``random``; adapters ``optuna-tpe``, ``optuna-cmaes`` (extra ``optuna``) and
``nevergrad`` (extra ``nevergrad``). Plugins from other packages arrive through the entry-point
group ``tooldesign.optimizers``; see ``docs/optimizer-plugins.md``.

Limits every optimizer enforces (callers that check input early import them from here):
``BOUND_MAX`` (largest magnitude of a bound), ``BATCH_SIZE_MAX``, ``SEED_MAX`` (int64) and
``VALUE_MAX`` (largest magnitude of a told value); ``check_bounds`` validates a box.
"""

from __future__ import annotations

from ._imports import DependencyNotInstalled
from ._rng import GlobalRandomState
from ._validation import BATCH_SIZE_MAX, BOUND_MAX, SEED_MAX, VALUE_MAX, check_bounds
from .base import (
    Batch,
    FailurePolicy,
    Optimizer,
    OptimizerStateError,
    PluginError,
    Recommendation,
)
from .registry import available, make, register

__all__ = [
    "BATCH_SIZE_MAX",
    "BOUND_MAX",
    "SEED_MAX",
    "VALUE_MAX",
    "Batch",
    "DependencyNotInstalled",
    "FailurePolicy",
    "GlobalRandomState",
    "Optimizer",
    "OptimizerStateError",
    "PluginError",
    "Recommendation",
    "available",
    "check_bounds",
    "make",
    "register",
]
