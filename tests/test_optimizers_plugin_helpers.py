"""Public helpers for plugin authors: pending points, the global-RNG guard, named plugin errors."""

from __future__ import annotations

import numpy as np
import pytest

from optimizers import GlobalRandomState, Optimizer, PluginError

BOUNDS = [[-1.0, 2.0], [10.0, 20.0]]


class Uniform(Optimizer):
    def _ask(self, ids):  # type: ignore[no-untyped-def]
        return self._rng.random((len(ids), self.n_dims))

    def _tell(self, ids, x, values, failed):  # type: ignore[no-untyped-def]
        pass


class Broken(Uniform):
    def __init__(self, *args, fail_in="_ask", error=None, **kwargs):  # type: ignore[no-untyped-def]
        super().__init__(*args, **kwargs)
        self.fail_in = fail_in
        self.error = KeyError("backend state") if error is None else error

    def _ask(self, ids):  # type: ignore[no-untyped-def]
        if self.fail_in == "_ask":
            raise self.error
        return super()._ask(ids)

    def _tell(self, ids, x, values, failed):  # type: ignore[no-untyped-def]
        if self.fail_in == "_tell":
            raise self.error


def test_pending_points_in_physical_units_and_in_the_unit_box():
    opt = Uniform(BOUNDS, batch_size=3, seed=0)
    assert opt.pending_points().shape == (0, 2)
    batch = opt.ask()
    np.testing.assert_array_equal(opt.pending_points(), batch.x)
    unit = opt.pending_points(unit=True)
    np.testing.assert_allclose(unit * [3.0, 10.0] + [-1.0, 10.0], batch.x)
    opt.tell(batch.ids[1:2], [1.0])
    np.testing.assert_array_equal(opt.pending_points(), batch.x[[0, 2]])
    opt.pending_points()[0, 0] = 99.0  # a copy: the optimizer is not changed
    assert opt.pending_points()[0, 0] == batch.x[0, 0]


@pytest.mark.parametrize("bad", [1, "yes", None])
def test_pending_points_bad_input(bad):
    with pytest.raises(TypeError, match="unit must be a bool"):
        Uniform(BOUNDS, seed=0).pending_points(unit=bad)


def test_global_random_state_isolates_and_continues_its_stream():
    guard = GlobalRandomState(7)
    np.random.seed(123)  # noqa: NPY002  (the caller's global stream, which must survive)
    outer = np.random.get_state()  # noqa: NPY002
    with guard.active():
        first = np.random.random(3)  # noqa: NPY002
    with guard.active():
        second = np.random.random(3)  # noqa: NPY002
    after = np.random.get_state()  # noqa: NPY002
    assert all(np.array_equal(a, b) for a, b in zip(outer[1:2], after[1:2], strict=True))
    expected = np.random.RandomState(7).random(6)
    np.testing.assert_array_equal(np.r_[first, second], expected)


@pytest.mark.parametrize(
    "seed, error",
    [(-1, ValueError), (2**32, ValueError), ("1", TypeError), (True, TypeError), (1.5, TypeError)],
)
def test_global_random_state_bad_seed(seed, error):
    with pytest.raises(error, match="seed"):
        GlobalRandomState(seed)


@pytest.mark.parametrize("hook", ["_ask", "_tell"])
def test_an_unexpected_plugin_error_names_the_plugin_and_the_hook(hook):
    opt = Broken(BOUNDS, batch_size=2, seed=0, fail_in=hook)
    with pytest.raises(PluginError) as excinfo:
        batch = opt.ask()
        opt.tell(batch.ids, [1.0, 2.0])
    message = str(excinfo.value)
    assert f"{__name__}.Broken.{hook} raised KeyError" in message
    assert isinstance(excinfo.value.__cause__, KeyError)


@pytest.mark.parametrize("error", [ValueError("bad setting"), TypeError("bad type")])
def test_type_and_value_errors_of_a_plugin_keep_their_type_and_name_the_hook(error):
    opt = Broken(BOUNDS, seed=0, error=error)
    with pytest.raises(type(error)) as excinfo:
        opt.ask()
    assert str(excinfo.value) == (
        f"optimizer plugin {__name__}.Broken._ask raised {type(error).__name__}: {error}"
    )
    assert excinfo.value.__cause__ is error


@pytest.mark.slow
def test_the_cli_reports_a_plugin_error_in_one_line(monkeypatch, capsys):
    import benchmarks.design as design  # the command imports run_design from here when run
    from benchmarks.cli import main

    def fail(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise PluginError("optimizer plugin acme.Hill._ask raised KeyError: 'x'")

    monkeypatch.setattr(design, "run_design", fail)
    with pytest.raises(SystemExit) as excinfo:
        main(["design", "--out", "x"])
    assert excinfo.value.code == 1
    assert "acme.Hill._ask raised KeyError" in capsys.readouterr().err
