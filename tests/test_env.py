"""ToolDesign-v0: the Gymnasium contract, the scene's outcomes, determinism and bad input."""

from __future__ import annotations

import copy
import itertools
import json
import os
import pickle
import subprocess
import sys
import tempfile
from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest
from scipy.stats import spearmanr

import tooldesign_env
from tooldesign_env import ObjectiveSpec, SceneSpec, ToolDesignEnv, evaluate_robustness, make_tool
from tooldesign_env.env import SERIES_KEYS

STRAIGHT = (0.0, 0.0, 0.0)
HOOK = (0.0, 1.5, 0.0)
START = np.array([*SceneSpec().box_position, 0.1])


@pytest.fixture(scope="module")
def env():
    e = gym.make("ToolDesign-v0", info_series=True)
    e.reset(seed=0)
    yield e
    e.close()


def radius(p):
    return float(np.hypot(p[0], p[1]))


@pytest.mark.slow
def test_make_after_import_and_by_module_path():
    assert "ToolDesign-v0" in gym.registry
    code = (
        "import gymnasium as gym; e = gym.make('tooldesign_env:ToolDesign-v0'); "
        "print(e.unwrapped.__class__.__name__); e.close()"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert out.stdout.strip().splitlines()[-1] == "ToolDesignEnv"


@pytest.mark.slow
def test_gymnasium_check_env(env):
    from gymnasium.utils.env_checker import check_env

    # The render check would open a 'human' window, which needs a display; rgb_array is
    # checked in test_rgb_array_render.
    check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.slow
def test_stable_baselines3_check_env(env):
    from stable_baselines3.common.env_checker import check_env

    check_env(env.unwrapped, warn=True)


@pytest.mark.slow
def test_step_contract_and_info_keys(env):
    obs, info = env.reset(seed=1)
    np.testing.assert_array_equal(obs, [0.0, 1.5, 0.1])
    assert env.observation_space.contains(obs)
    obs2, reward, terminated, truncated, info = env.step(np.array(STRAIGHT))
    assert terminated is True and truncated is False
    assert reward == -info["free_energy"]
    assert info["valid"] is True
    T = len(info["times"])
    assert info["box_trajectory"].shape == (T, 3)
    assert info["torques"].shape == (T, 7)
    assert info["free_energy"] == pytest.approx(info["goal_error"] - info["confidence"])
    np.testing.assert_allclose(info["goal_error"], info["goal_error_t"].sum())
    np.testing.assert_allclose(info["confidence"], info["confidence_t"].sum())
    limits = np.array([87, 87, 87, 87, 12, 12, 12])
    assert np.all(np.abs(info["torques"]) <= limits + 1e-9)
    assert_finite_info(info)


@pytest.mark.slow
def test_info_holds_scalars_unless_series_are_asked_for():
    e = gym.make("ToolDesign-v0")
    e.reset(seed=0)
    info = e.step(np.array(STRAIGHT))[4]
    e.close()
    assert not set(SERIES_KEYS) & set(info)
    for key, value in info.items():
        assert np.ndim(value) == 0 or key in ("coefficients", "goal"), key
    assert info["free_energy"] == pytest.approx(info["goal_error"] - info["confidence"])


def assert_finite_info(info):
    for key, value in info.items():
        if isinstance(value, (float, np.floating)):
            assert np.isfinite(value), key
        elif isinstance(value, np.ndarray) and value.dtype.kind == "f":
            assert np.all(np.isfinite(value)), key


@pytest.mark.slow
def test_straight_tool_pushes_the_box_to_the_goal(env):
    env.reset(seed=0)
    *_, info = env.step(STRAIGHT)
    assert info["final_distance"] < 0.15
    assert info["tracking_error"].max() < 0.01  # the controller follows the plan within 1 cm


@pytest.mark.slow
def test_a_hook_pulls_the_box_toward_the_base(env):
    env.reset(seed=0)
    *_, info = env.step(HOOK)
    final = info["box_trajectory"][-1]
    assert radius(START) - radius(final) >= 0.3


@pytest.mark.slow
def test_random_designs_give_spread_outcomes(env):
    env.reset(seed=0)
    space = env.action_space
    space.seed(7)
    distances = []
    for _ in range(32):
        *_, info = env.step(space.sample())
        assert_finite_info(info)
        distances.append(info["final_distance"])
    assert max(distances) - min(distances) >= 0.8


@pytest.mark.slow
def test_confidence_is_higher_in_contact():
    for estimator in ("contact", "trajectory", "resimulation"):
        e = ToolDesignEnv(estimator=estimator, info_series=True)
        e.reset(seed=0)
        for design in (STRAIGHT, HOOK):
            *_, info = e.step(design)
            c, touching = info["confidence_t"], info["contact"]
            assert touching.any() and (~touching).any()
            inside, outside = c[touching].mean(), c[~touching].mean()
            ratio = 2.5 if estimator == "trajectory" else 10.0
            assert inside > ratio * outside, (estimator, design, inside, outside)
        e.close()


@pytest.mark.slow
def test_estimators_agree_in_rank():
    rng = np.random.default_rng(11)
    designs = [STRAIGHT, HOOK, (1.5, -1.5, 0.5), (-1.5, 1.5, -0.5)]
    designs += [tuple(rng.uniform([-1.5, -1.5, -0.5], [1.5, 1.5, 0.5])) for _ in range(8)]
    scores = {}
    for estimator in ("contact", "trajectory", "resimulation"):
        e = ToolDesignEnv(estimator=estimator, info_series=True)
        e.reset(seed=0)
        scores[estimator] = [e.step(d)[4]["confidence"] for d in designs]
        e.close()
    rho = spearmanr(scores["trajectory"], scores["resimulation"]).statistic
    assert rho >= 0.8, rho
    rho = spearmanr(scores["contact"], scores["resimulation"]).statistic
    assert rho >= 0.8, rho


@pytest.mark.slow
def test_same_action_same_result_in_process_and_across_processes(env):
    env.reset(seed=3)
    a = env.step((0.3, -0.7, 0.2))[4]
    env.reset(seed=3)
    b = env.step((0.3, -0.7, 0.2))[4]
    np.testing.assert_array_equal(a["box_trajectory"], b["box_trajectory"])
    np.testing.assert_array_equal(a["torques"], b["torques"])
    assert a["free_energy"] == b["free_energy"]
    code = (
        "import json, gymnasium as gym, tooldesign_env; "
        "e = gym.make('ToolDesign-v0', info_series=True); "
        "e.reset(seed=3); info = e.step((0.3, -0.7, 0.2))[4]; "
        "print(json.dumps({'F': info['free_energy'], "
        "'X': info['box_trajectory'].tolist(), 'U': info['torques'].tolist()}))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    other = json.loads(out.stdout.strip().splitlines()[-1])
    assert other["F"] == a["free_energy"]
    np.testing.assert_array_equal(np.array(other["X"]), a["box_trajectory"])
    np.testing.assert_array_equal(np.array(other["U"]), a["torques"])


@pytest.mark.slow
def test_fast_forward_matches_full_simulation():
    full = ToolDesignEnv(scene=SceneSpec(fast_forward_rest=False), info_series=True)
    fast = ToolDesignEnv(info_series=True)
    for design in (STRAIGHT, HOOK):
        full.reset(seed=0)
        fast.reset(seed=0)
        a, b = full.step(design)[4], fast.step(design)[4]
        assert b["fast_forward_from"] < len(b["times"])
        assert np.abs(a["box_trajectory"] - b["box_trajectory"]).max() < 1e-3
    full.close()
    fast.close()


# ----------------------------------------------------------------- bad input
@pytest.mark.slow
@pytest.mark.parametrize(
    ("action", "error", "says"),
    [
        ([np.nan, 0.0, 0.0], ValueError, r"NaN or infinite values at index \[0\] \(\[nan"),
        ([np.inf, 0.0, 0.0], ValueError, r"NaN or infinite values at index \[0\] \(\[inf"),
        ([0.0, 0.0], ValueError, r"shape \(2,\), expected \(3,\)"),
        ([[0.0, 0.0, 0.0]], ValueError, r"shape \(1, 3\), expected \(3,\)"),
        (["a", "b", "c"], TypeError, r"not real numbers"),
        ("0 0 0", TypeError, r"got str"),
        (None, TypeError, r"got NoneType"),
        ([1e300, 0.0, 0.0], ValueError, r"\[1e\+300, 0.0, 0.0\] is outside the action space"),
    ],
)
def test_bad_actions_raise_clear_errors(env, action, error, says):
    env.reset(seed=0)
    # The message names the value and what is allowed.
    with pytest.raises(error, match=says) as excinfo:
        env.step(action)
    assert "allowed" in str(excinfo.value) or "[low, high]" in str(excinfo.value)


@pytest.mark.slow
def test_out_of_bounds_message_says_what_is_allowed(env):
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"outside the action space.*\[low, high\]"):
        env.step([2.0, 0.0, 0.0])


@pytest.mark.slow
def test_an_action_past_a_bound_by_rounding_is_that_bound():
    # Found by an audit: RescaleAction's corners (and a float32 copy of a bound) landed a few
    # ulps outside custom bounds, and 9 of 12 corner actions were refused.
    bounds = [[0.1, 0.7], [-0.3, 1.1], [-0.13, 0.37]]
    e = ToolDesignEnv(bounds=bounds)
    low, high = np.array(bounds).T
    rescaled = gym.wrappers.RescaleAction(e, -1.0, 1.0)
    for corner in itertools.product((-1.0, 1.0), repeat=3):
        coeffs = e.check_action(rescaled.action(np.array(corner)))
        assert np.all((low <= coeffs) & (coeffs <= high))
        assert np.allclose(coeffs, np.where(np.array(corner) > 0, high, low), rtol=0, atol=1e-12)
    single = e.check_action(high.astype(np.float32))  # 0.37 -> 0.3700000047, past the bound
    assert np.all(single <= high) and np.allclose(single, high, rtol=0, atol=1e-7)
    inside = np.array([0.3, 0.2, 0.1])
    assert np.array_equal(e.check_action(inside), inside)  # untouched inside the bounds
    # Past the rounding slack (1e-6 of the bounds' scale) an action is refused, not clipped.
    with pytest.raises(ValueError, match="outside the action space"):
        e.check_action(high + [0.0, 0.0, 2e-6])
    e.close()


@pytest.mark.slow
def test_a_tool_overlapping_the_box_is_invalid_not_a_crash():
    e = ToolDesignEnv(bounds=[(-10, 10)] * 3, info_series=True)
    e.reset(seed=0)
    # y = 4.35 u^2 passes through the box centre (u = 0.394 m, y = 0.675 m) at the start.
    _, reward, terminated, _, info = e.step((0.0, 4.35, 0.0))
    assert info["valid"] is False and "overlaps the box" in info["invalid_reason"]
    assert terminated and np.isfinite(reward)
    assert info["free_energy"] == pytest.approx(info["goal_error"] + info["penalty"])
    assert info["box_trajectory"].shape == (0, 3)
    assert_finite_info(info)
    e.close()


@pytest.mark.slow
def test_an_unbuildable_tool_is_invalid():
    e = ToolDesignEnv(bounds=[(-1e3, 1e3)] * 3)
    e.reset(seed=0)
    *_, info = e.step((1e3, -1e3, 0.0))
    assert info["valid"] is False and info["invalid_reason"].startswith("cannot be built")
    assert_finite_info(info)
    e.close()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("options", "error"),
    [
        ({"goal": (0.0, 1.5)}, ValueError),
        ({"goal": (np.nan, 1.5, 0.1)}, ValueError),
        ({"goal": (9.0, 1.5, 0.1)}, ValueError),
        ({"goal": "here"}, TypeError),
        ({"box_mass": -1.0}, ValueError),
        ({"box_mass": "heavy"}, TypeError),
        ({"speed": 3}, ValueError),
    ],
)
def test_bad_reset_options(env, options, error):
    with pytest.raises(error):
        env.reset(seed=0, options=options)


