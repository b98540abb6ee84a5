"""What each built-in plugin promises beyond the conformance suite: its backend sees only finite
values, it leaves no files or logging behind, its settings are checked, and state survives a
fresh process."""

from __future__ import annotations

import functools
import importlib.util
import json
import logging
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import optimizers
from optimizers import FailurePolicy, testing
from optimizers.testing import BOUNDS, shifted_sphere

ROOT = Path(__file__).resolve().parents[1]
FAILURES = [math.nan, None, math.inf, -math.inf]


def needs(module: str) -> None:
    """Skip unless a backend is installed; found without importing it (importing pyswarms
    itself would write report.log into the working folder)."""
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed")


def run(optimizer: optimizers.Optimizer, iterations: int, fail_first: bool = False) -> None:
    """Ask/tell rounds on the shifted sphere; the first point of each batch fails if asked."""
    for k in range(iterations):
        batch = optimizer.ask()
        values: list[Any] = list(shifted_sphere(batch.x))
        if fail_first:
            values[0] = FAILURES[k % len(FAILURES)]
        optimizer.tell(batch.ids, values)


def spy_on(
    monkeypatch: pytest.MonkeyPatch, owner: Any, name: str, seen: list[Any], pick: Any
) -> None:
    """Record ``pick(*args, **kwargs)`` of every call of ``owner.name``."""
    original = getattr(owner, name)

    def spy(*args: Any, **kwargs: Any) -> Any:
        seen.append(pick(*args, **kwargs))
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, spy)


def all_finite(seen: list[Any]) -> bool:
    return bool(seen) and all(np.all(np.isfinite(np.asarray(v, dtype=np.float64))) for v in seen)


# --- cmaes ---------------------------------------------------------------------------------------


@pytest.mark.slow
def test_cmaes_backend_is_told_finite_values_only(monkeypatch: pytest.MonkeyPatch) -> None:
    optimizer = optimizers.make("cmaes", bounds=BOUNDS, batch_size=6, seed=0)
    seen: list[Any] = []
    spy_on(monkeypatch, optimizer._es, "tell", seen, lambda solutions, values, **kw: values)
    run(optimizer, 6, fail_first=True)
    assert len(seen) == 6 and all_finite(seen)


def test_cmaes_writes_no_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    run(optimizers.make("cmaes", bounds=BOUNDS, batch_size=6, seed=0), 5)
    assert list(tmp_path.iterdir()) == []


def test_cmaes_starts_at_x0_with_step_sigma0() -> None:
    x0 = np.array([1.0, -1.0, 0.25])
    optimizer = optimizers.make("cmaes", bounds=BOUNDS, batch_size=50, seed=0, x0=x0, sigma0=0.01)
    x = optimizer.ask().x
    widths = BOUNDS[:, 1] - BOUNDS[:, 0]
    assert np.allclose(x.mean(axis=0), x0, atol=0.01 * widths.max())
    assert np.allclose(x.std(axis=0) / widths, 0.01, rtol=0.5)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"sigma0": 0.0}, ValueError, "sigma0"),
        ({"sigma0": 2.0}, ValueError, "sigma0"),
        ({"sigma0": "big"}, TypeError, "sigma0"),
        ({"sigma0": True}, TypeError, "sigma0"),
        ({"x0": [5.0, 0.0, 0.0]}, ValueError, "inside the bounds"),
        ({"x0": [0.0, 0.0]}, ValueError, "shape"),
        ({"x0": "centre"}, TypeError, "x0"),
        ({"batch_size": 1}, ValueError, "batch_size must be >= 2"),
        ({"bounds": [[0.0, 1.0]]}, ValueError, "at least 2 dimensions"),
    ],
)
def test_cmaes_rejects_bad_settings(kwargs: dict[str, Any], error: type, match: str) -> None:
    settings = {"bounds": BOUNDS, "batch_size": 4, "seed": 0, **kwargs}
    with pytest.raises(error, match=match):
        optimizers.make("cmaes", **settings)


# --- state in a fresh process ------------------------------------------------------------------

