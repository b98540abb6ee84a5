"""The RL baselines of benchmarks/rl: configs, methods and saved policies.

The rl suite itself (storage, resume, report, command line) is tested in test_rl_suite.py; the
saved policies tested here are those of its smoke run (the ``rl_smoke`` fixture, conftest.py).
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from benchmarks.cli import main
from benchmarks.rl import (
    ContextualConfig,
    ContextualPolicy,
    PPOConfig,
    SACConfig,
    default_config,
    load_config,
    run_cmaes,
    run_random,
    train_contextual,
    train_ppo,
    train_sac,
)
from benchmarks.rl.policies import design_for_goal, load_policy, save_policy
from benchmarks.rl.suite import SIZES, held_out_budgets


# ------------------------------------------------------------------ configs
@pytest.mark.parametrize("method", ["ppo", "sac", "contextual"])
def test_the_committed_configs_load(method):
    config = default_config(method)
    assert type(config).__name__.lower().startswith(method[:3])


@pytest.mark.parametrize(
    ("cls", "kwargs", "error"),
    [
        (PPOConfig, {"n_steps": 0}, ValueError),
        (PPOConfig, {"n_steps": 8, "batch_size": 16}, ValueError),
        (PPOConfig, {"learning_rate": float("nan")}, ValueError),
        (PPOConfig, {"net_arch": [64]}, TypeError),
        (PPOConfig, {"n_epochs": 2.5}, TypeError),
        (SACConfig, {"ent_coef": "lots"}, ValueError),
        (SACConfig, {"batch_size": True}, TypeError),
        (ContextualConfig, {"mode": "mean"}, ValueError),
        (ContextualConfig, {"popsize": 1}, ValueError),
        (ContextualConfig, {"bandwidth": -1.0}, ValueError),
    ],
)
def test_bad_config_values_raise(cls, kwargs, error):
    with pytest.raises(error):
        cls(**kwargs)


def test_load_config_refuses_unknown_methods_and_keys(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text('method = "dqn"\n')
    with pytest.raises(ValueError, match="method must be one of"):
        load_config(path)
    path.write_text('method = "ppo"\nlearning_rte = 0.1\n')
    with pytest.raises(ValueError, match="unknown keys"):
        load_config(path)
    with pytest.raises(TypeError, match="path"):
        load_config(3)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="method must be one of"):
        default_config("dqn")


# ------------------------------------------------------------------ methods
def test_contextual_policy_interpolates_between_training_goals():
    goals = [(0.0, 1.0, 0.1), (0.4, 1.0, 0.1)]
    actions = [(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    kernel = ContextualPolicy(goals, actions, bandwidth=0.1)
    mid, _ = kernel.predict(np.array([0.2, 1.0, 0.1, 0.1]))
    np.testing.assert_allclose(mid, [0.0, 0.0, 0.0], atol=1e-6)
    near, _ = kernel.predict(np.array([0.0, 1.0, 0.1, 0.1]))
    assert near[0] < -0.9
    nearest = ContextualPolicy(goals, actions, mode="nearest")
    assert nearest.predict(np.array([0.3, 1.0, 0.1]))[0][0] == 1.0
    back = ContextualPolicy.from_dict(json.loads(json.dumps(kernel.to_dict())))
    np.testing.assert_array_equal(
        back.predict([0.1, 1.0, 0.1])[0], kernel.predict([0.1, 1, 0.1])[0]
    )


@pytest.mark.parametrize(
    ("args", "kwargs"),
    [
        (([], []), {}),
        (([(0, 1, 0.1)], [(2.0, 0, 0)]), {}),
        (([(0, 1, 0.1)], [(0, 0, 0)]), {"mode": "mean"}),
        (([(0, 1, 0.1)], [(0, 0, 0)]), {"bandwidth": 0.0}),
    ],
)
def test_bad_contextual_policies_raise(args, kwargs):
    with pytest.raises(ValueError):
        ContextualPolicy(*args, **kwargs)


@pytest.mark.slow
def test_same_seed_same_runs():
    for run in (run_random, run_cmaes):
        kwargs = {"popsize": 2} if run is run_cmaes else {}
        a = run(total_episodes=3, seed=5, **kwargs)
        b = run(total_episodes=3, seed=5, **kwargs)
        assert len(a) == 3 and [r.free_energy for r in a] == [r.free_energy for r in b]
        assert all(np.all(np.abs(r.action) <= 1.0) for r in a)


@pytest.mark.parametrize("fn", [train_ppo, train_sac])
@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"total_episodes": 0, "seed": 0}, ValueError),
        ({"total_episodes": 2.0, "seed": 0}, TypeError),
        ({"total_episodes": 2, "seed": -1}, TypeError),
    ],
)
def test_bad_training_arguments_raise(fn, kwargs, error):
    config = PPOConfig() if fn is train_ppo else SACConfig()
    with pytest.raises(error):
        fn(config, **kwargs)


def test_a_config_of_the_wrong_method_is_refused():
    with pytest.raises(TypeError, match="PPOConfig"):
        train_ppo(SACConfig(), total_episodes=2, seed=0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="SACConfig"):
        train_sac(PPOConfig(), total_episodes=2, seed=0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="ContextualConfig"):
        train_contextual(PPOConfig(), seed=0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="total_episodes"):
        run_random(total_episodes=0, seed=0)
    with pytest.raises(TypeError, match="seed"):
        run_cmaes(total_episodes=2, seed="zero")  # type: ignore[arg-type]


# ------------------------------------------------------------------ saved policies
@pytest.mark.slow
@pytest.mark.parametrize("method", ["ppo", "sac", "contextual"])
def test_a_saved_policy_designs_a_tool_for_a_new_goal(rl_smoke, method):
    card = rl_smoke / "policies" / f"{method}.json"
    result = design_for_goal(card, (0.2, 1.0, 0.1))
    assert np.isfinite(result.free_energy) and result.valid is not None
    low, high = np.array([-1.5, -1.5, -0.5]), np.array([1.5, 1.5, 0.5])
    c = np.array(result.coefficients)
    assert np.all(c >= low) and np.all(c <= high)
    # Deterministic: the same goal gives the same tool.
    again = design_for_goal(card, (0.2, 1.0, 0.1), simulate=False)
    assert again.coefficients == result.coefficients and np.isnan(again.free_energy)


@pytest.mark.slow
def test_the_command_line_designs_and_reports_bad_goals(rl_smoke, capsys):
    card = str(rl_smoke / "policies" / "contextual.json")
    goal = ["--goal", "0.1", "1.2", "0.1"]
    assert main(["rl", "design", "--policy", card, *goal, "--no-simulate"]) == 0
    assert json.loads(capsys.readouterr().out)["goal"] == [0.1, 1.2, 0.1]
    with pytest.raises(SystemExit) as excinfo:
        main(["rl", "design", "--policy", card, "--goal", "9", "1", "0.1"])
    assert excinfo.value.code == 2
    assert "outside the workspace" in capsys.readouterr().err


# ------------------------------------------------------------------ bad input
def test_bad_policy_cards_and_goals_raise(tmp_path):
    card = tmp_path / "p.json"
    with pytest.raises(FileNotFoundError):
        design_for_goal(card, (0.0, 1.0, 0.1))
    card.write_text("not json")
    with pytest.raises(ValueError, match="not a policy card"):
        load_policy(card)
    card.write_text(json.dumps({"format": 1, "method": "dqn"}))
    with pytest.raises(ValueError, match="method"):
        load_policy(card)
    policy = ContextualPolicy([(0.0, 1.0, 0.1)], [(0.0, 0.0, 0.0)])
    config = dataclasses.replace(ContextualConfig(), n_goals=1)
    good = save_policy(policy, "contextual", tmp_path / "c.json", config=config, train_episodes=1)
    with pytest.raises(ValueError, match="outside the workspace"):
        design_for_goal(good, (9.0, 1.0, 0.1), simulate=False)
    with pytest.raises(TypeError, match="goal"):
        design_for_goal(good, "here", simulate=False)
    with pytest.raises(TypeError, match="simulate"):
        design_for_goal(good, (0.0, 1.0, 0.1), simulate="no")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=".json"):
        save_policy(policy, "contextual", tmp_path / "c.pkl", config=config, train_episodes=1)
    with pytest.raises(ValueError, match="method"):
        save_policy(policy, "dqn", tmp_path / "d.json", config=config, train_episodes=1)
    with pytest.raises(TypeError, match="Stable-Baselines3"):
        save_policy(policy, "ppo", tmp_path / "e.json", config=config, train_episodes=1)


def test_held_out_budgets_include_one_and_the_equal_total():
    size = SIZES["short"]
    budgets = held_out_budgets(size)
    equal = -(-size.train_episodes // size.held_out_goals) + 1
    assert budgets[0] == 1 and equal in budgets and set(size.budgets) <= set(budgets)
    # At the equal budget, CMA-ES spends as many episodes as a trained policy tried once per goal.
    assert equal * size.held_out_goals >= size.train_episodes + size.held_out_goals


def test_bad_probe_arguments_raise():
    from benchmarks.rl.tuning import probe

    with pytest.raises(ValueError, match="method"):
        probe("dqn", episodes=2, seed=0)
    with pytest.raises(ValueError, match="overrides"):
        probe("ppo", episodes=2, seed=0, overrides={"no_such_field": 1})


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ppo", "sac"])
def test_same_seed_same_training(method):
    if method == "ppo":
        config, train = PPOConfig(n_steps=4, batch_size=4), train_ppo
    else:
        config, train = SACConfig(learning_starts=2, batch_size=2), train_sac
    a = train(config, total_episodes=6, seed=7, randomize_goal=True)
    b = train(config, total_episodes=6, seed=7, randomize_goal=True)
    assert len(a.records) >= 6
    assert [r.action for r in a.records] == [r.action for r in b.records]
    assert [r.free_energy for r in a.records] == [r.free_energy for r in b.records]
    assert len({r.goal for r in a.records}) == len(a.records)  # random goals, all different


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ppo", "sac"])
def test_training_leaves_no_folder_in_the_temporary_folder(method, tmp_path, monkeypatch):
    # SB3's default logger makes an empty SB3-<date> folder in tempfile.gettempdir() per learn().
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    if method == "ppo":
        train_ppo(PPOConfig(n_steps=2, batch_size=2), total_episodes=2, seed=0)
    else:
        train_sac(SACConfig(learning_starts=1, batch_size=1), total_episodes=2, seed=0)
    # (torch may make its own one-per-user cache, torchinductor_<user>, there: not ours.)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith("SB3-")] == []


# ------------------------------------------------------------------ goal and box mass as the task
def test_a_contextual_policy_with_masses_reads_the_mass_from_the_observation():
    goals = [(0.0, 1.0, 0.1), (0.0, 1.0, 0.1)]
    actions = [(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    policy = ContextualPolicy(goals, actions, mode="nearest", masses=[0.1, 0.9], mass_scale=1.0)
    assert policy.predict([0.0, 1.0, 0.1, 0.2])[0][0] == -1.0
    assert policy.predict([0.0, 1.0, 0.1, 0.8])[0][0] == 1.0
    back = ContextualPolicy.from_dict(json.loads(json.dumps(policy.to_dict())))
    assert back.predict([0.0, 1.0, 0.1, 0.8])[0][0] == 1.0
    with pytest.raises(ValueError, match="box mass"):
        policy.predict([0.0, 1.0, 0.1])  # the mass is missing
    # A card without masses (phase 1's) is a goal-only policy.
    old = {"goals": [[0.0, 1.0, 0.1]], "actions": [[0.5, 0.0, 0.0]], "bandwidth": 0.25}
    assert ContextualPolicy.from_dict({**old, "mode": "kernel"}).masses is None


@pytest.mark.parametrize(
    "kwargs",
    [
        {"masses": [0.1]},  # one mass for two goals
        {"masses": [0.1, -0.5]},
        {"masses": [0.1, 0.5], "mass_scale": 0.0},
        {"masses": [0.1, 0.5], "mass_scale": float("inf")},
    ],
)
def test_bad_masses_of_a_contextual_policy_raise(kwargs):
    with pytest.raises(ValueError, match="mass"):
        ContextualPolicy([(0, 1, 0.1), (0, 1.2, 0.1)], [(0, 0, 0), (0, 0, 0)], **kwargs)


@pytest.mark.slow
def test_ppo_and_the_contextual_method_train_on_random_goals_and_masses():
    env_kwargs = {"mass_range": (0.2, 0.8)}
    ppo = train_ppo(
        PPOConfig(n_steps=4, batch_size=4),
        total_episodes=4,
        seed=3,
        randomize_goal=True,
        env_kwargs=env_kwargs,
    )
    masses = [r.box_mass for r in ppo.records]
    assert len(set(masses)) == 4 and all(0.2 <= m <= 0.8 for m in masses)
    config = ContextualConfig(n_goals=2, episodes_per_goal=2, popsize=2, mode="nearest")
    contextual = train_contextual(config, seed=3, env_kwargs=env_kwargs)
    policy = contextual.model
    assert policy.masses is not None and np.all((policy.masses >= 0.2) & (policy.masses <= 0.8))
    # Each training task's CMA-ES ran at its own mass; the goals are those of a goal-only run.
    assert [r.box_mass for r in contextual.records] == list(np.repeat(policy.masses, 2))
    goal_only = train_contextual(config, seed=3)
    np.testing.assert_array_equal(goal_only.model.goals, policy.goals)


# ------------------------------------------------------------------ without torch
@pytest.mark.slow
def test_benchmarks_import_and_refuse_ppo_clearly_without_torch(tmp_path):
    card = tmp_path / "c.json"
    policy = ContextualPolicy([(0.0, 1.0, 0.1)], [(0.0, 0.0, 0.0)])
    save_policy(policy, "contextual", card, config=ContextualConfig(), train_episodes=1)
    code = f"""
import importlib.abc, sys

class NoTorch(importlib.abc.MetaPathFinder):  # as if torch and SB3 were not installed
    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in ("torch", "stable_baselines3"):
            raise ModuleNotFoundError(f"No module named {{name!r}}")
        return None

sys.meta_path.insert(0, NoTorch())
import benchmarks, benchmarks.rl, benchmarks.reports, benchmarks.reports.rl
from benchmarks.cli import build_parser
build_parser("bench"); build_parser("rl")
from benchmarks.rl import PPOConfig, design_for_goal, rl_suite_config, train_ppo
rl_suite_config("full")
print(design_for_goal({str(card)!r}, (0.1, 1.0, 0.1), simulate=False).coefficients)
try:
    train_ppo(PPOConfig(), total_episodes=1, seed=0)
except ImportError as error:
    print("refused:", error)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "(0.0, 0.0, 0.0)" in out.stdout
    assert "refused:" in out.stdout and 'pip install "tooldesign[rl]"' in out.stdout
    assert "torch" not in out.stderr
