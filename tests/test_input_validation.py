"""Bad input at every public entry point gives a TypeError/ValueError naming it (issue #10).

The cases found by the fuzzing pass first, then properties over the action space, the env
options and the configuration fields. ``benchmarks/perf/fuzz_inputs.py`` is the rerunnable
version over many more inputs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import optimizers
from benchmarks.cli import main
from benchmarks.design import DesignConfig
from optimizers._validation import BATCH_SIZE_MAX, BOUND_MAX, VALUE_MAX
from tooldesign_env import ToolDesignEnv
from tooldesign_env.specs import BOX_MASS_MAX, GOAL_PRECISION_MAX, ObjectiveSpec

ANY = st.one_of(
    st.booleans(),
    st.none(),
    st.text(max_size=5),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.lists(st.floats(), max_size=3),
)


def _is_number(value: object) -> bool:
    return (
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and abs(value) < 1e308
        and math.isfinite(value)
    )


@pytest.fixture(scope="module")
def env():
    e = ToolDesignEnv()
    yield e
    e.close()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"goal_precision": 1e308}, ValueError, "goal_precision must be <= 1e\\+06"),
        ({"goal_precision": True}, TypeError, "goal_precision must be a real number, got True"),
        ({"goal_precision": "20"}, TypeError, "goal_precision must be a real number, got '20'"),
        ({"box_mass": True}, TypeError, "box_mass must be a real number, got True"),
        ({"box_mass": 1e300}, ValueError, "box_mass must be <= 1000 kg"),
        ({"randomize_goal": "no"}, TypeError, "randomize_goal must be True or False, got 'no'"),
        ({"bounds": [[-1e308, 1e308]] * 3}, ValueError, "bounds must lie within"),
        ({"bounds": [[-1, True]] * 3}, TypeError, "bounds must be"),
        ({"goal": (True, 1.5, 0.1)}, TypeError, "goal must be a real number, got True"),
        ({"goal": "abc"}, TypeError, "goal must be 3 numbers"),
    ],
)
def test_env_constructor_refuses_found_cases(kwargs, error, match):
    with pytest.raises(error, match=match):
        ToolDesignEnv(**kwargs)


@pytest.mark.parametrize(
    ("options", "error"),
    [
        ({"box_mass": 10**400}, ValueError),
        ({"box_mass": 1e300}, ValueError),
        ({"box_mass": np.float32("nan")}, ValueError),
        ({"goal": (10**400, 1.5, 0.1)}, ValueError),
        ({"goal": (True, 1.5, 0.1)}, TypeError),
    ],
)
def test_reset_refuses_found_cases(env, options, error):
    with pytest.raises(error, match="options"):
        env.reset(options=options)


def test_goal_precision_maximum_keeps_free_energy_finite():
    # The worst goal error: 10 m from the goal for 10^4 control steps at the largest p^X.
    spec = ObjectiveSpec(goal_precision=GOAL_PRECISION_MAX)
    assert math.isfinite(1e4 * 0.5 * spec.goal_precision * 10.0**2)


@settings(max_examples=60, deadline=None)
@given(value=ANY)
def test_env_numbers_accept_only_numbers(value):
    for key in ("goal_precision", "box_mass"):
        try:
            ToolDesignEnv(**{key: value}).close()
        except (TypeError, ValueError) as error:
            assert key in str(error)
        else:
            assert value is None or _is_number(value)


@settings(max_examples=100, deadline=None)
@given(action=st.lists(ANY, min_size=0, max_size=4))
def test_action_check_accepts_only_numbers_in_the_box(env, action):
    try:
        coeffs = env.check_action(action)
    except (TypeError, ValueError) as error:
        assert "coeffs" in str(error) or "action" in str(error)
    else:
        assert len(action) == 3 and all(_is_number(v) for v in action)
        assert env.action_space.contains(coeffs)
        assert coeffs.tolist() == [float(v) for v in action]  # unchanged, bit for bit


@settings(max_examples=60, deadline=None)
@given(mass=ANY, goal_x=ANY)
def test_reset_options_accept_only_numbers(env, mass, goal_x):
    try:
        _, info = env.reset(options={"box_mass": mass, "goal": (goal_x, 1.5, 0.1)})
    except (TypeError, ValueError) as error:
        assert "options[" in str(error)
    else:
        assert _is_number(mass) and 0 < mass <= BOX_MASS_MAX
        assert _is_number(goal_x) and info["goal"][0] == goal_x


@pytest.mark.parametrize("name", optimizers.available())
def test_optimizers_refuse_found_cases(name):
    with pytest.raises(ValueError, match="bounds must lie within"):
        optimizers.make(name, bounds=[[-1e308, 1e308]] * 2, batch_size=4)
    with pytest.raises(ValueError, match=f"batch_size must be <= {BATCH_SIZE_MAX}"):
        optimizers.make(name, bounds=[[0, 1]] * 2, batch_size=10**6)
    with pytest.raises(ValueError, match="seed must be an int in"):
        optimizers.make(name, bounds=[[0, 1]] * 2, batch_size=4, seed=99999999999999999999)
    opt = optimizers.make(name, bounds=[[0, 1]] * 2, batch_size=4, seed=0)
    batch = opt.ask()
    with pytest.raises(ValueError, match="fit a float64|within"):
        opt.tell(batch.ids, [10**400, 1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="values must lie within"):
        opt.tell(batch.ids, [1e308, 1.0, 1.0, 1.0])
    opt.tell(batch.ids, [1.0, 2.0, 3.0, 4.0])  # a refused tell leaves the batch pending
    assert opt.n_told == 4


@settings(max_examples=60, deadline=None)
@given(low=ANY, high=ANY)
def test_optimizer_bounds_accept_only_numbers(low, high):
    try:
        opt = optimizers.make("random", bounds=[[low, high]], batch_size=2, seed=0)
    except (TypeError, ValueError) as error:
        assert "bounds" in str(error)
    else:
        assert _is_number(low) and _is_number(high) and low < high
        assert max(abs(low), abs(high)) <= BOUND_MAX
        assert np.all(np.isfinite(opt.ask().x))


@settings(max_examples=60, deadline=None)
@given(value=st.one_of(ANY, st.floats(-1e120, 1e120)))
def test_tell_values(value):
    opt = optimizers.make("random", bounds=[[0, 1]], batch_size=1, seed=0)
    batch = opt.ask()
    try:
        opt.tell(batch.ids, [value])
    except (TypeError, ValueError) as error:
        assert "values" in str(error)
    else:
        finite = _is_number(value) and abs(value) <= VALUE_MAX
        non_finite = value is None or (isinstance(value, float) and not math.isfinite(value))
        assert finite or non_finite


@settings(max_examples=60, deadline=None)
@given(value=ANY)
def test_design_config_fields(value):
    for key in ("seed", "iterations", "batch_size", "goal_precision", "box_mass"):
        try:
            DesignConfig(**{key: value})
        except (TypeError, ValueError) as error:
            assert key in str(error)
        else:
            assert _is_number(value)


@pytest.mark.parametrize(
    "argv",
    [
        ["design", "--seed", "99999999999999999999"],
        ["design", "--batch-size", "1000000"],
        ["design", "--goal-precision", "1e308"],
        ["evaluate", "--coeffs", "0", "0", "0", "--goal-precision", "1e308"],
        ["evaluate", "--coeffs", "0", "0", "0"],  # --out is an existing file
    ],
)
def test_cli_errors_are_one_line_exit_2(argv, tmp_path, capsys):
    existing = tmp_path / "file"
    existing.write_text("x")
    with pytest.raises(SystemExit) as stop:
        main([*argv, "--out", str(existing)])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0] and "Traceback" not in err[0]


def test_report_of_an_existing_file_exits_2(tmp_path: Path, capsys):
    existing = tmp_path / "file"
    existing.write_text("x")
    with pytest.raises(SystemExit) as stop:
        main(["report", str(existing)])
    assert stop.value.code == 2


@pytest.mark.parametrize("name", ["random", "cmaes"])
def test_state_loads_only_with_the_recorded_digest(name, tmp_path: Path):
    opt = optimizers.make(name, bounds=[[0, 1]] * 2, batch_size=4, seed=0)
    opt.tell(opt.ask().ids, [1.0, 2.0, 3.0, 4.0])
    path = tmp_path / "state.pkl"
    digest = opt.save_state(path)
    again = optimizers.Optimizer.load_state(path, sha256=digest)
    assert np.array_equal(again.ask().x, opt.ask().x)
    data = path.read_bytes()
    for changed in (data[:-7], data[:40] + bytes([data[40] ^ 1]) + data[41:], b"\x80\x05junk"):
        path.write_bytes(changed)
        with pytest.raises(ValueError, match="was not loaded"):
            optimizers.Optimizer.load_state(path, sha256=digest)
        with pytest.raises(ValueError, match="optimizer state"):
            optimizers.Optimizer.load_state(path)
