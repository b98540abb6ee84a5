"""The ``nevergrad`` adapter: its measured refusal rule, its replayed backends, its np.random.

The rule comes from ``optimizers/_nevergrad_support.py``, which ``tests/nevergrad_survey.py``
measured; these tests check that the adapter applies it, that what it accepts works (a sample),
and the survey's own classification.
"""

from __future__ import annotations

import gc
import importlib.util
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import optimizers
from optimizers import _nevergrad_support as support
from optimizers import nevergrad_adapter
from optimizers.testing import BOUNDS, shifted_sphere

if importlib.util.find_spec("nevergrad") is None:
    pytest.skip("nevergrad is not installed", allow_module_level=True)

import nevergrad as ng

sys.path.insert(0, str(Path(__file__).resolve().parent))
import nevergrad_survey  # noqa: E402

ALTERNATIVES = ("'TwoPointsDE'", "'CMA'", "'PSO'", "'OnePlusOne'")
SAME_VERSION = ng.__version__ == support.MEASURED_ON["nevergrad"]
needs_measured_version = pytest.mark.skipif(
    not SAME_VERSION, reason=f"the table was measured on nevergrad {support.MEASURED_ON}"
)


def make(name: str, budget: int | None = None, batch_size: int = 4, seed: int = 0) -> Any:
    return optimizers.make(
        "nevergrad", bounds=BOUNDS, batch_size=batch_size, seed=seed, optimizer=name, budget=budget
    )


def rounds(optimizer: optimizers.Optimizer, n: int) -> list[list[list[float]]]:
    asked = []
    for _ in range(n):
        batch = optimizer.ask()
        optimizer.tell(batch.ids, shifted_sphere(batch.x))
        asked.append(np.asarray(batch.x).tolist())
    return asked


def refusal(name: str, budget: int | None, batch_size: int) -> str:
    with pytest.raises(ValueError) as raised:
        make(name, budget, batch_size)
    message = str(raised.value)
    assert message.startswith(f"optimizer {name!r} "), message
    assert all(alternative in message for alternative in ALTERNATIVES), message
    return message


def test_the_table_is_consistent_and_recommends_only_names_it_accepts() -> None:
    assert not support.FAILS.keys() & (support.NEEDS_BUDGET | support.SEQUENTIAL)
    for alternative in ALTERNATIVES:
        name = alternative.strip("'")
        assert name not in support.FAILS.keys() | support.NEEDS_BUDGET | support.SEQUENTIAL
    if SAME_VERSION:
        registry = set(ng.optimizers.registry)
        assert support.FAILS.keys() | support.NEEDS_BUDGET | support.SEQUENTIAL <= registry


@needs_measured_version
@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("NGOpt", "TypeError on numpy 2"),
        ("NGOptRW", "TypeError on numpy 2"),
        ("Wiz", "TypeError on numpy 2"),
        ("NgIoh", "TypeError on numpy 2"),
        ("CSEC", "TypeError on numpy 2"),
        ("CmaFmin2", "is not reproducible"),
        ("NGOptF2", "is not reproducible across processes"),
        ("BO", "is too slow to be checked"),
        ("AX", "needs the package 'ax'"),
    ],
)
def test_names_that_fail_with_a_budget_are_refused_saying_why(name: str, why: str) -> None:
    for budget, batch_size in [(20, 1), (200, 8), (None, 4)]:
        message = refusal(name, budget, batch_size)
        assert why in message and "measured on nevergrad" in message


@pytest.mark.slow
def test_every_name_of_the_table_is_refused_with_its_reason() -> None:
    known = set(ng.optimizers.registry)
    for name, why in support.FAILS.items():
        if name in known:
            assert why in refusal(name, 200, 1)
    for name in support.NEEDS_BUDGET & known:
        assert "fails without a budget" in refusal(name, None, 1)
        assert "give budget=..." in refusal(name, None, 1)
    for name in support.SEQUENTIAL & known:
        message = refusal(name, 200, 4)
        assert "fails with batch_size=4" in message and "give batch_size=1" in message


