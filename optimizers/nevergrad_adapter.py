"""``nevergrad``: the optimizers of Nevergrad's registry through its ask/tell interface.

An adapter, to show that the interface fits other libraries: the parametrization is an
``ng.p.Array`` in the unit box with its own ``numpy.random.RandomState`` seeded from the
optimizer's generator, ``num_workers`` is the batch size, and each point is one Nevergrad
candidate told with ``optimizer.tell(candidate, value)``. Three things make more of the registry
work than a plain wrapper would:

- a budget is rounded up to whole batches, since the run asks whole batches (Nevergrad's
  sequence samplers, ``HaltonSearch`` and the like, fail past their budget);
- optimizers that draw from ``np.random`` themselves (lognormal mutations, ``Rescaled``, ...)
  draw from a stream of their own (:class:`~optimizers.GlobalRandomState`), so they are
  reproducible and leave the caller's ``np.random`` alone;
- a backend that cannot be pickled (the scipy-based ``Powell``, ``Cobyla``, ``BFGS``, ... run
  in a thread) is saved as its seeds and the log of asks and tells, and rebuilt on loading by
  replaying them, each replayed point checked against the logged one.

Which names it takes is measured, not guessed. ``tests/nevergrad_survey.py`` ran the 542 names
of the registry of nevergrad 1.0.12 (numpy 2.4.6, scipy 1.17.1, scikit-learn 1.9.1) through the
adapter in 3 dimensions, batch sizes 1, 4 and 8, without a budget and with budgets 20, 60 and
200, and required each to ask and tell up to its budget, ask the same points again under the
same seed and in another process, and continue with the same points after ``save_state`` and
``load_state``; ``optimizers/_nevergrad_support.py`` holds what failed. The rule:

1. ``FAILS`` (169 names) are refused whatever the settings, with the reason measured: 119 raise
   ``TypeError`` on numpy 2 (``float()`` of a 1-element array in a meta-model step; among them
   41 of the 52 meta-optimizers, ``NGOpt``, ``NGOptRW``, ``Wiz`` and ``NgIoh`` too, which pick
   such a step for some budget), 27 need a package that is not installed (``nlopt``,
   ``bayes_optim``, ``fcmaes``, ``pymoo``, ``ax``, ...), 16 are not reproducible (in the same
   process, across processes as they depend on Python's hash seed, or after loading in another
   process; ``CmaFmin2`` and what chains it reseed from the clock) and 7 are too slow to be
   checked (``BO``, ``BOSplit``, ``NGOptF``, ...: over 90 s for the survey's runs).
2. ``NEEDS_BUDGET`` (71 names) without a budget, and any other meta-optimizer (a subclass of
   ``NGOptBase``, for names of another Nevergrad version) without a budget.
3. ``SEQUENTIAL`` (32 names, e.g. ``Powell``, ``Cobyla``, ``NGOpt16``) with ``batch_size > 1``.

Each refusal is a ``ValueError`` naming the optimizer, why, and what to use instead. The other
275 names passed in every setting. The meta-optimizers taken are ``Shiwa``, ``NGO``,
``NgIohRW2``, ``NGOptBase`` and ``NGOptDSBase`` with a budget, and ``NGOpt16`` and ``NGOpt36``
with a budget and ``batch_size=1``; they also passed in 2, 5 and 8 dimensions with budgets 300
to 1000, but a meta-optimizer picks its sub-optimizer from the dimension, budget and batch size,
so settings far from the survey's may meet a step it did not. 46 of the 373 names taken
(``HaltonSearch``, ``Powell`` and the like) ask the same first points whatever the seed. A name
Nevergrad itself cannot build is a ``ValueError`` too. After upgrading Nevergrad, run the survey
again (``--table`` rewrites the table).
"""

from __future__ import annotations

import pickle
from typing import Any

import numpy as np

from . import _nevergrad_support as _support
from ._imports import import_optional
from ._rng import GlobalRandomState
from .base import Optimizer

__all__ = ["NevergradOptimizer"]

_ALTERNATIVES = "use 'TwoPointsDE' (the default), 'CMA', 'PSO' or 'OnePlusOne'"


