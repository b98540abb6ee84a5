"""Bad input at every public entry point gives a TypeError/ValueError naming it (issue #10).

The cases found by the fuzzing pass first, then properties over the action space, the env
options, the configuration fields and suite config files. ``tests/test_fuzz_inputs.py`` runs the
fuzzer's wider net of values through every entry point as Hypothesis properties.
"""

from __future__ import annotations

import dataclasses
import fractions
import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import optimizers
from benchmarks.cli import main
from benchmarks.design import DesignConfig
from benchmarks.suites import (
    OptimizerSpec,
    SuiteConfig,
    builtin_suite,
    load_suite,
    save_suite,
    suite_from_json,
)
from benchmarks.suites.config import N_SEEDS_MAX
from optimizers import BATCH_SIZE_MAX, BOUND_MAX, VALUE_MAX
from tooldesign_env import ToolDesignEnv
from tooldesign_env.geometry import ToolSpec
from tooldesign_env.specs import (
    BOX_MASS_MAX,
    GOAL_PRECISION_MAX,
    ControllerSpec,
    ObjectiveSpec,
    PlanSpec,
    SceneSpec,
    TaskSpec,
    spec_to_dict,
)

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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize("options", ["", 0, False, [], "goal"])
def test_reset_options_must_be_none_or_a_mapping(env, options):
    # "", 0 and False were read as no options by `options or {}`.
    with pytest.raises(TypeError, match="options must be None or a mapping"):
        env.reset(options=options)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [np.int64(3), np.uint16(3)])
def test_a_numpy_integer_seed_is_taken_as_the_int(seed):
    # gymnasium refused it: "Seed must be a python integer".
    made = ToolDesignEnv(randomize_goal=True)
    try:
        drawn = made.reset(seed=seed)[0]
        np.testing.assert_array_equal(drawn, made.reset(seed=3)[0])
    finally:
        made.close()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("seed", "error"),
    [(True, TypeError), (np.bool_(False), TypeError), (3.0, TypeError), (-1, ValueError)],
)
def test_a_seed_that_is_not_an_int_is_refused_naming_it(env, seed, error):
    with pytest.raises(error, match="seed must be an int >= 0 or None"):
        env.reset(seed=seed)


@pytest.mark.slow
def test_goal_precision_maximum_keeps_free_energy_finite():
    # The worst goal error: 10 m from the goal for 10^4 control steps at the largest p^X.
    spec = ObjectiveSpec(goal_precision=GOAL_PRECISION_MAX)
    assert math.isfinite(1e4 * 0.5 * spec.goal_precision * 10.0**2)


# Every vector field of the specs, with a valid value of it.
SPEC_VECTORS = [
    (SceneSpec, "box_size", (0.2, 0.1, 0.15)),
    (SceneSpec, "box_position", (1.0, 0.5)),
    (ControllerSpec, "torque_limits", (80.0, 80.0, 80.0, 80.0, 10.0, 10.0, 10.0)),
    (TaskSpec, "goal", (1.0, 0.5, 0.1)),
    (ObjectiveSpec, "scene_jitter", (0.002, 0.02)),
    (ObjectiveSpec, "expected_masses", (0.5, 2.0, 1.0)),
]


@pytest.mark.slow
@pytest.mark.parametrize(
    "make_goal", [set, frozenset, dict.fromkeys, lambda v: dict.fromkeys(v).keys()]
)
def test_a_goal_without_order_is_refused_not_reordered(make_goal):
    goal = make_goal([1.0, 0.5, 0.1])  # a set iterates as 0.5, 1.0, 0.1
    with pytest.raises(TypeError, match=r"goal must be 3 numbers \(x, y, z\) in m, in order"):
        ToolDesignEnv(goal=goal)
    with pytest.raises(TypeError, match="in order"):
        gym.make("ToolDesign-v0", goal=goal)


