"""The base class: bounds, validation, ids and counts, the generation rule, failures, state."""

from __future__ import annotations

import math
import os
import pickle
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from optimizers import (
    Batch,
    FailurePolicy,
    Optimizer,
    OptimizerStateError,
    PluginError,
    Recommendation,
)
from optimizers.base import STATE_FORMAT


class Recorder(Optimizer):
    """Uniform samples; records what the hook is told."""

    def __init__(self, bounds=None, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(bounds, **kwargs)
        self.told: list[tuple[tuple[int, ...], np.ndarray, np.ndarray, np.ndarray]] = []

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return self._rng.random((len(ids), self.n_dims))

    def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
        self.told.append((ids, x, values, failed))


class Generational(Recorder):
    generational = True


class Corners(Recorder):
    """Asks the corners 0 and 1 of the unit box, to test the conversion at the bounds."""

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        return np.tile([0.0, 1.0], (len(ids), self.n_dims // 2))


BOUNDS = [[-1.0, 2.0], [10.0, 20.0]]


# --- construction ------------------------------------------------------------------------------


def test_bounds_as_rows_or_as_low_and_high_are_the_same() -> None:
    a = Recorder(BOUNDS, batch_size=3, seed=1)
    b = Recorder(low=[-1.0, 10.0], high=[2.0, 20.0], batch_size=3, seed=1)
    assert np.array_equal(a.bounds, b.bounds) and a.bounds.shape == (2, 2)
    assert np.array_equal(a.ask().x, b.ask().x)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"bounds": [[1.0, 0.0]]}, ValueError, "low < high"),
        ({"bounds": [[0.0, 0.0]]}, ValueError, "low < high"),
        ({"bounds": [[0.0, math.inf]]}, ValueError, "finite"),
        ({"bounds": [0.0, 1.0]}, ValueError, r"shape \(d, 2\)"),
        ({"bounds": np.zeros((0, 2))}, ValueError, r"shape \(d, 2\)"),
        ({"bounds": [[0.0, 1.0], [0.0]]}, ValueError, "inhomogeneous|ragged"),
        ({"bounds": "[[0, 1]]"}, TypeError, "bounds"),
        ({"bounds": [[True, False]]}, TypeError, "bounds"),
        ({"bounds": [[0.0, 1j]]}, TypeError, "bounds"),
        ({"bounds": None}, ValueError, "missing"),
        ({"bounds": BOUNDS, "low": [0.0]}, ValueError, "not both"),
        ({"low": [0.0, 1.0], "high": [1.0]}, ValueError, "low and high"),
        ({"bounds": BOUNDS, "batch_size": 0}, ValueError, "batch_size"),
        ({"bounds": BOUNDS, "batch_size": 2.0}, TypeError, "batch_size"),
        ({"bounds": BOUNDS, "batch_size": True}, TypeError, "batch_size"),
        ({"bounds": BOUNDS, "seed": -3}, ValueError, "seed"),
        ({"bounds": BOUNDS, "seed": 0.5}, TypeError, "seed"),
        ({"bounds": BOUNDS, "seed": True}, TypeError, "seed"),
        ({"bounds": BOUNDS, "failure_policy": {"margin": 1}}, TypeError, "failure_policy"),
    ],
)
def test_bad_constructor_arguments_raise_clear_errors(kwargs, error, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error, match=match):
        Recorder(**kwargs)


def test_plugin_limits_are_enforced() -> None:
    class NeedsTwo(Recorder):
        min_batch_size = 2
        min_dims = 2

    with pytest.raises(ValueError, match="batch_size must be >= 2"):
        NeedsTwo(BOUNDS, batch_size=1)
    with pytest.raises(ValueError, match="at least 2 dimensions"):
        NeedsTwo([[0.0, 1.0]], batch_size=2)


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"margin": -1.0}, ValueError),
        ({"margin": math.nan}, ValueError),
        ({"fallback": math.inf}, ValueError),
        ({"fixed": "big"}, TypeError),
        ({"margin": True}, TypeError),
        ({"fixed": 1e155}, ValueError),  # beyond what a told value may be (VALUE_MAX)
        ({"fallback": -1e101}, ValueError),
    ],
)
def test_failure_policy_rejects_bad_settings(kwargs, error) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error):
        FailurePolicy(**kwargs)


