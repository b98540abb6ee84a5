"""``pso``: particle swarm optimization on pyswarms' backend, driven one generation at a time.

pyswarms has no ask/tell, so this plugin runs its backend step by step: ``create_swarm`` for the
first generation, then per generation ``compute_pbest``, the topology's ``compute_gbest``
(on tell) and ``compute_velocity`` / ``compute_position`` (on the next ask).

pyswarms has two side effects this plugin keeps away from the caller:

- it draws from numpy's global generator: every backend call runs with the optimizer's private
  ``np.random`` state swapped in;
- importing it, and constructing its topologies and handlers, calls ``logging.config.dictConfig``,
  which adds handlers to the root logger and creates ``report.log`` in the working directory:
  those steps run with ``dictConfig`` replaced by a no-op. Saved states hold the swarm as plain
  arrays and the topology and handlers by name, so loading a state imports no pyswarms module
  (and the topology's logger, which holds a stream, need not be pickled).

The Pyramid and Random topologies are broken on current numpy and not offered.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from types import SimpleNamespace
from typing import Any

import numpy as np

from ._imports import import_optional
from ._rng import GlobalRandomState
from .base import Optimizer

__all__ = ["ParticleSwarm"]

TOPOLOGIES = ("star", "ring")
_SWARM_FIELDS = (
    "position",
    "velocity",
    "n_particles",
    "dimensions",
    "options",
    "pbest_pos",
    "best_pos",
    "pbest_cost",
    "best_cost",
    "current_cost",
)
BOUNDARY_STRATEGIES = ("nearest", "reflective", "periodic", "random")


def _ignore_config(*args: Any, **kwargs: Any) -> None:
    """Stands in for logging.config.dictConfig while pyswarms objects are made."""


@contextmanager
def _no_logging_config() -> Iterator[None]:
    import logging.config

    original = logging.config.dictConfig
    logging.config.dictConfig = _ignore_config
    try:
        yield
    finally:
        logging.config.dictConfig = original


def _pyswarms() -> SimpleNamespace:
    """The pyswarms backend modules, imported without touching the logging configuration."""
    purpose = "the 'pso' optimizer"
    with _no_logging_config():
        generators = import_optional("pyswarms.backend.generators", purpose=purpose)
        operators = import_optional("pyswarms.backend.operators", purpose=purpose)
        topology = import_optional("pyswarms.backend.topology", purpose=purpose)
        handlers = import_optional("pyswarms.backend.handlers", purpose=purpose)
        swarms = import_optional("pyswarms.backend.swarms", purpose=purpose)
    return SimpleNamespace(
        Swarm=swarms.Swarm,
        create_swarm=generators.create_swarm,
        compute_pbest=operators.compute_pbest,
        Star=topology.Star,
        Ring=topology.Ring,
        BoundaryHandler=handlers.BoundaryHandler,
        VelocityHandler=handlers.VelocityHandler,
    )


def _number(value: Any, name: str, low: float, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not (math.isfinite(value) and low <= value <= high):
        raise ValueError(f"{name} must be a finite number in [{low}, {high}], got {value!r}")
    return float(value)


class ParticleSwarm(Optimizer):
    """Global- or local-best PSO (pyswarms backend) in the unit box.

    Generational: ``batch_size`` is the number of particles; every particle of a generation must
    be told before the next ask. The defaults are the constriction coefficients of Clerc and
    Kennedy (w = 0.7298, c1 = c2 = 1.49618).

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        topology: ``"star"`` (global best) or ``"ring"`` (best of the ``neighbours`` nearest
            particles, recomputed every generation).
        c1: Cognitive coefficient (pull to the particle's own best), >= 0.
        c2: Social coefficient (pull to the neighbourhood's best), >= 0.
        w: Inertia weight, >= 0.
        velocity_clamp: (min, max) velocity per dimension in box widths, min < max; also the
            range of the initial velocities. None leaves velocities unclamped (and initial
            velocities in [0, 1), pyswarms' default).
        boundary: How particles leaving the box are put back: ``"nearest"``, ``"reflective"``,
            ``"periodic"`` or ``"random"``.
        neighbours: Ring topology: particles per neighbourhood (the particle included),
            2 <= neighbours <= batch_size; ``min(3, batch_size)`` if None.
        p_norm: Ring topology: Minkowski p of the neighbour distance, 1 or 2.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        TypeError: A setting of the wrong type.
        ValueError: A setting outside its range.
    """

    generational = True

    def __init__(
        self,
        bounds: Any = None,
        *,
        topology: str = "star",
        c1: float = 1.49618,
        c2: float = 1.49618,
        w: float = 0.7298,
        velocity_clamp: tuple[float, float] | None = (-0.5, 0.5),
        boundary: str = "reflective",
        neighbours: int | None = None,
        p_norm: int = 2,
        **kwargs: Any,
    ) -> None:
        super().__init__(bounds, **kwargs)
        if topology not in TOPOLOGIES:
            raise ValueError(f"topology must be one of {TOPOLOGIES}, got {topology!r}")
        if boundary not in BOUNDARY_STRATEGIES:
            raise ValueError(f"boundary must be one of {BOUNDARY_STRATEGIES}, got {boundary!r}")
        self._options = {
            "c1": _number(c1, "c1", 0.0),
            "c2": _number(c2, "c2", 0.0),
            "w": _number(w, "w", 0.0),
        }
        if velocity_clamp is not None:
            if not isinstance(velocity_clamp, (tuple, list)) or len(velocity_clamp) != 2:
                raise TypeError(
                    f"velocity_clamp must be (min, max) or None, got {velocity_clamp!r}"
                )
            lo = _number(velocity_clamp[0], "velocity_clamp[0]", -math.inf)
            hi = _number(velocity_clamp[1], "velocity_clamp[1]", -math.inf)
            if not lo < hi:
                raise ValueError(f"velocity_clamp needs min < max, got {velocity_clamp!r}")
            velocity_clamp = (lo, hi)
        self._clamp = velocity_clamp
        if topology == "ring":
            if neighbours is None:
                neighbours = min(3, self.batch_size)
            if isinstance(neighbours, bool) or not isinstance(neighbours, (int, np.integer)):
                raise TypeError(f"neighbours must be an int, got {neighbours!r}")
            if not 2 <= neighbours <= self.batch_size:
                raise ValueError(
                    f"neighbours must be in [2, batch_size={self.batch_size}] for the ring "
                    f"topology, got {neighbours}"
                )
            if p_norm not in (1, 2) or isinstance(p_norm, bool):
                raise ValueError(f"p_norm must be 1 or 2, got {p_norm!r}")
        self._topology = topology
        self._boundary = boundary
        self._neighbours = None if neighbours is None else int(neighbours)
        self._p_norm = int(p_norm)
        self._global = GlobalRandomState(int(self._rng.integers(2**32)))
        self._unit = (np.zeros(self.n_dims), np.ones(self.n_dims))
        self._swarm: Any = None
        self._started = False
        self._tools_cache: tuple[SimpleNamespace, Any, Any, Any] | None = None
        self._tools()  # fail now, not at the first ask, if pyswarms is missing

    def _tools(self) -> tuple[SimpleNamespace, Any, Any, Any]:
        """The backend, topology, boundary and velocity handlers (rebuilt after loading)."""
        if self._tools_cache is None:
            ps = _pyswarms()
            with _no_logging_config():
                topology = ps.Star() if self._topology == "star" else ps.Ring(static=False)
                boundary = ps.BoundaryHandler(strategy=self._boundary)
                velocity = ps.VelocityHandler(strategy="unmodified")
            self._tools_cache = (ps, topology, boundary, velocity)
        return self._tools_cache

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_tools_cache"] = None
        if self._swarm is not None:
            state["_swarm"] = None
            state["_swarm_fields"] = {name: getattr(self._swarm, name) for name in _SWARM_FIELDS}
        return state

    def _live_swarm(self) -> Any:
        """The pyswarms Swarm, rebuilt from plain arrays after loading a state."""
        fields = self.__dict__.pop("_swarm_fields", None)
        if fields is not None:
            ps = self._tools()[0]
            self._swarm = ps.Swarm(**fields)
        return self._swarm

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        ps, topology, boundary, velocity = self._tools()
        swarm = self._live_swarm()
        with self._global.active():
            if swarm is None:
                self._swarm = ps.create_swarm(
                    n_particles=len(ids),
                    dimensions=self.n_dims,
                    options=dict(self._options),
                    bounds=self._unit,
                    clamp=self._clamp,
                )
            else:
                swarm.velocity = topology.compute_velocity(
                    swarm, clamp=self._clamp, vh=velocity, bounds=self._unit
                )
                swarm.position = topology.compute_position(swarm, bounds=self._unit, bh=boundary)
        return np.array(self._swarm.position)

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        ps, topology, _, _ = self._tools()
        swarm = self._live_swarm()
        with self._global.active():
            swarm.current_cost = np.array(values)
            if not self._started:
                # The first generation is every particle's best: no inf placeholder needed.
                swarm.pbest_pos = np.array(swarm.position)
                swarm.pbest_cost = np.array(values)
                self._started = True
            else:
                swarm.pbest_pos, swarm.pbest_cost = ps.compute_pbest(swarm)
            if self._topology == "star":
                swarm.best_pos, swarm.best_cost = topology.compute_gbest(swarm)
            else:
                swarm.best_pos, swarm.best_cost = topology.compute_gbest(
                    swarm, p=self._p_norm, k=self._neighbours
                )

    def _backend_versions(self) -> dict[str, str]:
        from importlib.metadata import version  # not `import pyswarms`: see the module docstring

        return {"pyswarms": version("pyswarms")}