@pytest.mark.slow
@pytest.mark.parametrize(
    "kwargs",
    [
        {"render_mode": "video"},
        {"bounds": [(-1, 1)] * 2},
        {"bounds": [(1, -1)] * 3},
        {"goal_precision": -5.0},
        {"estimator": "guess"},
        {"goal": (0.0, 1.5)},
        {"box_mass": 0.0},
    ],
)
def test_bad_constructor_arguments(kwargs):
    with pytest.raises((ValueError, TypeError)):
        ToolDesignEnv(**kwargs)


@pytest.mark.slow
def test_human_render_without_display_says_so(monkeypatch):
    if not sys.platform.startswith("linux"):
        pytest.skip("the DISPLAY check is for Linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="rgb_array"):
        ToolDesignEnv(render_mode="human")


# ------------------------------------------------------------------- tasks
@pytest.mark.slow
def test_goal_randomization_is_seeded_and_in_the_papers_range():
    e = ToolDesignEnv(randomize_goal=True)
    goals = [e.reset(seed=s)[0] for s in range(20)]
    again = [e.reset(seed=s)[0] for s in range(20)]
    np.testing.assert_array_equal(goals, again)
    g = np.array(goals)
    assert np.all((g[:, 0] >= -0.5) & (g[:, 0] <= 0.5))
    assert np.all((g[:, 1] >= 0.5) & (g[:, 1] <= 1.5))
    assert np.all(g[:, 2] == 0.1)
    assert len({tuple(x) for x in goals}) == 20
    e.close()


@pytest.mark.slow
def test_reset_options_set_the_task(env):
    obs, info = env.reset(seed=0, options={"goal": (0.2, 1.0, 0.1), "box_mass": 0.5})
    np.testing.assert_array_equal(obs, [0.2, 1.0, 0.1])
    assert info["box_mass"] == 0.5
    env.reset(seed=0)  # back to the default task for the other tests


@pytest.mark.slow
def test_rgb_array_render():
    e = ToolDesignEnv(render_mode="rgb_array")
    e.reset(seed=0)
    e.step(STRAIGHT)
    frame = e.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 5  # not a blank image
    e.close()
    e.close()  # closing twice is safe


@pytest.mark.slow
def test_robustness_metrics():
    e = ToolDesignEnv()
    e.reset(seed=0)
    same = e.unwrapped.evaluate_robustness(STRAIGHT, masses=(0.1,))
    assert same.robustness == 0.0 and same.control_deviation == 0.0
    result = e.unwrapped.evaluate_robustness(STRAIGHT)
    assert result.masses == (0.3, 0.5, 0.7, 0.9)
    assert result.robustness < 0 and result.accuracy < 0 and result.control_deviation > 0
    with pytest.raises(ValueError, match="masses"):
        e.unwrapped.evaluate_robustness(STRAIGHT, masses=(0.3, -1.0))
    e.close()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("coeffs", "match"),
    [
        # step() reports it invalid: it lies on the box where the sweep starts.
        ([1.5, 1.5, 0.5], "overlaps the box at the start of the sweep"),
        # The tube folds over itself (only reachable with wider bounds).
        ([-7.15474143, 54.5508592, -0.0125023575], "cannot be built"),
    ],
)
def test_robustness_refuses_a_design_that_is_not_a_tool(coeffs, match):
    e = ToolDesignEnv(bounds=[[-100.0, 100.0]] * 3)
    e.reset(seed=0)
    assert not e.step(coeffs)[4]["valid"]
    with pytest.raises(ValueError, match=match):
        e.evaluate_robustness(coeffs, masses=(0.3,))
    geometry = make_tool(coeffs, e.tool_spec)
    with pytest.raises(ValueError, match=match):
        evaluate_robustness(e.simulator, geometry, (0.5, 0.0, 0.0), masses=(0.3,))
    e.close()