@needs_measured_version
@pytest.mark.filterwarnings("ignore:COBYLA. Invalid RHOEND:UserWarning")  # NGOpt16's Cobyla
@pytest.mark.parametrize("name", ["Shiwa", "NGO", "NgIohRW2", "NGOpt16"])
def test_sampled_meta_optimizers_with_a_budget_run_reproducibly(name: str) -> None:
    assert issubclass(ng.optimizers.registry[name], ng.optimizers.NGOptBase)
    assert "fails without a budget" in refusal(name, None, 4)
    batch_size = 1 if name in support.SEQUENTIAL else 4
    first = make(name, budget=40, batch_size=batch_size, seed=5)
    asked = rounds(first, 3)
    assert asked == rounds(make(name, budget=40, batch_size=batch_size, seed=5), 3)
    restored = pickle.loads(pickle.dumps(first))
    assert rounds(restored, 2) == rounds(first, 2)


@needs_measured_version
def test_a_sequential_name_is_refused_with_batches_and_taken_without() -> None:
    assert "Powell" in support.SEQUENTIAL
    refusal("Powell", 40, 4)
    rounds(make("Powell", budget=40, batch_size=1), 3)


def test_a_backend_run_in_a_thread_is_replayed_after_loading(tmp_path: Path) -> None:
    # Powell runs scipy in a thread: no pickle, so a saved state rebuilds it and replays the log.
    uninterrupted = make("Powell", budget=60, batch_size=1, seed=2)
    expected = rounds(uninterrupted, 12)
    interrupted = make("Powell", budget=60, batch_size=1, seed=2)
    assert rounds(interrupted, 6) == expected[:6]
    pending = interrupted.ask()
    assert interrupted.__getstate__()["_backend"] is None  # the replay path, not a pickle
    interrupted.save_state(tmp_path / "state.pkl")
    restored = optimizers.Optimizer.load_state(tmp_path / "state.pkl")
    assert restored.pending_ids == pending.ids
    restored.tell(pending.ids, shifted_sphere(pending.x))
    assert [np.asarray(pending.x).tolist(), *rounds(restored, 5)] == expected[6:]
    # ... and a backend that pickles is pickled, not replayed.
    assert isinstance(make("TwoPointsDE").__getstate__()["_backend"], bytes)


def test_a_replay_that_asks_other_points_is_refused(tmp_path: Path) -> None:
    optimizer = make("Powell", budget=60, batch_size=1, seed=2)
    rounds(optimizer, 3)
    i, point = optimizer._log[2]
    optimizer._log[2] = (i, point + 1e-9)  # as if the backend had changed
    optimizer.save_state(tmp_path / "state.pkl")
    with pytest.raises(ValueError, match="'Powell' asked another point when replayed"):
        optimizers.Optimizer.load_state(tmp_path / "state.pkl")


def test_the_budget_is_rounded_up_to_whole_batches() -> None:
    # A low-discrepancy sequence of exactly `budget` points: 3 batches of 8 need 24.
    optimizer = make("HaltonSearch", budget=20, batch_size=8)
    assert optimizer._optimizer.budget == 24
    rounds(optimizer, 3)


def test_a_backend_drawing_from_np_random_draws_from_its_own_stream() -> None:
    # LognormalDiscreteOnePlusOne calls np.random.randn() in its mutation.
    alone = rounds(make("LognormalDiscreteOnePlusOne", seed=1), 4)
    optimizer = make("LognormalDiscreteOnePlusOne", seed=1)
    start = optimizer._global._state[1].copy()
    asked = []
    for k in range(4):
        np.random.seed(k)  # noqa: NPY002 - the caller's own draws must not shift it
        before = np.random.get_state(legacy=True)  # noqa: NPY002
        asked += rounds(optimizer, 1)
        after = np.random.get_state(legacy=True)  # noqa: NPY002
        assert np.array_equal(before[1], after[1]) and before[2] == after[2]
    assert asked == alone
    assert not np.array_equal(optimizer._global._state[1], start)  # its stream was used


# Nevergrad's scipy-based optimizers refuse num_workers > 1 in __init__; their __del__ then trips
# over an attribute __init__ never set.
nevergrads_del = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")


