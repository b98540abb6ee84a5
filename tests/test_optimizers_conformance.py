"""Every available optimizer passes the conformance suite and beats random sampling.

Parametrized over ``optimizers.available()``: a new plugin (registered or installed through the
entry-point group) is tested here without new test code.
"""

from __future__ import annotations

import functools
import importlib.util

import numpy as np
import pytest

import optimizers
from optimizers import testing

NAMES = optimizers.available()

# Rosenbrock in 3-D on the tool's coefficient box [-1.5, 1.5]^2 x [-0.5, 0.5]; its minimum
# (1, 1, 1) lies outside, so the best point is on the boundary x3 = 0.5.
ROSENBROCK_BOUNDS = np.array([[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]])


def rosenbrock(x: np.ndarray) -> np.ndarray:
    return np.sum(100.0 * (x[:, 1:] - x[:, :-1] ** 2) ** 2 + (1.0 - x[:, :-1]) ** 2, axis=1)


def best_after(name: str, seed: int, iterations: int = 15, batch_size: int = 8) -> float:
    optimizer = optimizers.make(name, bounds=ROSENBROCK_BOUNDS, batch_size=batch_size, seed=seed)
    for _ in range(iterations):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, rosenbrock(batch.x))
    return optimizer.recommend().value


def test_builtins_are_available_when_their_backend_is_installed() -> None:
    assert {"cmaes", "random"} <= set(NAMES)
    backends = {"bo": "skopt", "pso": "pyswarms", "optuna-tpe": "optuna", "nevergrad": "nevergrad"}
    for name, module in backends.items():
        # find_spec, not import: importing pyswarms writes report.log into the working folder
        assert (name in NAMES) == (importlib.util.find_spec(module) is not None)


@pytest.mark.parametrize("check", testing.CHECKS, ids=lambda check: check.__name__)
@pytest.mark.parametrize("name", NAMES)
def test_conformance(name: str, check: testing.Factory) -> None:
    check(functools.partial(optimizers.make, name))


@pytest.mark.parametrize("name", [n for n in NAMES if n != "random"])
def test_beats_random_sampling_on_rosenbrock(name: str) -> None:
    # Equal budget (15 iterations of 8), five seeds, compared by the median best value.
    seeds = range(5)
    median = np.median([best_after(name, seed) for seed in seeds])
    baseline = np.median([best_after("random", seed) for seed in seeds])
    assert median < baseline, f"{name}: median best {median:.4g} vs random {baseline:.4g}"


def test_check_optimizer_runs_every_check_and_names_the_failing_one() -> None:
    testing.check_optimizer(functools.partial(optimizers.make, "random"))

    class Leaky(optimizers.Optimizer):
        def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
            return np.random.random((len(ids), self.n_dims))  # noqa: NPY002 - the global RNG: the bug

        def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
            pass

    with pytest.raises(AssertionError, match="check_same_seed_same_asks"):
        testing.check_optimizer(Leaky)
    with pytest.raises(ValueError, match="unknown checks"):
        testing.check_optimizer(Leaky, skip={"check_nothing"})