@pytest.mark.slow
@pytest.mark.parametrize("how", ["copy", "deepcopy", "pickle"])
def test_an_env_refuses_to_be_copied_since_it_owns_its_connection(env, how):
    # A copy shared the PyBullet client: closing it (or collecting it) disconnected the original.
    copies = {"copy": copy.copy, "deepcopy": copy.deepcopy, "pickle": pickle.dumps}
    inner = env.unwrapped
    # A shallow copy of gymnasium's wrapper shares the env inside, as any shallow copy would.
    wrapper = () if how == "copy" else (env,)
    rl = gym.make("ToolDesignRL-v0")
    for obj in (*wrapper, inner, inner.simulator, inner.simulator.world, rl.unwrapped):
        with pytest.raises(TypeError, match="cannot be copied or pickled"):
            copies[how](obj)
    rl.close()
    env.reset(seed=0)
    assert np.isfinite(env.step(np.zeros(3))[1])  # the original still works


@pytest.mark.slow
def test_no_temporary_files_are_left(env, tmp_path, monkeypatch):
    # A private temporary folder: the shared /tmp also holds the files of test runs and other
    # programs running at the same time, which made this test flaky.
    private = tmp_path / "tmp"
    private.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(private))
    monkeypatch.setenv("TMPDIR", str(private))
    made = []
    real_mkstemp = tempfile.mkstemp

    def recording_mkstemp(*args, **kwargs):
        fd, path = real_mkstemp(*args, **kwargs)
        made.append(path)
        return fd, path

    monkeypatch.setattr(tempfile, "mkstemp", recording_mkstemp)
    env.reset(seed=0)
    env.step(HOOK)
    assert made and all(os.path.dirname(p) == str(private) for p in made)  # it watched them
    assert os.listdir(private) == []


