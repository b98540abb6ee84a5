"""The registry: names, "module:Class" strings, entry points, missing backends, light import."""

from __future__ import annotations

import ast
import importlib.metadata
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import optimizers
from optimizers import DependencyNotInstalled, registry
from optimizers.random_search import RandomSearch

ROOT = Path(__file__).resolve().parents[1]
BOUNDS = [[0.0, 1.0], [-2.0, 2.0]]


@pytest.fixture
def fresh_registry(monkeypatch: pytest.MonkeyPatch) -> dict[str, object]:
    """The registry as it is, restored after the test."""
    copy = dict(registry._REGISTRY)
    monkeypatch.setattr(registry, "_REGISTRY", copy)
    return copy


def fake_entry_points(monkeypatch: pytest.MonkeyPatch, **values: str) -> None:
    points = {
        name: importlib.metadata.EntryPoint(name, value, registry.ENTRY_POINT_GROUP)
        for name, value in values.items()
    }
    monkeypatch.setattr(registry, "_entry_points", lambda: points)


@pytest.mark.slow
def test_make_builds_registered_optimizers_with_their_settings() -> None:
    optimizer = optimizers.make("random", bounds=BOUNDS, batch_size=3, seed=2)
    assert isinstance(optimizer, RandomSearch) and optimizer.batch_size == 3
    assert np.array_equal(optimizer.bounds, BOUNDS)
    cma = optimizers.make("cmaes", bounds=BOUNDS, batch_size=4, seed=0, sigma0=0.1)
    assert cma.batch_size == 4


def test_register_a_class_a_factory_and_a_string(fresh_registry: dict[str, object]) -> None:
    optimizers.register("mine", RandomSearch)
    optimizers.register("mine-small", lambda **kw: RandomSearch(batch_size=2, **kw))
    optimizers.register("mine-lazy", "optimizers.random_search:RandomSearch")
    assert {"mine", "mine-small", "mine-lazy"} <= set(optimizers.available())
    assert optimizers.make("mine-small", bounds=BOUNDS, seed=0).batch_size == 2
    assert isinstance(optimizers.make("mine-lazy", bounds=BOUNDS), RandomSearch)


@pytest.mark.parametrize(
    ("name", "target", "error", "match"),
    [
        ("random", RandomSearch, ValueError, "already registered"),
        ("", RandomSearch, ValueError, "non-empty"),
        (" padded", RandomSearch, ValueError, "spaces"),
        ("a:b", RandomSearch, ValueError, "':'"),
        (3, RandomSearch, TypeError, "name must be a str"),
        ("new", 42, TypeError, "cls_or_factory"),
        ("new", "no colon", ValueError, "module:attr"),
    ],
)
def test_register_rejects_bad_names_and_targets(  # type: ignore[no-untyped-def]
    fresh_registry, name, target, error, match
) -> None:
    with pytest.raises(error, match=match):
        optimizers.register(name, target)


def test_register_rejects_bad_requires(fresh_registry: dict[str, object]) -> None:
    with pytest.raises(TypeError, match="requires"):
        optimizers.register("new", RandomSearch, requires="numpy")  # type: ignore[arg-type]


def test_a_registered_name_with_a_missing_module_is_hidden_and_explained(
    fresh_registry: dict[str, object],
) -> None:
    optimizers.register("ghost", RandomSearch, requires=("no_such_module_xyz",))
    assert "ghost" not in optimizers.available()
    with pytest.raises(DependencyNotInstalled, match="pip install no_such_module_xyz"):
        optimizers.make("ghost", bounds=BOUNDS)


def test_module_class_strings() -> None:
    optimizer = optimizers.make("optimizers.random_search:RandomSearch", bounds=BOUNDS, seed=1)
    assert isinstance(optimizer, RandomSearch)
    with pytest.raises(ValueError, match="module:Class"):
        optimizers.make("optimizers.random_search:", bounds=BOUNDS)
    with pytest.raises(ImportError, match="no_such_module_xyz"):
        optimizers.make("no_such_module_xyz:Thing", bounds=BOUNDS)
    with pytest.raises(ImportError, match="has no 'Nothing'"):
        optimizers.make("optimizers.random_search:Nothing", bounds=BOUNDS)


