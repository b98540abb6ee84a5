"""``cmaes``: CMA-ES on pycma's ``CMAEvolutionStrategy`` ask/tell, the paper's designer.

pycma's own ``seed`` option reseeds numpy's *global* generator (and ``seed=0`` means the clock),
so two instances would interfere. Here the Gaussian samples come from the optimizer's own
``numpy.random.Generator`` through pycma's ``randn`` option, and every backend call runs with a
private ``np.random`` state swapped in (for the few other draws pycma makes), so instances are
independent of each other and of the caller's ``np.random``. pycma writes no ``outcmaes/`` files:
``verbose=-9`` and ``verb_log=0``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._rng import GlobalRandomState
from .base import Optimizer

__all__ = ["CMAES"]

#: Smallest initial step, a fraction of the box (the rl suite's CMA-ES uses the same limit).
SIGMA0_MIN = 1e-6


class _Randn:
    """pycma's ``randn(*shape)`` drawing from one generator (a picklable callable)."""

    def __init__(self, generator: np.random.Generator) -> None:
        self.generator = generator

    def __call__(self, *shape: int) -> np.ndarray:
        return self.generator.standard_normal(size=shape)


class CMAES(Optimizer):
    """CMA-ES (Hansen's pycma) in the unit box with its bounds [0, 1] per dimension.

    Generational: ``batch_size`` is the population size lambda, and every point of a generation
    must be told before the next ask. The backend works in the unit box, so one sigma fits all
    dimensions whatever their physical ranges; pycma's ``BoundTransform`` keeps the samples in
    the box. Needs d >= 2 and batch_size >= 2 (pycma's limits).

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        sigma0: Initial step size as a fraction of the box width, in [1e-6, 1]; 0.3 puts most
            of the first generation inside the box around the centre. Below 1e-6 the step is
            lost in rounding (pycma's update overflows from 1e-300 and 1e-320 failed its
            assertion after the first generation).
        x0: (d,) initial mean in physical units, inside the bounds; the box centre if None.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        TypeError: sigma0 or x0 of the wrong type.
        ValueError: sigma0 outside [1e-6, 1] or x0 outside the bounds.
    """

    generational = True
    min_batch_size = 2
    min_dims = 2

    def __init__(
        self, bounds: Any = None, *, sigma0: float = 0.3, x0: Any = None, **kwargs: Any
    ) -> None:
        super().__init__(bounds, **kwargs)
        if isinstance(sigma0, bool) or not isinstance(sigma0, (int, float, np.number)):
            raise TypeError(f"sigma0 must be a number, got {sigma0!r}")
        if not (math.isfinite(sigma0) and SIGMA0_MIN <= sigma0 <= 1):
            raise ValueError(
                f"sigma0 must be in [{SIGMA0_MIN:g}, 1] (a fraction of the box), got {sigma0!r}"
            )
        mean = np.full(self.n_dims, 0.5) if x0 is None else self._to_unit(x0, "x0")
        import cma  # a core dependency, imported here to keep `import optimizers` light

        self._global = GlobalRandomState(int(self._rng.integers(2**32)))
        options = {
            "popsize": self.batch_size,
            "bounds": [0.0, 1.0],
            "randn": _Randn(self._rng),
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
        }
        with self._global.active():
            self._es = cma.CMAEvolutionStrategy(mean, float(sigma0), options)
        self._asked: list[np.ndarray] = []

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        with self._global.active():
            self._asked = self._es.ask()
        return np.array(self._asked)

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        # pycma wants back the very solutions it asked (ids arrive in ask order).
        with self._global.active():
            self._es.tell(self._asked, [float(v) for v in values])
        self._asked = []

    def _backend_versions(self) -> dict[str, str]:
        import cma

        return {"cma": str(cma.__version__)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        # pycma files the solutions it asked under hash(x.tobytes()), which Python salts per
        # process: unpickled in another process, a pending generation would no longer be found
        # and pycma would take the told solutions for foreign ("injected") ones, so the run
        # would continue otherwise than uninterrupted. File them again under this process's hash.
        self.__dict__.update(state)
        _rehash_solution_dicts(self._es)


def _rehash_solution_dicts(root: Any) -> None:
    """Re-key every pycma ``SolutionDict`` reachable from ``root`` with this process's hash."""
    from cma.utilities.utils import SolutionDict

    seen: set[int] = set()
    stack = [root]
    while stack:
        obj = stack.pop()
        if id(obj) in seen:
            continue
        seen.add(id(obj))
        if isinstance(obj, SolutionDict):
            remap = {old: obj.key(x) for old, x in obj._unhashed_keys.items()}
            obj.data = {remap.get(k, k): v for k, v in obj.data.items()}
            obj.data_with_same_key = {remap.get(k, k): v for k, v in obj.data_with_same_key.items()}
            obj._unhashed_keys = {remap[k]: x for k, x in obj._unhashed_keys.items()}
            continue
        # Only pycma's own objects are searched: its solution dicts hang off them.
        if type(obj).__module__.split(".")[0] == "cma":
            stack.extend(vars(obj).values() if hasattr(obj, "__dict__") else ())