def test_failure_policy_penalty_values() -> None:
    policy = FailurePolicy()
    assert policy.penalty(None, None) == 1.0e10
    assert policy.penalty(1.0, 3.0) == pytest.approx(3.2)  # worst + 0.1 * (worst - best)
    assert policy.penalty(-5.0, -5.0) == pytest.approx(-4.5)  # all equal: 0.1 * max(|w|, 1)
    assert policy.penalty(0.0, 0.0) == pytest.approx(0.1)
    assert FailurePolicy(fixed=7.0).penalty(1.0, 3.0) == 7.0
    assert FailurePolicy(margin=1.0, fallback=5.0).penalty(None, None) == 5.0
    assert math.isfinite(policy.penalty(-1e308, 1.7e308))
    # A huge margin stops at VALUE_MAX, where backends still fit their models.
    assert FailurePolicy(margin=1e300).penalty(0.0, 1.0) == 1e100
    assert FailurePolicy(fixed=-1e100).penalty(0.0, 1.0) == -1e100


# --- ask ---------------------------------------------------------------------------------------


def test_ask_converts_the_unit_box_to_the_bounds_exactly_at_the_corners() -> None:
    optimizer = Corners(BOUNDS, batch_size=2, seed=0)
    batch = optimizer.ask()
    assert isinstance(batch, Batch) and len(batch) == 2
    assert np.array_equal(batch.x, [[-1.0, 20.0], [-1.0, 20.0]])
    assert not batch.x.flags.writeable
    with pytest.raises(ValueError):
        batch.x[0, 0] = 5.0


@settings(max_examples=30, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(-1e6, 1e6, allow_nan=False), st.floats(1e-6, 1e6, allow_nan=False)),
        min_size=1,
        max_size=5,
    ),
    st.integers(0, 2**32),
)
def test_asks_stay_inside_any_bounds(rows: list[tuple[float, float]], seed: int) -> None:
    bounds = np.array([[low, low + width] for low, width in rows])
    optimizer = Recorder(bounds, batch_size=4, seed=seed)
    x = optimizer.ask().x
    assert np.all((x >= bounds[:, 0]) & (x <= bounds[:, 1]))


@pytest.mark.parametrize(
    ("points", "match"),
    [
        (np.full((3, 2), 1.5), "outside the unit box"),
        (np.full((3, 2), np.nan), "non-finite"),
        (np.zeros((3, 3)), "shape"),
        ([["a", "b"]] * 3, "not numbers"),
    ],
)
def test_a_plugin_returning_bad_points_is_reported(points, match) -> None:  # type: ignore[no-untyped-def]
    class Broken(Recorder):
        def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
            return points

    optimizer = Broken(BOUNDS, batch_size=3, seed=0)
    with pytest.raises(PluginError, match=match):
        optimizer.ask()
    assert optimizer.n_asked == 0


def test_rounding_just_outside_the_unit_box_is_clipped() -> None:
    class Rounding(Recorder):
        def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
            return np.array([[-1e-12, 1.0 + 1e-12]] * len(ids))

    x = Rounding(BOUNDS, batch_size=2, seed=0).ask().x
    assert np.array_equal(x, [[-1.0, 20.0]] * 2)


# --- tell --------------------------------------------------------------------------------------


def test_ids_are_consecutive_and_counts_follow_tells() -> None:
    optimizer = Recorder(BOUNDS, batch_size=3, seed=0)
    first, second = optimizer.ask(), optimizer.ask()
    assert first.ids == (0, 1, 2) and second.ids == (3, 4, 5)
    assert optimizer.pending_ids == (0, 1, 2, 3, 4, 5)
    optimizer.tell([4, 0], [1.0, None])
    assert (optimizer.n_asked, optimizer.n_told, optimizer.n_failed) == (6, 2, 1)
    assert optimizer.pending_ids == (1, 2, 3, 5) and optimizer.iteration == 0
    optimizer.tell(np.array([1, 2]), np.array([3.0, 2.0]))
    assert optimizer.iteration == 1
    optimizer.tell((3, 5), (0.5, float("inf")))
    assert (optimizer.iteration, optimizer.n_failed, optimizer.n_pending) == (2, 2, 0)
    optimizer.tell([], [])  # an empty tell does nothing
    assert optimizer.n_told == 6