@pytest.mark.parametrize(("spec", "field", "value"), SPEC_VECTORS)
@pytest.mark.parametrize("unordered", [set, lambda v: dict.fromkeys(v), lambda v: {0: v}.values()])
def test_spec_vectors_without_order_are_refused_naming_the_field(spec, field, value, unordered):
    with pytest.raises(TypeError, match=rf"{spec.__name__}\.{field} must be .*in order"):
        spec(**{field: unordered(value)})


@pytest.mark.parametrize(("spec", "field", "value"), SPEC_VECTORS)
@pytest.mark.parametrize(
    "convert", [np.array, list, lambda v: np.array(v, dtype=np.float32).astype(np.float64)]
)
def test_spec_vectors_are_stored_as_tuples_of_floats(spec, field, value, convert):
    made = spec(**{field: convert(value)})
    stored = getattr(made, field)
    assert type(stored) is tuple and all(type(v) is float for v in stored)
    assert made == spec(**{field: tuple(float(v) for v in convert(value))})
    hash(made)
    json.dumps(spec_to_dict(made))


def _real_fields(spec):
    defaults = spec()
    return [
        f.name
        for f in dataclasses.fields(spec)
        if type(getattr(defaults, f.name)) is float  # not the ints, bools and strings
    ]


@pytest.mark.parametrize("spec", [SceneSpec, PlanSpec, ControllerSpec, ObjectiveSpec, ToolSpec])
@pytest.mark.parametrize("kind", [fractions.Fraction, np.float64])
def test_real_spec_fields_are_stored_as_floats(spec, kind):
    names = _real_fields(spec)
    assert names
    for name in names:
        made = spec(**{name: kind(getattr(spec(), name))})  # the default, exactly
        assert type(getattr(made, name)) is float, name
        json.dumps(spec_to_dict(made))


@pytest.mark.slow
def test_goal_precision_given_as_a_fraction_reaches_info_as_a_float():
    spec = ObjectiveSpec(goal_precision=fractions.Fraction(20))
    assert type(spec.goal_precision) is float
    env = ToolDesignEnv(goal_precision=fractions.Fraction(20))
    try:
        assert type(env.objective.goal_precision) is float
    finally:
        env.close()


def test_numpy_flags_and_counts_of_specs_are_stored_as_python_values():
    scene = SceneSpec(fast_forward_rest=np.True_, merge_fixed_links=np.False_)
    assert scene.fast_forward_rest is True and scene.merge_fixed_links is False
    objective = ObjectiveSpec(scene_samples=np.int64(2), scene_seed=np.uint32(7))
    assert type(objective.scene_samples) is int and type(objective.scene_seed) is int
    json.dumps(spec_to_dict(scene))
    json.dumps(spec_to_dict(objective))


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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
    # A longdouble beyond float64 became inf, a failed evaluation, where the int was refused.
    huge = np.longdouble(10) ** 4000
    with pytest.raises(ValueError, match=r"fit a float64.*entry 0"):
        opt.tell(batch.ids, [huge, 1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"fit a float64.*entry 2"):
        opt.tell(batch.ids, np.array([1.0, 1.0, huge, 1.0], dtype=np.longdouble))
    with pytest.raises(ValueError, match="values must lie within"):
        opt.tell(batch.ids, [1e308, 1.0, 1.0, 1.0])
    opt.tell(batch.ids, [1.0, 2.0, 3.0, 4.0])  # a refused tell leaves the batch pending
    assert opt.n_told == 4


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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
    if argv[-1] == "0":  # only --out is wrong: the message says what it is and what is wanted
        assert f"{existing} is a file; give a folder" in err[0]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("key", "value", "flag"),
    [
        ("seed", "5", "--seed"),
        ("batch_size", "4", "--batch-size"),
        ("bounds", "[[0,1],[0,1],[0,1]]", "coefficient bounds"),
        ("low", "[0,0,0]", "coefficient bounds"),
        ("high", "[1,1,1]", "coefficient bounds"),
    ],
)
def test_an_option_the_design_sets_itself_is_refused_naming_its_flag(
    key, value, flag, tmp_path, capsys
):
    # It reached optimizers.make twice: "got multiple values for keyword argument 'seed'".
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as stop:
        main(["design", "--optimizer", "random", "--option", f"{key}={value}", "--out", str(out)])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--option {key}=...: " in err[0] and flag in err[0], err
    assert not out.exists()
    with pytest.raises(ValueError, match=f"optimizer_settings must not set '{key}'"):
        DesignConfig(optimizer="random", optimizer_settings={key: json.loads(value)})


