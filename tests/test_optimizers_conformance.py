"""Every available optimizer passes the conformance suite and beats random sampling.

Parametrized over ``optimizers.available()``: a new plugin (registered or installed through the
entry-point group) is tested here without new test code, and the checks its class lists in
``conformance_skip`` (``check_seed_changes_asks`` for a deterministic method) are skipped.
"""

from __future__ import annotations

import functools
import importlib.util
import inspect
import os
import subprocess
import sys
import threading
import unittest
from pathlib import Path

import numpy as np
import pytest

import optimizers
from optimizers import testing

NAMES = optimizers.available()
ROOT = Path(__file__).resolve().parents[1]
#: The optimizers whose checks run in the default tier: the built-in ones that need NumPy only.
#: The adapters to other libraries (scikit-optimize's GP, Optuna, Nevergrad, PySwarms) take
#: seconds per check and run with --all.
FAST = {"random", "cmaes"}


def _tiered(names: list[str]) -> list[object]:
    return [n if n in FAST else pytest.param(n, marks=pytest.mark.slow) for n in names]

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
@pytest.mark.parametrize("name", _tiered(NAMES))
def test_conformance(name: str, check: testing.Factory) -> None:
    check(functools.partial(optimizers.make, name))


@pytest.mark.parametrize("name", _tiered([n for n in NAMES if n != "random"]))
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


# --- plugins that declare checks inapplicable ----------------------------------------------


class Compass(optimizers.Optimizer):
    """Compass search: polls +-step along each axis around the best point; deterministic."""

    generational = True
    conformance_skip = ("check_seed_changes_asks",)

    def __init__(self, bounds=None, **kwargs):  # type: ignore[no-untyped-def]
        super().__init__(bounds, **kwargs)
        self._step = 0.25
        self._center = np.full(self.n_dims, 0.5)
        self._center_value = np.inf
        self._queue: list[np.ndarray] = []

    def _ask(self, ids):  # type: ignore[no-untyped-def]
        while len(self._queue) < len(ids):
            for axis in range(self.n_dims):
                for sign in (1.0, -1.0):
                    point = self._center.copy()
                    point[axis] += sign * self._step
                    self._queue.append(np.clip(point, 0.0, 1.0))
        points, self._queue = self._queue[: len(ids)], self._queue[len(ids) :]
        return np.array(points)

    def _tell(self, ids, x, values, failed):  # type: ignore[no-untyped-def]
        k = int(np.argmin(values))
        if values[k] < self._center_value:
            self._center, self._center_value = x[k].copy(), float(values[k])
        else:
            self._step *= 0.5


class Undeclared(Compass):
    conformance_skip = ()


class Misspelt(Compass):
    conformance_skip = ("check_seed_changes_ask",)


class NotATuple(Compass):
    conformance_skip = "check_seed_changes_asks"  # type: ignore[assignment]


def test_a_declared_check_is_skipped_and_the_others_run() -> None:
    with pytest.raises(AssertionError, match="check_seed_changes_asks"):
        testing.check_optimizer(Undeclared)  # without the declaration the method fails it
    for factory in (Compass, functools.partial(optimizers.make, f"{__name__}:Compass")):
        assert testing.declared_skips(factory) == {"check_seed_changes_asks"}
        testing.check_optimizer(factory)
        with pytest.raises(unittest.SkipTest) as excinfo:  # pytest reports it as a skip
            testing.check_seed_changes_asks(factory)
        assert f"{__name__}.Compass.conformance_skip" in str(excinfo.value)
        testing.check_same_seed_same_asks(factory)  # the others still run


@pytest.mark.parametrize(
    ("cls", "error", "match"),
    [
        (
            Misspelt,
            ValueError,
            r"Misspelt.conformance_skip names unknown checks "
            r"\['check_seed_changes_ask'\]; known: \['check_asks_inside_bounds'",
        ),
        (
            NotATuple,
            TypeError,
            r"NotATuple.conformance_skip must be a tuple of check names, "
            r"got 'check_seed_changes_asks'",
        ),
    ],
)
def test_a_bad_declaration_is_refused_by_every_check(cls, error, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error, match=match):
        testing.check_optimizer(cls)
    for check in (testing.check_seed_changes_asks, testing.check_counts):
        with pytest.raises(error, match=match):
            check(cls)
    with pytest.raises(error, match=match):
        testing.declared_skips(cls)