@pytest.mark.parametrize(
    ("ids", "values", "error", "match"),
    [
        ([0, 0], [1.0, 2.0], ValueError, "repeated"),
        ([7], [1.0], ValueError, "never asked"),
        ([-1], [1.0], ValueError, "never asked"),
        ([0, 1], [1.0], ValueError, "one entry per id"),
        ([0], [[1.0]], ValueError, "1-D"),
        ([0], ["1.0"], TypeError, "values"),
        ([0], [True], TypeError, "values"),
        ([0], "1", TypeError, "values"),
        ([0], 1.0, TypeError, "values"),
        ([0], np.array(["a"]), TypeError, "values"),
        ([0.0], [1.0], TypeError, "ids"),
        ([True], [1.0], TypeError, "ids"),
        (0, [1.0], TypeError, "ids"),
        ("0", [1.0], TypeError, "ids"),
        (np.array([0.0]), [1.0], TypeError, "ids"),
        (np.array([[0]]), [1.0], TypeError, "ids"),
    ],
)
def test_bad_tells_raise_and_change_nothing(ids, values, error, match) -> None:  # type: ignore[no-untyped-def]
    optimizer = Recorder(BOUNDS, batch_size=2, seed=0)
    optimizer.ask()
    with pytest.raises(error, match=match):
        optimizer.tell(ids, values)
    assert optimizer.n_told == 0 and optimizer.pending_ids == (0, 1) and not optimizer.told


def test_telling_an_id_twice_says_it_was_already_told() -> None:
    optimizer = Recorder(BOUNDS, batch_size=2, seed=0)
    optimizer.ask()
    optimizer.tell([0], [1.0])
    with pytest.raises(ValueError, match="already told"):
        optimizer.tell([0], [1.0])


def test_numpy_scalars_and_object_arrays_are_accepted() -> None:
    optimizer = Recorder(BOUNDS, batch_size=3, seed=0)
    optimizer.ask()
    optimizer.tell(
        [np.int64(0), np.int32(1), 2], np.array([np.float32(1.5), None, 2], dtype=object)
    )
    assert optimizer.n_failed == 1 and optimizer.recommend().value == 1.5


def test_sequential_plugins_are_told_at_once_in_the_order_given() -> None:
    optimizer = Recorder(BOUNDS, batch_size=3, seed=0)
    batch = optimizer.ask()
    optimizer.tell([2, 0], [5.0, 4.0])
    ids, x, values, failed = optimizer.told[-1]
    assert ids == (2, 0) and np.array_equal(values, [5.0, 4.0]) and not failed.any()
    assert np.allclose(optimizer._to_physical(x), batch.x[[2, 0]])


def test_generational_plugins_see_whole_generations_in_ask_order() -> None:
    optimizer = Generational(BOUNDS, batch_size=3, seed=0)
    batch = optimizer.ask()
    optimizer.tell([2], [3.0])
    with pytest.raises(OptimizerStateError, match="generational"):
        optimizer.ask()
    assert not optimizer.told
    optimizer.tell([1, 0], [2.0, 1.0])
    ((ids, x, values, failed),) = optimizer.told
    assert ids == (0, 1, 2) and np.array_equal(values, [1.0, 2.0, 3.0])
    assert np.allclose(optimizer._to_physical(x), batch.x)
    optimizer.ask()


# --- failures ----------------------------------------------------------------------------------


def test_failures_reach_the_hook_as_the_penalty_never_as_nan() -> None:
    optimizer = Recorder(BOUNDS, batch_size=4, seed=0)
    optimizer.ask()
    optimizer.tell([0, 1, 2, 3], [math.nan, None, math.inf, -math.inf])
    values, failed = optimizer.told[-1][2:]
    assert np.array_equal(values, [1.0e10] * 4) and failed.all()  # nothing finite yet: fallback
    optimizer.ask()
    optimizer.tell([4, 5, 6, 7], [1.0, 3.0, None, 2.0])
    values, failed = optimizer.told[-1][2:]
    assert values == pytest.approx([1.0, 3.0, 3.2, 2.0])  # worst 3 + 0.1 * (3 - 1)
    assert failed.tolist() == [False, False, True, False]