CONTINUE = textwrap.dedent(
    """
    import json, os, sys
    import numpy as np
    from optimizers import Optimizer
    from optimizers.testing import shifted_sphere

    optimizer = Optimizer.load_state(sys.argv[1])
    asked = []
    for _ in range(3):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, shifted_sphere(batch.x))
        asked.append(np.asarray(batch.x).tolist())
    print(json.dumps({"asked": asked, "files": sorted(os.listdir(".")),
                      "root_handlers": len(__import__("logging").getLogger().handlers)}))
    """
)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cmaes", "pso"])
def test_a_run_resumes_in_a_fresh_process_exactly(name: str, tmp_path: Path) -> None:
    if name == "pso":
        needs("pyswarms")
    uninterrupted = optimizers.make(name, bounds=BOUNDS, batch_size=6, seed=3)
    run(uninterrupted, 4)
    expected = []
    for _ in range(3):
        batch = uninterrupted.ask()
        uninterrupted.tell(batch.ids, shifted_sphere(batch.x))
        expected.append(np.asarray(batch.x).tolist())

    interrupted = optimizers.make(name, bounds=BOUNDS, batch_size=6, seed=3)
    run(interrupted, 4)
    state = tmp_path / "state.pkl"
    interrupted.save_state(state)
    work = tmp_path / "cwd"
    work.mkdir()
    result = subprocess.run(
        [sys.executable, "-c", CONTINUE, str(state)],
        cwd=work,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    out = json.loads(result.stdout)
    assert out["asked"] == expected
    assert out["files"] == [] and out["root_handlers"] == 0  # no report.log, no logging setup


SAVE_PENDING = textwrap.dedent(
    """
    import sys
    import optimizers
    from optimizers.testing import BOUNDS, shifted_sphere

    optimizer = optimizers.make(sys.argv[1], bounds=BOUNDS, batch_size=4, seed=3)
    for _ in range(3):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, shifted_sphere(batch.x))
    optimizer.ask()  # left pending
    optimizer.save_state(sys.argv[2])
    """
)

CONTINUE_PENDING = textwrap.dedent(
    """
    import json, sys, warnings
    import numpy as np
    from optimizers import Optimizer
    from optimizers.testing import shifted_sphere

    warnings.simplefilter("error")  # e.g. pycma's "orphanated injected solution"
    optimizer = Optimizer.load_state(sys.argv[1])
    optimizer.tell(optimizer.pending_ids, shifted_sphere(optimizer.pending_points()))
    asked = []
    for _ in range(3):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, shifted_sphere(batch.x))
        asked.append(np.asarray(batch.x).tolist())
    print(json.dumps(asked))
    """
)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(optimizers.available()))
def test_a_state_saved_with_points_pending_continues_exactly_in_another_process(
    name: str, tmp_path: Path
) -> None:
    # Python salts str and bytes hashes per process (PYTHONHASHSEED): a backend that files its
    # pending points under such a hash (pycma does) must find them again after loading. (With
    # batch_size=4 and seed=3 pycma's pending generation holds points it repaired into the box,
    # which it tells apart from foreign ones only by that lookup.)
    uninterrupted = optimizers.make(name, bounds=BOUNDS, batch_size=4, seed=3)
    run(uninterrupted, 3)
    batch = uninterrupted.ask()
    uninterrupted.tell(batch.ids, shifted_sphere(batch.x))
    expected = []
    for _ in range(3):
        batch = uninterrupted.ask()
        uninterrupted.tell(batch.ids, shifted_sphere(batch.x))
        expected.append(np.asarray(batch.x).tolist())

    state = tmp_path / "state.pkl"
    work = tmp_path / "cwd"
    work.mkdir()

    def python(code: str, *args: str, hash_seed: str) -> str:
        env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONHASHSEED": hash_seed}
        done = subprocess.run(
            [sys.executable, "-c", code, *args], cwd=work, env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr
        return done.stdout

    python(SAVE_PENDING, name, str(state), hash_seed="5")
    assert json.loads(python(CONTINUE_PENDING, str(state), hash_seed="6")) == expected


@pytest.mark.slow
@pytest.mark.parametrize("policy", [{"margin": 1e300}, {"fixed": 1e100}])
def test_every_optimizer_survives_the_largest_failure_penalty(policy: dict[str, float]) -> None:
    # bo's Gaussian process saw NaN once penalties passed about 1e155 (an audit of issue 3).
    for name in sorted(optimizers.available()):
        optimizer = optimizers.make(
            name, bounds=BOUNDS, batch_size=4, seed=0, failure_policy=FailurePolicy(**policy)
        )
        run(optimizer, 4, fail_first=True)
        assert optimizer.n_failed == 4 and math.isfinite(optimizer.recommend().value)


# --- pso ---------------------------------------------------------------------------------------


@pytest.mark.slow
def test_pso_leaves_no_report_log_and_no_logging_setup(tmp_path: Path) -> None:
    needs("pyswarms")
    code = textwrap.dedent(
        """
        import json, logging, os
        import optimizers
        from optimizers.testing import BOUNDS, shifted_sphere
        for topology in ("star", "ring"):
            optimizer = optimizers.make("pso", bounds=BOUNDS, batch_size=5, seed=0,
                                        topology=topology)
            for _ in range(3):
                batch = optimizer.ask()
                optimizer.tell(batch.ids, shifted_sphere(batch.x))
        print(json.dumps({"files": os.listdir("."), "handlers": len(logging.getLogger().handlers),
                          "level": logging.getLogger().level}))
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(result.stdout) == {"files": [], "handlers": 0, "level": logging.WARNING}


def test_pso_backend_sees_finite_costs_only() -> None:
    needs("pyswarms")
    optimizer = optimizers.make("pso", bounds=BOUNDS, batch_size=5, seed=0)
    seen: list[Any] = []
    for k in range(6):
        batch = optimizer.ask()
        values: list[Any] = list(shifted_sphere(batch.x))
        values[k % 5] = FAILURES[k % 4]
        optimizer.tell(batch.ids, values)
        swarm = optimizer._swarm
        seen += [swarm.current_cost, swarm.pbest_cost, swarm.best_cost]
    assert all_finite(seen)


@pytest.mark.slow
def test_pso_ring_topology_passes_the_conformance_suite() -> None:
    needs("pyswarms")
    testing.check_optimizer(functools.partial(optimizers.make, "pso", topology="ring"))


@pytest.mark.parametrize("boundary", ["nearest", "reflective", "periodic", "random"])
def test_pso_boundary_strategies_keep_particles_in_the_box(boundary: str) -> None:
    needs("pyswarms")
    optimizer = optimizers.make(
        "pso", bounds=BOUNDS, batch_size=6, seed=1, boundary=boundary, velocity_clamp=None
    )
    for _ in range(8):
        batch = optimizer.ask()
        assert np.all((batch.x >= BOUNDS[:, 0]) & (batch.x <= BOUNDS[:, 1]))
        optimizer.tell(batch.ids, shifted_sphere(batch.x))


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"topology": "pyramid"}, ValueError, "topology"),
        ({"topology": "random"}, ValueError, "topology"),
        ({"boundary": "shrink"}, ValueError, "boundary"),
        ({"c1": -1.0}, ValueError, "c1"),
        ({"w": "heavy"}, TypeError, "w"),
        ({"velocity_clamp": (1.0, 0.0)}, ValueError, "velocity_clamp"),
        ({"velocity_clamp": 0.5}, TypeError, "velocity_clamp"),
        ({"topology": "ring", "neighbours": 1}, ValueError, "neighbours"),
        ({"topology": "ring", "neighbours": 9}, ValueError, "neighbours"),
        ({"topology": "ring", "neighbours": 2.0}, TypeError, "neighbours"),
        ({"topology": "ring", "p_norm": 3}, ValueError, "p_norm"),
    ],
)
def test_pso_rejects_bad_settings(kwargs: dict[str, Any], error: type, match: str) -> None:
    needs("pyswarms")
    with pytest.raises(error, match=match):
        optimizers.make("pso", bounds=BOUNDS, batch_size=4, seed=0, **kwargs)


# --- bo ----------------------------------------------------------------------------------------


def test_bo_posterior_shortcut_equals_skopt_prediction() -> None:
    needs("skopt")
    from optimizers.bo import _Posterior

    # A noisy objective keeps K well conditioned: skopt's explicit inverse of K loses digits
    # (even negative variances) when the fitted noise is at its lower bound.
    rng = np.random.default_rng(1)
    optimizer = optimizers.make("bo", bounds=BOUNDS, batch_size=8, seed=0, n_initial_points=8)
    for _ in range(3):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, shifted_sphere(batch.x) + 0.05 * rng.standard_normal(8))
    X, y = optimizer._training_data()
    gp = optimizer._fitted_model(X, y)
    points = rng.random((50, 3))
    mean, std = gp.predict(points, return_std=True)
    fast_mean, fast_std = _Posterior(gp).predict(points, return_std=True)
    assert np.allclose(mean, fast_mean) and np.allclose(std, fast_std, rtol=1e-5, atol=1e-8)


def test_bo_gp_is_fitted_on_finite_values_with_failures_repenalized(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    needs("skopt")
    from skopt.learning import GaussianProcessRegressor

    seen: list[Any] = []
    spy_on(monkeypatch, GaussianProcessRegressor, "fit", seen, lambda gp, X, y: np.array(y))
    optimizer = optimizers.make("bo", bounds=BOUNDS, batch_size=4, seed=0, n_initial_points=4)
    run(optimizer, 5, fail_first=True)
    assert all_finite(seen)
    X, y = optimizer._training_data()
    failed = np.asarray(optimizer._failed)
    assert failed.sum() == 5 and np.all(y[failed] == optimizer._failure_penalty())
    assert optimizer._failure_penalty() > y[~failed].max()


def test_bo_pending_points_are_believers_so_batches_differ() -> None:
    needs("skopt")
    optimizer = optimizers.make("bo", bounds=BOUNDS, batch_size=4, seed=0, n_initial_points=4)
    run(optimizer, 2)
    first, second = optimizer.ask(), optimizer.ask()  # asynchronous: nothing told in between
    points = np.vstack([first.x, second.x])
    gaps = np.linalg.norm(points[:, None] - points[None], axis=-1) + np.eye(8)
    assert gaps.min() > 1e-3


@pytest.mark.slow
@pytest.mark.parametrize(
    "settings",
    [
        {"acq_func": "PI"},
        {"acq_func": "LCB", "kappa": 3.0},
        {"acq_optimizer": "lbfgs"},
        {"n_points": 10, "gp_restarts": 0},
    ],
)
def test_bo_settings_work(settings: dict[str, Any]) -> None:
    needs("skopt")
    optimizer = optimizers.make(
        "bo", bounds=BOUNDS, batch_size=4, seed=0, n_initial_points=4, **settings
    )
    run(optimizer, 4)
    assert optimizer.recommend().value < 1.0


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"acq_func": "gp_hedge"}, ValueError, "acq_func"),
        ({"acq_optimizer": "auto"}, ValueError, "acq_optimizer"),
        ({"n_points": 0}, ValueError, "n_points"),
        ({"n_initial_points": 1.5}, TypeError, "n_initial_points"),
        ({"gp_restarts": -1}, ValueError, "gp_restarts"),
        ({"xi": math.nan}, ValueError, "xi"),
        ({"kappa": "wide"}, TypeError, "kappa"),
    ],
)
def test_bo_rejects_bad_settings(kwargs: dict[str, Any], error: type, match: str) -> None:
    needs("skopt")
    with pytest.raises(error, match=match):
        optimizers.make("bo", bounds=BOUNDS, batch_size=4, seed=0, **kwargs)


# --- adapters ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["optuna-tpe", "optuna-cmaes"])
def test_optuna_is_told_finite_values_and_stays_quiet(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    if name not in optimizers.available():
        pytest.skip(f"{name} needs a backend that is not installed")
    import optuna

    optuna.logging.set_verbosity(optuna.logging.INFO)
    records: list[logging.LogRecord] = []
    handler = logging.Handler()
    handler.emit = records.append  # type: ignore[method-assign]
    logging.getLogger("optuna").addHandler(handler)
    try:
        optimizer = optimizers.make(name, bounds=BOUNDS, batch_size=4, seed=0)
        seen: list[Any] = []
        spy_on(monkeypatch, optimizer._study, "tell", seen, lambda trial, value, **kw: value)
        run(optimizer, 4, fail_first=True)
        assert optuna.logging.get_verbosity() == optuna.logging.INFO  # restored
    finally:
        logging.getLogger("optuna").removeHandler(handler)
        optuna.logging.set_verbosity(optuna.logging.WARNING)
    assert len(seen) == 16 and all_finite(seen)
    assert not [r for r in records if r.levelno < logging.WARNING]


@pytest.mark.parametrize(
    ("name", "kwargs", "error"),
    [
        ("optuna-tpe", {"n_startup_trials": -1}, ValueError),
        ("optuna-tpe", {"n_startup_trials": 2.0}, TypeError),
        ("optuna-cmaes", {"sigma0": 0.0}, ValueError),
        ("optuna-cmaes", {"sigma0": "wide"}, TypeError),
        ("nevergrad", {"optimizer": "NoSuchOptimizer"}, ValueError),
        ("nevergrad", {"optimizer": 3}, TypeError),
        ("nevergrad", {"budget": 0}, ValueError),
        ("nevergrad", {"budget": 10.0}, TypeError),
    ],
)
def test_adapters_reject_bad_settings(name: str, kwargs: dict[str, Any], error: type) -> None:
    if name not in optimizers.available():
        pytest.skip(f"{name} needs a backend that is not installed")
    with pytest.raises(error):
        optimizers.make(name, bounds=BOUNDS, batch_size=4, seed=0, **kwargs)


def test_nevergrad_is_told_finite_values_and_takes_other_optimizers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    needs("nevergrad")
    optimizer = optimizers.make("nevergrad", bounds=BOUNDS, batch_size=4, seed=0)
    seen: list[Any] = []
    spy_on(monkeypatch, optimizer._optimizer, "tell", seen, lambda candidate, value, **kw: value)
    run(optimizer, 4, fail_first=True)
    assert len(seen) == 16 and all_finite(seen)
    other = optimizers.make("nevergrad", bounds=BOUNDS, batch_size=4, seed=0, optimizer="CMA")
    run(other, 3)
    assert type(other._optimizer).__name__ != type(optimizer._optimizer).__name__


@pytest.mark.parametrize("sigma0", [5.0, 1.5, 1e-7, 0.0, -0.1, float("nan"), np.float64(2.0)])
def test_optuna_cmaes_limits_sigma0_like_cmaes_with_its_wording(sigma0: float) -> None:
    needs("optuna")
    needs("cmaes")
    with pytest.raises(ValueError) as expected:
        optimizers.make("cmaes", bounds=BOUNDS, batch_size=4, seed=0, sigma0=sigma0)
    with pytest.raises(ValueError) as got:
        optimizers.make("optuna-cmaes", bounds=BOUNDS, batch_size=4, seed=0, sigma0=sigma0)
    assert str(got.value) == str(expected.value)
    assert str(got.value).startswith("sigma0 must be in [1e-06, 1] (a fraction of the box)")


@pytest.mark.parametrize("sigma0", [np.float32(0.3), np.float64(1.0), np.int64(1), 1e-6])
def test_optuna_cmaes_takes_numpy_numbers_for_sigma0(sigma0: Any) -> None:
    needs("optuna")
    needs("cmaes")
    optimizer = optimizers.make("optuna-cmaes", bounds=BOUNDS, batch_size=4, seed=0, sigma0=sigma0)
    sampler = optimizer._study.sampler
    assert type(sampler._sigma0) is float and sampler._sigma0 == float(sigma0)
    run(optimizer, 2)