@pytest.mark.slow
def test_this_suite_skips_what_an_installed_plugin_declares(tmp_path: Path) -> None:
    # A deterministic plugin installed through its entry point used to fail this very file.
    site = tmp_path / "site"
    info = site / "detcompass-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: detcompass\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[tooldesign.optimizers]\ndetcompass = detcompass:Compass\n"
    )
    source = "import numpy as np\n\nimport optimizers\n\n\n" + inspect.getsource(Compass)
    (site / "detcompass.py").write_text(source)
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            str(Path(__file__)),
            "-q",
            "-rs",
            "--all",  # the plugin's checks include slow ones: this test is about all of them
            "-p",
            "no:cacheprovider",
            "-k",
            "detcompass",
        ],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(ROOT)])},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout[-3000:]
    summary = result.stdout.strip().splitlines()[-1]
    assert "failed" not in summary and "12 passed, 1 skipped" in summary, summary
    assert "detcompass.Compass.conformance_skip" in result.stdout


# --- a broken plugin fails the check, whatever the plugin raises ----------------------------


class _Uniform(optimizers.Optimizer):
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return self._rng.uniform(size=(len(ids), self.n_dims))

    def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
        pass


class OutOfBox(_Uniform):
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return super()._ask(ids) * 1.5


class NaNAsk(_Uniform):
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        points = super()._ask(ids)
        points[0, 0] = np.nan
        return points


class TellRaises(_Uniform):
    def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
        raise ValueError("boom")


class InitCrashes(_Uniform):
    def __init__(self, bounds=None, **kwargs):  # type: ignore[no-untyped-def]
        super().__init__(bounds, **kwargs)
        raise RuntimeError("backend down")


class Locked(_Uniform):
    def __init__(self, bounds=None, **kwargs):  # type: ignore[no-untyped-def]
        super().__init__(bounds, **kwargs)
        self._lock = threading.Lock()


@pytest.mark.parametrize(
    ("cls", "check", "cause", "match"),
    [
        (
            OutOfBox,
            testing.check_asks_inside_bounds,
            optimizers.PluginError,
            "outside the unit box",
        ),
        (NaNAsk, testing.check_asks_inside_bounds, optimizers.PluginError, "non-finite points"),
        (TellRaises, testing.check_asks_inside_bounds, ValueError, "TellRaises._tell raised"),
        (InitCrashes, testing.check_asks_inside_bounds, RuntimeError, "backend down"),
        (
            Locked,
            testing.check_save_load_continues_identically,
            optimizers.PluginError,
            "Locked cannot be pickled",
        ),
    ],
)
def test_whatever_a_broken_plugin_raises_the_check_fails_naming_itself(  # type: ignore[no-untyped-def]
    cls, check, cause, match
) -> None:
    for factory in (cls, functools.partial(optimizers.make, f"{__name__}:{cls.__name__}")):
        with pytest.raises(AssertionError, match=f"^{check.__name__}: .*{match}") as excinfo:
            testing.check_optimizer(factory)
        assert isinstance(excinfo.value.__cause__, (cause, optimizers.PluginError))
        with pytest.raises(AssertionError, match=f"^{check.__name__}: .*{match}") as excinfo:
            check(factory)  # run alone, as a parametrized test runs it
        assert isinstance(excinfo.value.__cause__, (cause, optimizers.PluginError))
    with pytest.raises(AssertionError, match=f"^{check.__name__}: ") as excinfo:
        check(cls)
    assert isinstance(excinfo.value.__cause__, cause)


class GlobalDraws(_Uniform):
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return np.random.random((len(ids), self.n_dims))  # noqa: NPY002 - the global RNG: the bug


def test_an_assertion_of_a_check_run_alone_names_the_check() -> None:
    with pytest.raises(AssertionError, match="^check_same_seed_same_asks: the same seed"):
        testing.check_same_seed_same_asks(GlobalDraws)


@pytest.mark.slow
def test_the_checks_run_without_pytest_as_the_docs_say() -> None:
    script = (
        "import sys, functools\n"
        "sys.modules['pytest'] = None  # importing pytest now fails\n"
        "import optimizers\n"
        "from optimizers.testing import check_optimizer\n"
        "check_optimizer(functools.partial(optimizers.make, 'random'))\n"
        "print('passed')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=env, check=False
    )
    assert done.returncode == 0 and done.stdout.strip() == "passed", done.stderr
    docs = (ROOT / "docs" / "optimizer-plugins.md").read_text(encoding="utf-8")
    section = docs.split("### Running the conformance suite on your plugin")[1]
    assert "they need pytest" not in section
    assert "They need only numpy" in section and "pytest is needed only to run them" in section
