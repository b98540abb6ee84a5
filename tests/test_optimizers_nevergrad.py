"""The ``nevergrad`` adapter: its replayed backends, its budget, its own np.random stream.

Also the classification of ``tests/nevergrad_survey.py``, the survey of Nevergrad's registry.
"""

from __future__ import annotations

import gc
import importlib.util
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import optimizers
from optimizers import nevergrad_adapter
from optimizers.testing import BOUNDS, shifted_sphere

if importlib.util.find_spec("nevergrad") is None:
    pytest.skip("nevergrad is not installed", allow_module_level=True)

sys.path.insert(0, str(Path(__file__).resolve().parent))
import nevergrad_survey  # noqa: E402

ALTERNATIVES = ("'TwoPointsDE'", "'CMA'", "'PSO'", "'OnePlusOne'")


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


@nevergrads_del
def test_a_name_nevergrad_cannot_build_is_a_value_error_naming_it() -> None:
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