def test_the_penalty_of_a_generation_uses_its_own_finite_values() -> None:
    optimizer = Generational(BOUNDS, batch_size=3, seed=0, failure_policy=FailurePolicy(margin=1.0))
    optimizer.ask()
    optimizer.tell([0], [None])
    optimizer.tell([1, 2], [10.0, 20.0])
    values = optimizer.told[-1][2]
    assert values.tolist() == [30.0, 10.0, 20.0]


def test_a_fixed_penalty_is_used_as_given() -> None:
    optimizer = Recorder(BOUNDS, batch_size=2, seed=0, failure_policy=FailurePolicy(fixed=99.0))
    optimizer.ask()
    optimizer.tell([0, 1], [1.0, math.nan])
    assert optimizer.told[-1][2].tolist() == [1.0, 99.0]
    assert optimizer.failure_policy.fixed == 99.0


# --- recommend ---------------------------------------------------------------------------------


def test_recommend_returns_the_earliest_best_finite_value() -> None:
    optimizer = Recorder(BOUNDS, batch_size=4, seed=0)
    with pytest.raises(OptimizerStateError, match="nothing to recommend"):
        optimizer.recommend()
    batch = optimizer.ask()
    optimizer.tell(batch.ids, [2.0, -math.inf, 1.0, 1.0])
    best = optimizer.recommend()
    assert isinstance(best, Recommendation)
    assert (best.id, best.value) == (2, 1.0) and np.array_equal(best.x, batch.x[2])
    assert not best.x.flags.writeable


# --- state -------------------------------------------------------------------------------------


def test_save_state_writes_atomically_and_load_state_continues(tmp_path) -> None:  # type: ignore[no-untyped-def]
    optimizer = Recorder(BOUNDS, batch_size=3, seed=4)
    optimizer.ask()
    path = tmp_path / "state.pkl"
    optimizer.save_state(path)
    assert os.listdir(tmp_path) == ["state.pkl"]
    restored = Recorder.load_state(str(path))
    assert restored.pending_ids == optimizer.pending_ids == (0, 1, 2)
    for each in (optimizer, restored):
        each.tell([0, 1, 2], [1.0, 2.0, 3.0])
    assert np.array_equal(optimizer.ask().x, restored.ask().x)