class NevergradOptimizer(Optimizer):
    """A Nevergrad optimizer in the unit box.

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        optimizer: Name in ``nevergrad.optimizers.registry``, e.g. ``"TwoPointsDE"``, ``"CMA"``,
            ``"PSO"``, ``"OnePlusOne"``; names measured not to work are refused (see above).
        budget: Total evaluations the run will make (some Nevergrad optimizers adapt to it,
            some need it), rounded up to whole batches; or None.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        DependencyNotInstalled: Nevergrad is missing (``pip install tooldesign[nevergrad]``).
        TypeError: A setting of the wrong type.
        ValueError: An unknown optimizer name, a budget < 1, or an optimizer that cannot work
            with these settings (the rule above): the message names it, says why and what to
            use instead.
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
        reason = _refusal(ng, optimizer, budget, self.batch_size)
        if reason is not None:
            raise ValueError(f"optimizer {optimizer!r} {reason}")
        if budget is not None:  # the run asks whole batches
            budget = -(-budget // self.batch_size) * self.batch_size
        # What rebuilds the backend: name, budget, seeds of the parametrization and np.random.
        self._spec = (
            optimizer,
            budget,
            int(self._rng.integers(2**32)),
            int(self._rng.integers(2**32)),
        )
        # Every ask (id, point) and tell (id, value), to replay into a rebuilt backend.
        self._log: list[tuple[int, np.ndarray | float]] | None = []
        self._build()

    def _build(self) -> None:
        """A new Nevergrad optimizer from ``_spec``, no candidate pending."""
        ng = import_optional("nevergrad", purpose="the 'nevergrad' optimizer")
        name, budget, seed, global_seed = self._spec
        parametrization = ng.p.Array(shape=(self.n_dims,), lower=0.0, upper=1.0)
        parametrization.random_state = np.random.RandomState(seed)
        # Some Nevergrad optimizers draw from np.random itself: give them a stream of their own.
        self._global = GlobalRandomState(global_seed)
        try:
            with self._global.active():
                self._optimizer = ng.optimizers.registry[name](
                    parametrization=parametrization, budget=budget, num_workers=self.batch_size
                )
        except Exception as error:  # a name the table does not know (another Nevergrad version)
            raise ValueError(
                f"optimizer {name!r} could not be made with budget={budget}, batch_size="
                f"{self.batch_size} ({type(error).__name__}: {error}); {_ALTERNATIVES}"
            ) from error
        self._candidates: dict[int, Any] = {}  # id -> pending candidate

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        with self._global.active():
            return np.array([self._ask_one(i) for i in ids])

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        with self._global.active():
            for i, value in zip(ids, values, strict=True):
                self._tell_one(i, float(value))

    def _ask_one(self, i: int) -> np.ndarray:
        """One candidate for id ``i``, logged; inside ``self._global.active()``."""
        candidate = self._optimizer.ask()
        self._candidates[i] = candidate
        point = np.array(candidate.value, dtype=np.float64)
        if self._log is not None:
            self._log.append((i, point))
        return point

    def _tell_one(self, i: int, value: float) -> None:
        """The value of id ``i`` to the backend, logged; inside ``self._global.active()``."""
        self._optimizer.tell(self._candidates.pop(i), value)
        if self._log is not None:
            self._log.append((i, value))

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        del state["_optimizer"], state["_candidates"]
        try:  # the backend and its pending candidates together, so that they stay linked
            state["_backend"] = pickle.dumps(
                (self._optimizer, self._candidates), protocol=pickle.HIGHEST_PROTOCOL
            )
        except (TypeError, ValueError, AttributeError, pickle.PicklingError) as error:
            # Nevergrad's scipy-based optimizers run in a thread, which cannot be pickled: they
            # are rebuilt from the seeds and replayed (their own replay starts elsewhere).
            if self._log is None:
                raise TypeError(f"the Nevergrad optimizer cannot be pickled: {error}") from error
            state["_backend"] = None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        backend = state.pop("_backend", None)
        self.__dict__.update(state)
        if "_spec" not in state:  # saved before backends were rebuilt: the backend is in state
            self._global = GlobalRandomState(0)
            self._log = None
        elif backend is not None:
            self._optimizer, self._candidates = pickle.loads(backend)
        else:
            self._replay()

    def _replay(self) -> None:
        """Rebuild the backend and give it the asks and tells of the log again."""
        self._build()
        log, self._log = self._log or [], None  # the replay must not add to the log
        try:
            with self._global.active():
                for k, (i, entry) in enumerate(log):
                    if isinstance(entry, float):
                        self._tell_one(i, entry)
                        continue
                    point = self._ask_one(i)
                    if not np.array_equal(point, entry):
                        raise RuntimeError(
                            f"the Nevergrad optimizer {self._spec[0]!r} asked another point when "
                            f"replayed (event {k} of {len(log)}): {point} instead of {entry}; it "
                            "is not reproducible with these package versions"
                        )
        finally:
            self._log = log

    def _backend_versions(self) -> dict[str, str]:
        from importlib.metadata import version

        return {"nevergrad": version("nevergrad")}


def _refusal(ng: Any, name: str, budget: int | None, batch_size: int) -> str | None:
    """Why ``name`` cannot work with these settings and what to do instead, or None.

    The rule of the module docstring: the measured table first, then, for names it does not
    know (another Nevergrad version), the class rule for meta-optimizers.
    """
    measured = f"measured on nevergrad {_support.MEASURED_ON['nevergrad']}"
    if name in _support.FAILS:
        return f"{_support.FAILS[name]} ({measured}); {_ALTERNATIVES}"
    cls = ng.optimizers.registry[name]
    meta = isinstance(cls, type) and issubclass(cls, ng.optimizers.NGOptBase)
    if budget is None and (name in _support.NEEDS_BUDGET or meta):
        return f"fails without a budget ({measured}); give budget=..., or {_ALTERNATIVES}"
    if batch_size > 1 and name in _support.SEQUENTIAL:
        return (
            f"proposes one point at a time and fails with batch_size={batch_size} ({measured}); "
            f"give batch_size=1, or {_ALTERNATIVES}"
        )
    return None