def test_make_rejects_unknown_names_and_non_optimizers(fresh_registry: dict[str, object]) -> None:
    with pytest.raises(ValueError, match=r"unknown optimizer 'nope'; available: .*cmaes"):
        optimizers.make("nope", bounds=BOUNDS)
    with pytest.raises(TypeError, match="name_or_spec must be a str"):
        optimizers.make(RandomSearch, bounds=BOUNDS)  # type: ignore[arg-type]
    optimizers.register("not-an-optimizer", lambda **kw: object())
    with pytest.raises(TypeError, match="not an optimizers.Optimizer"):
        optimizers.make("not-an-optimizer", bounds=BOUNDS)
    with pytest.raises(TypeError, match="not callable"):
        optimizers.make("numpy:pi")


def test_entry_points_are_listed_without_importing_and_loaded_when_made(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fake_entry_points(
        monkeypatch,
        external="optimizers.random_search:RandomSearch",
        broken="no_such_module_xyz:Plugin",
    )
    names = optimizers.available()
    assert "external" in names and "broken" in names  # listing imports nothing
    assert isinstance(optimizers.make("external", bounds=BOUNDS), RandomSearch)
    with pytest.raises(ImportError, match="entry point 'no_such_module_xyz:Plugin'"):
        optimizers.make("broken", bounds=BOUNDS)


def test_a_registered_name_shadows_an_entry_point_with_a_warning(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fake_entry_points(monkeypatch, random="no_such_module_xyz:Plugin")
    with pytest.warns(RuntimeWarning, match="shadowed"):
        optimizer = optimizers.make("random", bounds=BOUNDS)
    assert isinstance(optimizer, RandomSearch)


@pytest.mark.parametrize(
    ("name", "module", "extra"),
    [
        ("bo", "skopt", "bo"),
        ("pso", "pyswarms", "pso"),
        ("optuna-tpe", "optuna", "optuna"),
        ("optuna-cmaes", "cmaes", "optuna"),
        ("nevergrad", "nevergrad", "nevergrad"),
    ],
)
def test_a_missing_backend_names_the_pip_extra(
    monkeypatch: pytest.MonkeyPatch, name: str, module: str, extra: str
) -> None:
    monkeypatch.setitem(sys.modules, module, None)  # what an uninstalled package looks like
    assert name not in optimizers.available()
    with pytest.raises(DependencyNotInstalled, match=rf"pip install tooldesign\[{extra}\]"):
        optimizers.make(name, bounds=BOUNDS, batch_size=4)


@pytest.mark.parametrize(
    ("target", "module", "extra"),
    [
        ("optimizers.bo:BayesianOptimization", "skopt", "bo"),
        ("optimizers.pso:ParticleSwarm", "pyswarms", "pso"),
        ("optimizers.optuna_adapter:OptunaTPE", "optuna", "optuna"),
        ("optimizers.nevergrad_adapter:NevergradOptimizer", "nevergrad", "nevergrad"),
    ],
)
def test_plugins_import_their_backend_lazily_with_the_same_hint(
    monkeypatch: pytest.MonkeyPatch, target: str, module: str, extra: str
) -> None:
    monkeypatch.setitem(sys.modules, module, None)
    with pytest.raises(DependencyNotInstalled, match=rf"pip install tooldesign\[{extra}\]"):
        optimizers.make(target, bounds=BOUNDS, batch_size=4)


HEAVY = ["cma", "skopt", "pyswarms", "optuna", "nevergrad", "sklearn", "pybullet", "gymnasium"]


def test_import_optimizers_loads_only_numpy() -> None:
    code = (
        "import sys, json, optimizers\n"
        "optimizers.available()\n"
        f"print(json.dumps([m for m in {HEAVY + ['tooldesign_env']!r} if m in sys.modules]))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert json.loads(result.stdout) == []


def test_no_module_of_the_package_imports_the_simulator_or_the_env() -> None:
    forbidden = {"pybullet", "pybullet_data", "gymnasium", "gym", "tooldesign_env", "benchmarks"}
    for path in sorted((ROOT / "optimizers").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            else:
                continue
            assert not {n.split(".")[0] for n in names} & forbidden, f"{path.name} imports {names}"