def test_a_failed_save_keeps_the_old_file_and_leaves_no_temporary(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "state.pkl"
    Recorder(BOUNDS, batch_size=3, seed=4).save_state(path)
    before = path.read_bytes()
    optimizer = Recorder(BOUNDS, batch_size=3, seed=4)
    optimizer.unpicklable = lambda: None  # type: ignore[attr-defined]
    with pytest.raises(PluginError, match="cannot be pickled") as excinfo:
        optimizer.save_state(path)
    assert isinstance(excinfo.value.__cause__, (pickle.PicklingError, AttributeError, TypeError))
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["state.pkl"]


def test_load_state_insists_on_the_class_it_is_called_on(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "state.pkl"
    Recorder(BOUNDS, batch_size=3, seed=4).save_state(path)
    assert isinstance(Optimizer.load_state(path), Recorder)
    with pytest.raises(TypeError, match="holds a Recorder, not a Generational"):
        Generational.load_state(path)


@pytest.mark.parametrize(
    ("payload", "match"),
    [
        ({"format": "other"}, "not an optimizer state"),
        ({"format": STATE_FORMAT, "version": 99, "optimizer": b""}, "version 99"),
        ([1, 2, 3], "not an optimizer state"),
    ],
)
def test_load_state_rejects_other_files(tmp_path, payload, match) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "state.pkl"
    path.write_bytes(pickle.dumps(payload))
    with pytest.raises(ValueError, match=match):
        Optimizer.load_state(path)


def test_load_state_names_a_plugin_that_cannot_be_imported(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "state.pkl"
    # Same length, so the pickle stays well-formed: only the module name changes.
    inner = pickle.dumps(Recorder(BOUNDS, seed=0))
    inner = inner.replace(b"test_optimizers_base", b"gone_module_absent__")
    payload = {"format": STATE_FORMAT, "version": 1, "class": "gone:Plugin", "optimizer": inner}
    path.write_bytes(pickle.dumps(payload))
    with pytest.raises(ImportError, match="gone:Plugin"):
        Optimizer.load_state(path)


def test_load_state_warns_when_versions_changed(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "state.pkl"
    Recorder(BOUNDS, seed=0).save_state(path)
    payload = pickle.loads(path.read_bytes())
    payload["versions"]["numpy"] = "0.0.1"
    path.write_bytes(pickle.dumps(payload))
    with pytest.warns(RuntimeWarning, match="numpy 0.0.1"):
        Optimizer.load_state(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Recorder(BOUNDS, seed=0).save_state(path)
        Optimizer.load_state(path)


@pytest.mark.parametrize("bad", [None, 3, b"state.pkl"])
def test_state_paths_must_be_paths(tmp_path, bad) -> None:  # type: ignore[no-untyped-def]
    optimizer = Recorder(BOUNDS, seed=0)
    with pytest.raises(TypeError, match="path"):
        optimizer.save_state(bad)
    with pytest.raises(TypeError, match="path"):
        Optimizer.load_state(bad)


def test_save_state_into_a_folder_or_a_missing_folder_fails_clearly(tmp_path) -> None:  # type: ignore[no-untyped-def]
    optimizer = Recorder(BOUNDS, seed=0)
    with pytest.raises(ValueError, match="folder"):
        optimizer.save_state(tmp_path)
    with pytest.raises(FileNotFoundError, match="no folder"):
        optimizer.save_state(tmp_path / "missing" / "state.pkl")
    with pytest.raises(FileNotFoundError):
        Optimizer.load_state(tmp_path / "absent.pkl")


@pytest.mark.parametrize("name", ["missing/", "missing/.", "missing/..", "."])
def test_save_state_to_a_path_that_names_a_folder_is_a_value_error(tmp_path, name) -> None:  # type: ignore[no-untyped-def]
    # "missing/" reached os.replace, which raised a raw NotADirectoryError.
    optimizer = Recorder(BOUNDS, seed=0)
    with pytest.raises(ValueError, match="path must be a file, .* names a folder|is a folder"):
        optimizer.save_state(f"{tmp_path}/{name}")
    with pytest.raises(ValueError, match="names a folder"):
        optimizer.save_state("")
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no temporary file left behind


def test_repr_names_the_class_and_counts() -> None:
    text = repr(Recorder(BOUNDS, batch_size=3, seed=0))
    assert text.startswith("Recorder(") and "batch_size=3" in text and "n_told=0" in text


# --- a backend that raises while told -------------------------------------------------------


@pytest.mark.parametrize("cls", [Recorder, Generational])
def test_a_tell_whose_backend_raises_is_undone_and_can_be_retried(cls) -> None:  # type: ignore[no-untyped-def]
    class Flaky(cls):  # type: ignore[misc, valid-type]
        fail_next = False

        def _tell(self, ids, x, values, failed) -> None:  # type: ignore[no-untyped-def]
            if self.fail_next:
                self.fail_next = False
                raise RuntimeError("a transient backend error")
            super()._tell(ids, x, values, failed)

    steady, flaky = cls(BOUNDS, batch_size=3, seed=0), Flaky(BOUNDS, batch_size=3, seed=0)
    for optimizer in (steady, flaky):
        optimizer.tell(*_first_batch(optimizer))
    batch = flaky.ask()
    steady_batch = steady.ask()
    values = [3.0, None, 1.0]
    flaky.fail_next = True
    with pytest.raises(PluginError, match="transient"):
        flaky.tell(batch.ids, values)
    # Nothing of the failed tell stays: the points are pending, nothing is counted.
    assert flaky.pending_ids == batch.ids and flaky.n_told == 3 and flaky.n_failed == 0
    assert flaky.iteration == 1 and flaky.recommend().value == steady.recommend().value
    flaky.tell(batch.ids, values)  # the retry goes through, as if nothing had failed
    steady.tell(steady_batch.ids, values)
    assert (flaky.n_told, flaky.n_failed, flaky.iteration) == (6, 1, 2)
    assert flaky.recommend().value == steady.recommend().value == 1.0
    assert [t[0] for t in flaky.told] == [t[0] for t in steady.told]
    for got, want in zip(flaky.told, steady.told, strict=True):
        assert all(np.array_equal(a, b) for a, b in zip(got[1:], want[1:], strict=True))


def _first_batch(optimizer: Optimizer) -> tuple[tuple[int, ...], list[float]]:
    batch = optimizer.ask()
    return batch.ids, [5.0, 4.0, 6.0]