@pytest.mark.slow
@pytest.mark.parametrize(
    ("key", "field"), [("seed", "seeds"), ("batch_size", "batch_size"), ("low", "bounds")]
)
def test_a_suite_optimizer_setting_the_suite_sets_itself_is_refused(key, field, tmp_path, capsys):
    with pytest.raises(ValueError, match=f"settings of random must not set '{key}': .*{field}"):
        OptimizerSpec(name="random", settings={key: 1})
    data = json.loads(json.dumps(builtin_suite("optimizers").to_json()))
    data["optimizers"][0]["settings"][key] = 1
    path = tmp_path / "suite.json"
    path.write_text(json.dumps(data))
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as stop:
        main(["bench", "--config", str(path), "--out", str(out), "--no-progress"])
    assert stop.value.code == 2
    assert f"must not set '{key}'" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.slow
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


# --- suite config files ------------------------------------------------------------------------

SUITE = {"name": "fuzz", "optimizers": [{"name": "random"}], "n_seeds": 1, "iterations": 1}


def _number_in(low: float, high: float, *, integer: bool = False):
    def allowed(value: object) -> bool:
        if integer and not isinstance(value, int):
            return False
        return _is_number(value) and low <= value <= high  # type: ignore[operator]

    return allowed


def _is_x_range(value: object) -> bool:
    """A valid x row of a goal box: [low, high] in the workspace's x range, low <= high."""
    return (
        isinstance(value, list)
        and len(value) == 2
        and all(_number_in(-2.5, 2.5)(v) for v in value)
        and value[0] <= value[1]
    )


def _is_goal(value: object) -> bool:
    """A valid goal: 3 numbers within the workspace (e.g. [0.0, 0.0, 0.0], on the floor)."""
    from tooldesign_env.env import WORKSPACE_HIGH, WORKSPACE_LOW

    return (
        isinstance(value, list)
        and len(value) == 3
        and all(
            _number_in(low, high)(v)
            for v, low, high in zip(value, WORKSPACE_LOW, WORKSPACE_HIGH, strict=True)
        )
    )