def test_specs_are_frozen_and_validated():
    with pytest.raises(ValueError, match="box_mass"):
        SceneSpec(box_mass=-0.1)
    spec = ObjectiveSpec()
    with pytest.raises(AttributeError):
        spec.goal_precision = 3.0  # type: ignore[misc]
    assert replace(spec, goal_precision=3.0).goal_precision == 3.0


def test_package_exports():
    assert tooldesign_env.ToolDesignEnv is ToolDesignEnv


@pytest.mark.slow
def test_a_fresh_physics_server_gives_the_same_result(monkeypatch):
    from tooldesign_env import simulation

    e = ToolDesignEnv(info_series=True)
    e.reset(seed=0)
    before = e.step((0.3, -0.7, 0.2))[4]
    monkeypatch.setattr(simulation, "RECONNECT_EVERY", 1)  # every build reconnects
    after = e.step((0.3, -0.7, 0.2))[4]
    np.testing.assert_array_equal(before["box_trajectory"], after["box_trajectory"])
    assert before["free_energy"] == after["free_energy"]
    e.close()


@pytest.mark.slow
def test_masked_values_and_boolean_seeds_are_refused(env):
    # np.asarray passed on the value under a mask, and seed=True was taken as the seed 1 (an
    # audit of issue 10).
    with pytest.raises(TypeError, match="seed must be an int"):
        env.reset(seed=True)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"masked values at index \[0\]"):
        env.step(np.ma.masked_array([0.1, 0.0, 0.0], mask=[1, 0, 0]))
    with pytest.raises(ValueError, match="masked values"):
        env.reset(options={"goal": np.ma.masked_array([0.0, 1.5, 0.1], mask=[0, 0, 1])})
    unmasked = np.ma.masked_array([0.0, 0.0, 0.0], mask=[0, 0, 0])
    env.reset(seed=0)
    assert env.step(unmasked)[1] == env.step(np.zeros(3))[1]
    rl = gym.make("ToolDesignRL-v0")
    with pytest.raises(TypeError, match="seed must be an int"):
        rl.reset(seed=np.bool_(True))
    rl.close()


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ["ToolDesign-v0", "ToolDesignRL-v0"])
def test_a_refused_reset_leaves_a_made_env_usable(env_id):
    """Gymnasium's passive checker broke the env for good after one refused reset."""
    import gymnasium as gym

    env = gym.make(env_id)
    try:
        with pytest.raises(ValueError, match="box_mass"):
            env.reset(options={"box_mass": -1.0})
        env.reset(seed=0)
        _, reward, terminated, _, _ = env.step(np.zeros(3, np.float32))
        assert np.isfinite(reward) and terminated
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tool", "scene", "plan", "controller", "objective"])
@pytest.mark.parametrize("value", [3, "x", {"box_mass": 1}])
def test_a_spec_argument_of_another_type_is_refused_by_name(name, value):
    with pytest.raises(TypeError, match=rf"^{name} must be a \w+Spec"):
        ToolDesignEnv(**{name: value})


@pytest.mark.slow
@pytest.mark.parametrize(
    ("masses", "error"),
    [
        (0.5, TypeError),  # a scalar
        ("0.5", TypeError),
        ((True,), TypeError),  # simulated as 1 kg before
        ((0.5, None), TypeError),
        ((), ValueError),
        ((1e6,), ValueError),  # above BOX_MASS_MAX, as every box mass
        ((0.5, float("nan")), ValueError),
    ],
)
def test_robustness_masses_are_checked_like_every_box_mass(masses, error):
    env = ToolDesignEnv()
    try:
        env.reset(seed=0)
        with pytest.raises(error, match="masses must be a non-empty sequence of finite masses"):
            env.evaluate_robustness([0.0, 0.0, 0.0], masses=masses)
    finally:
        env.close()