@pytest.mark.slow
@nevergrads_del
def test_names_the_table_does_not_know_fall_back_to_the_class_rule_and_nevergrads_errors(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # As with another Nevergrad version, whose names the table may not list.
    monkeypatch.setattr(support, "NEEDS_BUDGET", frozenset())
    monkeypatch.setattr(support, "SEQUENTIAL", frozenset())
    assert "fails without a budget" in refusal("Shiwa", None, 4)  # a subclass of NGOptBase
    message = refusal("Powell", 40, 4)
    assert "could not be made with budget=40, batch_size=4" in message
    assert "does not support parallelization" in message
    gc.collect()  # that __del__ runs now, under the filter


def test_the_survey_classifies_failures_by_the_settings_they_happen_in() -> None:
    def result(*failing: tuple[int | None, int]) -> dict[str, Any]:
        settings = {}
        for budget in nevergrad_survey.BUDGETS:
            for batch_size in nevergrad_survey.BATCH_SIZES:
                key = nevergrad_survey._key(budget, batch_size)
                settings[key] = {"ok": True}
                if (budget, batch_size) in failing:
                    settings[key] = {"ok": False, "stage": "run", "error": "E: x", "where": "f:1"}
        return {"settings": settings}

    numpy2 = "TypeError: only 0-dimensional arrays can be converted to Python scalars"
    assert nevergrad_survey.classify(result()) == ("ok", None)
    assert nevergrad_survey.classify(result((None, 1), (None, 8)))[0] == "needs budget"
    assert nevergrad_survey.classify(result((20, 4), (200, 8)))[0] == "sequential"
    assert nevergrad_survey.classify(result((None, 1), (60, 4)))[0] == "both"
    failed = result((None, 1), (200, 1))
    failed["settings"]["budget=200,batch=1"]["error"] = numpy2
    rule, why = nevergrad_survey.classify(failed)
    assert rule == "fails" and why is not None and why.startswith("raises TypeError on numpy 2")
    assert "budget=200, batch_size=1" in why
    rule, why = nevergrad_survey.classify({"timeout": 90.0})
    assert rule == "fails" and why is not None
    assert why.startswith("is too slow to be checked: its runs in the survey timed out after 90 s")


@pytest.mark.slow
@nevergrads_del
def test_the_survey_probes_a_setting_in_this_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(nevergrad_adapter, "_refusal", lambda *args: None)  # as the survey does
    state = str(tmp_path / "state.pkl")
    good = nevergrad_survey.probe_setting("TwoPointsDE", 20, 4, state)
    assert good["ok"] and good["digest"] != good["tail"]
    assert nevergrad_survey.recheck_setting("TwoPointsDE", 20, 4, state, good) == good
    bad = nevergrad_survey.probe_setting("Powell", 20, 4, state)
    assert not bad["ok"] and bad["stage"] == "construct"
    assert "does not support parallelization" in bad["error"]
    gc.collect()  # Nevergrad's __del__ of the object it could not build runs now, filtered


def test_the_adapter_module_names_the_version_its_rule_was_measured_on() -> None:
    doc = nevergrad_adapter.__doc__ or ""
    assert f"nevergrad {support.MEASURED_ON['nevergrad']}" in doc


def test_a_state_of_the_adapter_before_replays_still_loads_and_continues() -> None:
    # Saved before the adapter kept seeds and a log: its pickle held the backend itself.
    optimizer = make("TwoPointsDE", seed=4)
    rounds(optimizer, 2)
    old = {k: v for k, v in optimizer.__dict__.items() if k not in ("_spec", "_log", "_global")}
    expected = rounds(pickle.loads(pickle.dumps(optimizer)), 2)
    restored = nevergrad_adapter.NevergradOptimizer.__new__(nevergrad_adapter.NevergradOptimizer)
    restored.__setstate__(pickle.loads(pickle.dumps(old)))
    assert rounds(restored, 2) == expected
    assert pickle.loads(pickle.dumps(restored)).n_told == restored.n_told  # saves again
