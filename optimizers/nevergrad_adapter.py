"""``nevergrad``: any optimizer of Nevergrad's registry through its ask/tell interface.

An adapter, to show that the interface fits other libraries: the parametrization is an
``ng.p.Array`` in the unit box with its own ``numpy.random.RandomState`` seeded from the
optimizer's generator, ``num_workers`` is the batch size, and each point is one Nevergrad
candidate told with ``optimizer.tell(candidate, value)``.

The default is ``TwoPointsDE``, not ``NGOpt``: with nevergrad 1.0.12 on numpy 2, NGOpt (and
NGOptRW) pick for most budgets a meta-model step that raises ``TypeError`` (``float()`` of a
1-element array), a scipy-based optimizer run in a thread that cannot be pickled, or a meta-model
limited by a 20 s wall-clock timer (not reproducible); without a budget it fails an assertion.
So ``optimizer="NGOpt"`` and ``"NGOptRW"`` are refused with a ``ValueError``, and so is every
other meta-optimizer of Nevergrad (a subclass of ``NGOptBase``: ``Wiz``, ``NgIoh``, ``Shiwa``,
...) without a budget, where each fails that assertion at the first ask.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._imports import import_optional
from .base import Optimizer

__all__ = ["NevergradOptimizer"]

#: Optimizers that fail at the first ask whatever the budget (nevergrad 1.0.12 on numpy 2).
BROKEN = ("NGOpt", "NGOptRW")
_ALTERNATIVES = "use 'TwoPointsDE' (the default), 'CMA', 'PSO' or 'OnePlusOne'"


class NevergradOptimizer(Optimizer):
    """A Nevergrad optimizer in the unit box.

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        optimizer: Name in ``nevergrad.optimizers.registry``, e.g. ``"TwoPointsDE"``, ``"CMA"``,
            ``"PSO"``, ``"OnePlusOne"``.
        budget: Total evaluations the run will make (some Nevergrad optimizers adapt to it), or
            None.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        DependencyNotInstalled: Nevergrad is missing (``pip install tooldesign[nevergrad]``).
        TypeError: A setting of the wrong type.
        ValueError: An unknown optimizer name, a budget < 1, ``"NGOpt"`` or ``"NGOptRW"``
            (broken on numpy 2, see above), or another meta-optimizer (``NGOptBase``) without a
            budget.
    """

    def __init__(
        self,
        bounds: Any = None,
        *,
        optimizer: str = "TwoPointsDE",
        budget: int | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(bounds, **kwargs)
        ng = import_optional("nevergrad", purpose="the 'nevergrad' optimizer")
        if not isinstance(optimizer, str):
            raise TypeError(f"optimizer must be a str, got {optimizer!r}")
        if optimizer not in ng.optimizers.registry:
            raise ValueError(
                f"optimizer {optimizer!r} is not in nevergrad.optimizers.registry (e.g. "
                "'TwoPointsDE', 'CMA', 'PSO', 'OnePlusOne')"
            )
        if budget is not None:
            if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)):
                raise TypeError(f"budget must be an int or None, got {budget!r}")
            if budget < 1:
                raise ValueError(f"budget must be >= 1, got {budget}")
            budget = int(budget)
        if optimizer in BROKEN:
            raise ValueError(
                f"optimizer {optimizer!r} fails on numpy 2 (its meta-model steps raise TypeError, "
                f"run unpicklable threads or a wall-clock timer); {_ALTERNATIVES}"
            )
        meta = ng.optimizers.registry[optimizer]
        if budget is None and isinstance(meta, type) and issubclass(meta, ng.optimizers.NGOptBase):
            raise ValueError(
                f"optimizer {optimizer!r} is a Nevergrad meta-optimizer and needs a budget "
                "(without one it fails an assertion at the first ask): give budget=..., or "
                f"{_ALTERNATIVES}"
            )
        parametrization = ng.p.Array(shape=(self.n_dims,), lower=0.0, upper=1.0)
        parametrization.random_state = np.random.RandomState(int(self._rng.integers(2**32)))
        self._optimizer = ng.optimizers.registry[optimizer](
            parametrization=parametrization, budget=budget, num_workers=self.batch_size
        )
        self._candidates: dict[int, Any] = {}  # id -> pending candidate

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        rows = []
        for i in ids:
            candidate = self._optimizer.ask()
            self._candidates[i] = candidate
            rows.append(np.asarray(candidate.value, dtype=np.float64))
        return np.array(rows)

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        for i, value in zip(ids, values, strict=True):
            self._optimizer.tell(self._candidates.pop(i), float(value))

    def _backend_versions(self) -> dict[str, str]:
        from importlib.metadata import version

        return {"nevergrad": version("nevergrad")}
