"""A plugin's bugs are reported as its bugs: the message names ``module.Class.hook``.

Contract violations (what ``_ask`` or ``_backend_versions`` returns) and unexpected exceptions
of a hook or of the plugin's ``__init__`` are :class:`optimizers.PluginError`; a ``TypeError`` or
``ValueError`` raised inside a hook keeps its type but names the hook; the settings a user gives
to ``make`` are still refused with the plugin's own message.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import optimizers
from optimizers import DependencyNotInstalled, Optimizer, PluginError

ROOT = Path(__file__).resolve().parents[1]
BOUNDS = np.array([[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]])


class Centre(Optimizer):
    """Asks the centre of the box, learns nothing."""

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return np.full((len(ids), self.n_dims), 0.5)

    def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
        pass


class InitBoom(Centre):
    def __init__(self, bounds: Any = None, **kwargs: Any) -> None:
        super().__init__(bounds, **kwargs)
        raise RuntimeError("backend down")


class Strict(Centre):
    def __init__(self, bounds: Any = None, *, step: float = 0.2, **kwargs: Any) -> None:
        super().__init__(bounds, **kwargs)
        if not step > 0:
            raise ValueError(f"step must be > 0, got {step!r}")


class NeedsBackend(Centre):
    def __init__(self, bounds: Any = None, **kwargs: Any) -> None:
        super().__init__(bounds, **kwargs)
        raise DependencyNotInstalled("NeedsBackend needs acme: pip install tooldesign[acme]")


class Interrupted(Centre):
    def __init__(self, bounds: Any = None, **kwargs: Any) -> None:
        super().__init__(bounds, **kwargs)
        raise KeyboardInterrupt


def broken_factory(**kwargs: Any) -> Optimizer:
    raise KeyError("no such backend state")


class BadVersions(Centre):
    def _backend_versions(self) -> dict[str, str]:
        raise KeyError("version")


class VersionsNotStr(Centre):
    def _backend_versions(self) -> dict[str, str]:
        return {"acme": 1}  # type: ignore[dict-item]


class BroadcastTell(Centre):
    def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
        np.zeros(2) + np.zeros(3)


class TypeErrorAsk(Centre):
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return len(3)  # type: ignore[arg-type]


class DecodeAsk(Centre):
    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        b"\xff".decode("utf-8")  # UnicodeDecodeError: a ValueError that takes five arguments
        return super()._ask(ids)


def returning(points: Any) -> type[Optimizer]:
    """A plugin class whose ``_ask`` returns ``points(n, d)``."""

    class Returns(Centre):
        def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
            return points(len(ids), self.n_dims)  # type: ignore[no-any-return]

    return Returns


# --- defect: contract violations and __init__ failures are PluginErrors ------------------------


@pytest.mark.parametrize(
    ("points", "match"),
    [
        (lambda n, d: np.zeros((n - 1, d)), r"_ask returned shape \(2, 3\), expected \(3, 3\)"),
        (lambda n, d: np.zeros((n + 1, d)), r"_ask returned shape \(4, 3\), expected \(3, 3\)"),
        (lambda n, d: np.zeros(n * d), r"_ask returned shape \(9,\), expected \(3, 3\)"),
        (lambda n, d: np.full((n, d), np.nan), "_ask returned non-finite points"),
        (lambda n, d: np.full((n, d), 1.5), r"_ask returned points outside the unit box"),
        (lambda n, d: [["a"] * d] * n, "_ask returned something that is not numbers"),
        (lambda n, d: None, "_ask returned something that is not numbers"),
    ],
    ids=["fewer rows", "more rows", "flat", "nan", "outside", "strings", "None"],
)
def test_points_breaking_the_contract_are_a_plugin_error_naming_the_hook(points, match) -> None:  # type: ignore[no-untyped-def]
    optimizer = returning(points)(BOUNDS, batch_size=3, seed=0)
    with pytest.raises(PluginError, match=match) as excinfo:
        optimizer.ask()
    assert str(excinfo.value).startswith(
        f"optimizer plugin {__name__}.returning.<locals>.Returns._ask returned"
    )
    assert optimizer.n_asked == 0 and optimizer.n_pending == 0


def test_an_exception_in_the_plugins_init_is_a_plugin_error_naming_init() -> None:
    with pytest.raises(PluginError) as excinfo:
        optimizers.make(f"{__name__}:InitBoom", bounds=BOUNDS, batch_size=3, seed=0)
    assert str(excinfo.value) == (
        f"optimizer plugin {__name__}.InitBoom.__init__ raised RuntimeError: backend down"
    )
    assert isinstance(excinfo.value.__cause__, RuntimeError)


def test_an_exception_in_a_factory_names_the_factory() -> None:
    with pytest.raises(PluginError) as excinfo:
        optimizers.make(f"{__name__}:broken_factory", bounds=BOUNDS)
    assert str(excinfo.value) == (
        f"optimizer plugin {__name__}.broken_factory raised KeyError: 'no such backend state'"
    )


def test_bad_settings_given_to_make_keep_the_plugins_own_error() -> None:
    with pytest.raises(ValueError) as excinfo:
        optimizers.make(f"{__name__}:Strict", bounds=BOUNDS, step=-1)
    assert str(excinfo.value) == "step must be > 0, got -1"
    with pytest.raises(TypeError, match="has no setting 'stride'; its settings: bounds, step"):
        optimizers.make(f"{__name__}:Strict", bounds=BOUNDS, stride=1)
    with pytest.raises(ValueError, match=r"^bounds"):
        optimizers.make(f"{__name__}:InitBoom", bounds=[[1.0, 0.0]])
    with pytest.raises(OverflowError):  # the CLI and suites read it as a bad setting
        optimizers.make("cmaes", bounds=BOUNDS, sigma0=10**400)


def test_a_missing_backend_and_an_interrupt_in_init_pass_through() -> None:
    with pytest.raises(DependencyNotInstalled, match=r"tooldesign\[acme\]"):
        optimizers.make(f"{__name__}:NeedsBackend", bounds=BOUNDS)
    with pytest.raises(KeyboardInterrupt):
        optimizers.make(f"{__name__}:Interrupted", bounds=BOUNDS)


@pytest.mark.parametrize(
    ("cls", "match"),
    [
        (BadVersions, r"BadVersions\._backend_versions raised KeyError: 'version'"),
        (VersionsNotStr, r"VersionsNotStr\._backend_versions returned .*'acme': 1"),
    ],
)
def test_backend_versions_that_fail_are_a_plugin_error(cls, match, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    optimizer = cls(BOUNDS, batch_size=2, seed=0)
    with pytest.raises(PluginError, match=match):
        optimizer.save_state(tmp_path / "state.pkl")
    assert not list(tmp_path.iterdir())


class Locked(Centre):
    def __init__(self, bounds: Any = None, **kwargs: Any) -> None:
        super().__init__(bounds, **kwargs)
        self._lock = threading.Lock()


class LockedButPicklable(Locked):
    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_lock": None}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state, _lock=threading.Lock())


def test_an_unpicklable_plugin_is_a_plugin_error_naming_it_and_the_cure(tmp_path: Path) -> None:
    optimizer = optimizers.make(f"{__name__}:Locked", bounds=BOUNDS, batch_size=2, seed=0)
    with pytest.raises(PluginError) as excinfo:
        optimizer.save_state(tmp_path / "state.pkl")
    message = str(excinfo.value)
    assert message.startswith(f"optimizer plugin {__name__}.Locked cannot be pickled (")
    assert "_thread.lock" in message and "__getstate__/__setstate__" in message
    assert isinstance(excinfo.value.__cause__, TypeError)
    assert not list(tmp_path.iterdir())  # nothing written, no temporary file left
    # The cure the message names works:
    cured = LockedButPicklable(BOUNDS, batch_size=2, seed=0)
    cured.save_state(tmp_path / "state.pkl")
    restored = Optimizer.load_state(tmp_path / "state.pkl")
    assert isinstance(restored._lock, type(threading.Lock()))


INIT_BOOM = textwrap.dedent(
    """
    from optimizers import Optimizer

    class InitBoom(Optimizer):
        def __init__(self, bounds=None, **kw):
            super().__init__(bounds, **kw)
            raise RuntimeError("backend down")

        def _ask(self, ids):
            raise AssertionError("never asked")

        def _tell(self, *args):
            pass
    """
)


@pytest.mark.slow
def test_the_cli_ends_a_failing_plugin_init_in_one_line_with_exit_code_1(tmp_path: Path) -> None:
    (tmp_path / "errplugs.py").write_text(INIT_BOOM)
    argv = [
        "design",
        "--optimizer",
        "errplugs:InitBoom",
        "--iterations",
        "2",
        "--batch-size",
        "3",
        "--no-progress",
        "--no-video",
        "--out",
        str(tmp_path / "run"),
    ]
    code = f"from benchmarks.cli import main; raise SystemExit(main({argv!r}))"
    result = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 1, result.stderr
    assert result.stderr.splitlines() == [
        "tooldesign design: error: optimizer plugin errplugs.InitBoom.__init__ raised "
        "RuntimeError: backend down"
    ]


# --- defect: a TypeError or ValueError inside a hook names the hook -------------------------


def test_a_value_error_in_tell_keeps_its_type_and_names_the_hook() -> None:
    optimizer = BroadcastTell(BOUNDS, batch_size=2, seed=0)
    batch = optimizer.ask()
    with pytest.raises(ValueError) as excinfo:
        optimizer.tell(batch.ids, [1.0, 2.0])
    assert str(excinfo.value).startswith(
        f"optimizer plugin {__name__}.BroadcastTell._tell raised ValueError: operands could not "
        "be broadcast together"
    )
    assert not isinstance(excinfo.value, PluginError)
    assert isinstance(excinfo.value.__cause__, ValueError)
    assert optimizer.n_pending == 2 and optimizer.n_told == 0  # the tell was undone


def test_a_type_error_in_ask_keeps_its_type_and_names_the_hook() -> None:
    optimizer = TypeErrorAsk(BOUNDS, seed=0)
    with pytest.raises(TypeError) as excinfo:
        optimizer.ask()
    assert str(excinfo.value) == (
        f"optimizer plugin {__name__}.TypeErrorAsk._ask raised TypeError: object of type 'int' "
        "has no len()"
    )
    assert isinstance(excinfo.value.__cause__, TypeError)


def test_a_value_error_subclass_that_cannot_take_a_message_still_names_the_hook() -> None:
    with pytest.raises(UnicodeError) as excinfo:
        DecodeAsk(BOUNDS, seed=0).ask()
    assert str(excinfo.value).startswith(
        f"optimizer plugin {__name__}.DecodeAsk._ask raised UnicodeDecodeError: 'utf-8' codec"
    )
    assert isinstance(excinfo.value.__cause__, UnicodeDecodeError)


def test_builtin_settings_errors_read_as_before() -> None:
    with pytest.raises(ValueError) as excinfo:
        optimizers.make("cmaes", bounds=BOUNDS, sigma0=-1.0)
    assert str(excinfo.value).startswith("sigma0 must be")
    with pytest.raises(ValueError) as excinfo:
        optimizers.make("random", bounds=BOUNDS, batch_size=0)
    assert str(excinfo.value).startswith("batch_size must be")


def test_a_plugin_module_that_fails_to_import_is_a_plugin_error_naming_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Not ImportError: the module itself raises (a NameError at import, a bug of the plugin)."""
    (tmp_path / "brokenmod.py").write_text("x = undefined_name\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(PluginError, match=r"importing module 'brokenmod'.*NameError") as info:
        optimizers.make("brokenmod:Anything", bounds=[[0.0, 1.0]], batch_size=2, seed=0)
    assert isinstance(info.value.__cause__, NameError)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "typo", "known"),
    [
        ("cmaes", "sigma", "sigma0"),
        ("bo", "n_initial", "n_initial_points"),
        ("random", "x", "seed"),
    ],
)
def test_a_setting_the_optimizer_does_not_take_lists_the_ones_it_does(name, typo, known) -> None:  # type: ignore[no-untyped-def]
    if name == "bo":
        pytest.importorskip("skopt")
    with pytest.raises(
        TypeError, match=rf"optimizer '{name}' has no setting '{typo}'; its settings: .*\b{known}\b"
    ):
        optimizers.make(name, bounds=[[0.0, 1.0]] * 2, batch_size=4, seed=0, **{typo: 1})