# (the field the error must name, where the value goes in a valid suite, which values are valid)
SUITE_PLACES = [
    ("name", lambda v: {"name": v}, lambda v: isinstance(v, str) and v.strip() == v != ""),
    # null is the task's default goal (review 43: a config without a goal takes its task's).
    ("goal", lambda v: {"goal": v}, lambda v: v is None or _is_goal(v)),
    ("goal", lambda v: {"goal": [v, 1.5, 0.1]}, _number_in(-2.5, 2.5)),
    ("goal_box", lambda v: {"goal_box": [v, [0, 1], [0, 1]]}, lambda v: _is_x_range(v)),
    ("goal_box x", lambda v: {"goal_box": [[v, 0.5], [0, 1], [0, 1]]}, _number_in(-2.5, 0.5)),
    ("goal_precision", lambda v: {"goal_precision": v}, _number_in(0, GOAL_PRECISION_MAX)),
    ("box_mass", lambda v: {"box_mass": v}, lambda v: _number_in(0, BOX_MASS_MAX)(v) and v > 0),
    ("bounds", lambda v: {"bounds": [[-1.0, v]] * 3}, lambda v: _number_in(-1, 1e3)(v) and v > -1),
    ("variants", lambda v: {"variants": v}, lambda v: False),
    ("variant name", lambda v: {"variants": [{"name": v}]}, lambda v: isinstance(v, str)),
    (
        "goal_precision",
        lambda v: {"variants": [{"goal_precision": v}]},
        lambda v: v is None or _number_in(0, GOAL_PRECISION_MAX)(v),
    ),
    ("optimizers", lambda v: {"optimizers": [v]}, lambda v: False),
    (
        "settings of random",
        lambda v: {"optimizers": [{"name": "random", "settings": v}]},
        lambda v: _settings_ok(v) and _is_finite_json(v),
    ),
    ("batch_size", lambda v: {"batch_size": v}, _number_in(1, BATCH_SIZE_MAX, integer=True)),
    ("iterations", lambda v: {"iterations": v}, _number_in(1, 2**63 - 1, integer=True)),
    ("root_seed", lambda v: {"root_seed": v}, _number_in(0, 2**63 - 1, integer=True)),
    ("n_seeds", lambda v: {"n_seeds": v}, _number_in(1, N_SEEDS_MAX, integer=True)),
    (
        "workers",
        lambda v: {"workers": v},
        lambda v: v is None or _number_in(1, 1024, integer=True)(v),
    ),
    ("max_retries", lambda v: {"max_retries": v}, _number_in(0, 100, integer=True)),
    ("test_robustness", lambda v: {"test_robustness": v}, lambda v: isinstance(v, bool)),
    ("robustness_masses", lambda v: {"robustness_masses": [0.5, v]}, _number_in(1e-300, 1e3)),
    ("figures", lambda v: {"figures": [v]}, lambda v: False),
]

JSON = st.recursive(
    st.one_of(
        st.none(),
        st.booleans(),
        st.text(max_size=5),
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(min_value=-(10**400), max_value=10**400),
    ),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner),
    max_leaves=6,
)


def _settings_ok(value: object) -> bool:
    if isinstance(value, list):
        return value == []
    return isinstance(value, dict) and all(k.isidentifier() for k in value)  # JSON: str keys


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(place=st.sampled_from(SUITE_PLACES), value=st.one_of(ANY, JSON))
def test_suite_file_fields_accept_only_valid_values(tmp_path_factory, place, value):
    field, put, allowed = place
    path = tmp_path_factory.mktemp("suite") / "suite.json"
    path.write_text(json.dumps({**SUITE, **put(value)}), encoding="utf-8")  # NaN as NaN
    try:
        suite = load_suite(path)
    except (TypeError, ValueError) as error:
        message = str(error)
        assert message.startswith(str(path)) and field in message, message
        assert "\n" not in message and len(message) < 5000  # bounds echo 3 ints of 400 digits
    else:
        assert allowed(value), value
        assert len(suite.tasks()) == suite.n_seeds


def _is_finite_json(value: object) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, int) and not isinstance(value, bool):
        return abs(value) < 2**1024
    if isinstance(value, list):
        return all(_is_finite_json(v) for v in value)
    if isinstance(value, dict):
        return all(_is_finite_json(v) for v in value.values())
    return True


@pytest.mark.slow
@settings(max_examples=100, deadline=None)
@given(key=st.text(min_size=1, max_size=8), value=JSON, nested=st.booleans())
def test_unknown_suite_keys_are_named(key, value, nested):
    fields = {"name", "variants", "optimizers", "n_seeds", "iterations", "label", "settings"}
    assume(key not in fields and key not in SuiteConfig.__dataclass_fields__)
    data = {**SUITE, **({"variants": [{key: value}]} if nested else {key: value})}
    with pytest.raises(ValueError, match="unknown keys") as error:
        suite_from_json(data, where="suite.json")
    assert repr(key) in str(error.value)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(data=st.data(), suffix=st.sampled_from([".json", ".toml"]))
