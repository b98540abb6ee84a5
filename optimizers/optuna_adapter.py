"""``optuna-tpe`` and ``optuna-cmaes``: Optuna samplers through its ask-and-tell interface.

An adapter, to show that the interface fits other libraries: each point is one Optuna trial
with d float parameters in [0, 1] (the unit box), asked with ``study.ask(fixed_distributions)``
and told with ``study.tell(trial, value)``. Failures are told as the penalty, like every backend
(Optuna could take ``TrialState.FAIL``, but then TPE and CMA-ES would ignore the failed region).
Optuna's INFO log lines are silenced during backend calls, and its level restored after.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from ._imports import import_optional
from .base import Optimizer
from .cmaes import SIGMA0_MIN

__all__ = ["OptunaCMAES", "OptunaTPE"]

_PURPOSE = "the Optuna adapter"


@contextmanager
def _quiet_optuna() -> Iterator[Any]:
    optuna = import_optional("optuna", purpose=_PURPOSE)
    level = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        with warnings.catch_warnings():
            # Settings like constant_liar are marked experimental; they are chosen on purpose.
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            yield optuna
    finally:
        optuna.logging.set_verbosity(level)


class _OptunaAdapter(Optimizer):
    """An Optuna study driven by ask/tell in the unit box; subclasses choose the sampler."""

    def __init__(self, bounds: Any = None, **kwargs: Any) -> None:
        super().__init__(bounds, **kwargs)
        with _quiet_optuna() as optuna:
            self._study = optuna.create_study(
                direction="minimize", sampler=self._sampler(optuna, int(self._rng.integers(2**31)))
            )
            self._distributions = {
                f"x{i}": optuna.distributions.FloatDistribution(0.0, 1.0)
                for i in range(self.n_dims)
            }
        self._trials: dict[int, Any] = {}  # id -> pending optuna Trial

    def _sampler(self, optuna: Any, seed: int) -> Any:
        raise NotImplementedError

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        rows = []
        with _quiet_optuna():
            for i in ids:
                trial = self._study.ask(self._distributions)
                self._trials[i] = trial
                rows.append([trial.params[name] for name in self._distributions])
        return np.array(rows)

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        with _quiet_optuna():
            for i, value in zip(ids, values, strict=True):
                self._study.tell(self._trials.pop(i), float(value))

    def _backend_versions(self) -> dict[str, str]:
        from importlib.metadata import version

        return {"optuna": version("optuna")}


class OptunaTPE(_OptunaAdapter):
    """Optuna's TPE sampler (multivariate, constant liar for pending trials).

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        n_startup_trials: Random trials before TPE starts, >= 0.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        DependencyNotInstalled: Optuna is missing (``pip install tooldesign[optuna]``).
    """

    def __init__(self, bounds: Any = None, *, n_startup_trials: int = 10, **kwargs: Any) -> None:
        if isinstance(n_startup_trials, bool) or not isinstance(n_startup_trials, int):
            raise TypeError(f"n_startup_trials must be an int, got {n_startup_trials!r}")
        if n_startup_trials < 0:
            raise ValueError(f"n_startup_trials must be >= 0, got {n_startup_trials}")
        self._n_startup_trials = n_startup_trials
        super().__init__(bounds, **kwargs)

    def _sampler(self, optuna: Any, seed: int) -> Any:
        return optuna.samplers.TPESampler(
            seed=seed,
            n_startup_trials=self._n_startup_trials,
            multivariate=True,
            constant_liar=True,
        )


class OptunaCMAES(_OptunaAdapter):
    """Optuna's CMA-ES sampler (the ``cmaes`` package) with population size ``batch_size``.

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        sigma0: Initial step size in the unit box, in [1e-6, 1] like ``cmaes``'s (a fraction of
            the box; an int, float or numpy real number); Optuna's default if None.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        DependencyNotInstalled: Optuna or cmaes is missing (``pip install tooldesign[optuna]``).
        TypeError: sigma0 not a real number or None.
        ValueError: sigma0 outside [1e-6, 1].
    """

    min_batch_size = 2
    min_dims = 2

    def __init__(self, bounds: Any = None, *, sigma0: float | None = None, **kwargs: Any) -> None:
        if sigma0 is not None:
            if isinstance(sigma0, (bool, np.bool_)) or not isinstance(
                sigma0, (int, float, np.integer, np.floating)
            ):
                raise TypeError(f"sigma0 must be a number or None, got {sigma0!r}")
            if not (math.isfinite(sigma0) and SIGMA0_MIN <= sigma0 <= 1):
                raise ValueError(
                    f"sigma0 must be in [{SIGMA0_MIN:g}, 1] (a fraction of the box), got {sigma0!r}"
                )
            sigma0 = float(sigma0)
        self._sigma0 = sigma0
        import_optional("cmaes", purpose="the 'optuna-cmaes' optimizer")
        super().__init__(bounds, **kwargs)

    def _sampler(self, optuna: Any, seed: int) -> Any:
        # Until a trial is complete Optuna knows no search space and samples the first points
        # independently (uniformly): expected here, so not warned about.
        return optuna.samplers.CmaEsSampler(
            seed=seed,
            sigma0=self._sigma0,
            popsize=self.batch_size,
            n_startup_trials=0,
            warn_independent_sampling=False,
        )

    def _backend_versions(self) -> dict[str, str]:
        from importlib.metadata import version

        return {**super()._backend_versions(), "cmaes": version("cmaes")}