def test_edited_suite_files_are_accepted_or_refused_naming_the_file(tmp_path_factory, data, suffix):
    folder = tmp_path_factory.mktemp("edit")
    valid = save_suite(builtin_suite("robustness", "smoke"), folder / f"valid{suffix}")
    text = valid.read_text(encoding="utf-8")
    start = data.draw(st.integers(0, len(text)))
    end = data.draw(st.integers(start, min(len(text), start + 30)))
    insert = data.draw(st.text(alphabet='{}[]",:=.-+eE019 \n\tnaNIfy\x00', max_size=4))
    path = folder / f"edited{suffix}"
    path.write_text(text[:start] + insert + text[end:], encoding="utf-8")
    try:
        load_suite(path).tasks()
    except (TypeError, ValueError) as error:
        assert str(path) in str(error)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        # Each was a traceback, a message naming no field, or a value accepted, before.
        ("box.json", {"goal_box": [[10**400, 1], [0, 1], [0, 1]]}, "goal_box x"),
        ("figure.json", {"figures": [["x"]]}, "figures: unknown figure"),
        ("settings.json", {"optimizers": [{"name": "random", "settings": ""}]}, "settings of"),
        ("big.json", {"optimizers": [{"name": "cmaes", "settings": {"sigma0": 10**400}}]}, "JSON"),
        ("seeds.json", {"n_seeds": 10**12}, "n_seeds must be from 1 to 10000"),
        ("seed.json", {"root_seed": 10**400}, "root_seed must be from 0"),
        ("masses.json", {"robustness_masses": [1e300]}, "robustness_masses"),
        ("workers.json", {"workers": 10**6}, "workers must be <= 1024"),
        ("batch.json", {"batch_size": 10**9}, "batch_size must be from 1 to 10000"),
        ("goal.json", {"goal": [1e200, 1.5, 0.1]}, "outside the workspace"),
        ("p.json", {"variants": [{"goal_precision": 10**400}]}, "goal_precision"),
        ("long.json", {"variants": [{"name": "a" * 300}]}, "at most 200 characters"),
        ("deep.json", "[" * 100_000 + "]" * 100_000, "nests lists or tables too deeply"),
        ("binary.json", b"\xff\xfe{}", "not UTF-8"),
    ],
)
def test_suite_files_found_by_fuzzing_exit_2_with_one_line(tmp_path, capsys, name, content, match):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    else:
        path.write_text(json.dumps({**SUITE, **content}), encoding="utf-8")
    with pytest.raises((TypeError, ValueError), match=match):
        load_suite(path)
    # A good --out (a bad one is refused first, before the suite file is read): the refusal
    # names the suite file, and the run folder is never made.
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as stop:
        main(["bench", "--config", str(path), "--out", str(out), "--no-progress"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "Traceback" not in err[0], err
    assert not out.exists()


@pytest.mark.slow
def test_an_ordered_array_like_goal_is_taken_in_its_order():
    """A pandas Series (or any 1-D ordered array-like) was accepted before the set check."""
    pd = pytest.importorskip("pandas")
    from tooldesign_env import ToolDesignEnv

    env = ToolDesignEnv(goal=pd.Series([0.0, 1.4, 0.1]))
    try:
        assert env.task.goal == (0.0, 1.4, 0.1)
        assert all(type(v) is float for v in env.task.goal)
    finally:
        env.close()
    with pytest.raises(ValueError, match="TaskSpec.goal must be 3 finite numbers in order"):
        ToolDesignEnv(goal=np.zeros((1, 3)))


@pytest.mark.slow
def test_retest_masses_and_frictions_without_order_are_refused():
    from benchmarks.suites.retest import RetestConfig

    with pytest.raises(TypeError, match=r"RetestConfig.masses must be numbers in order"):
        RetestConfig(masses={0.9, 0.3, 0.5})
    with pytest.raises(TypeError, match=r"RetestConfig.frictions must be numbers in order"):
        RetestConfig(frictions={0.2: 1, 0.6: 2})
    assert RetestConfig(masses=[0.9, 0.3]).masses == (0.9, 0.3)  # the order given
