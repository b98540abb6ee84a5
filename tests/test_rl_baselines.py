"""The RL baselines of benchmarks/rl: configs, methods, the rl suite (smoke), saved policies."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

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
from benchmarks.rl.suite import FIXED_COLUMNS, HELD_OUT_COLUMNS, SIZES, run_rl_suite


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


# ------------------------------------------------------------------ the suite (smoke)
@pytest.fixture(scope="module")
def smoke(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rl-smoke")
    run_rl_suite("smoke", out)
    return out


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.slow
def test_the_smoke_suite_writes_long_csvs_and_a_summary(smoke):
    size = SIZES["smoke"]
    fixed = _rows(smoke / "fixed_goal.csv")
    assert tuple(fixed[0]) == FIXED_COLUMNS
    for method in ("random", "cmaes", "ppo", "sac"):
        mine = [r for r in fixed if r["method"] == method]
        assert len(mine) == size.seeds * size.fixed_episodes
        best = [float(r["best_so_far_F"]) for r in mine]
        assert best == list(np.minimum.accumulate([float(r["free_energy"]) for r in mine]))
    held = _rows(smoke / "held_out.csv")
    assert tuple(held[0]) == HELD_OUT_COLUMNS
    methods = {r["method"] for r in held}
    assert methods == {"straight", "ppo", "sac", "contextual", "cmaes", "random"}
    for row in held:
        n = int(row["budget_per_goal"]) * size.held_out_goals
        assert int(row["total_episodes"]) == int(row["train_episodes"]) + n
    summary = json.loads((smoke / "summary.json").read_text())
    assert summary["noise_floor"]["relative_F"] == 0.015
    assert set(summary["task_conditioned"]["approaches"]) >= {"ppo", "contextual", "cmaes@4"}


@pytest.mark.slow
@pytest.mark.parametrize("method", ["ppo", "sac", "contextual"])
def test_a_saved_policy_designs_a_tool_for_a_new_goal(smoke, method):
    card = smoke / "policies" / f"{method}.json"
    result = design_for_goal(card, (0.2, 1.0, 0.1))
    assert np.isfinite(result.free_energy) and result.valid is not None
    low, high = np.array([-1.5, -1.5, -0.5]), np.array([1.5, 1.5, 0.5])
    c = np.array(result.coefficients)
    assert np.all(c >= low) and np.all(c <= high)
    # Deterministic: the same goal gives the same tool.
    again = design_for_goal(card, (0.2, 1.0, 0.1), simulate=False)
    assert again.coefficients == result.coefficients and np.isnan(again.free_energy)


@pytest.mark.slow
def test_the_command_line_designs_and_reports_bad_goals(smoke, capsys):
    card = str(smoke / "policies" / "contextual.json")
    goal = ["--goal", "0.1", "1.2", "0.1"]
    assert main(["rl", "design", "--policy", card, *goal, "--no-simulate"]) == 0
    assert json.loads(capsys.readouterr().out)["goal"] == [0.1, 1.2, 0.1]
    with pytest.raises(SystemExit) as excinfo:
        main(["rl", "design", "--policy", card, "--goal", "9", "1", "0.1"])
    assert excinfo.value.code == 2
    assert "outside the workspace" in capsys.readouterr().err


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"size": "huge"}, ValueError),
        ({"size": 3}, TypeError),
        ({"size": "smoke", "seeds": 0}, ValueError),
        ({"size": "smoke", "seeds": 1.5}, TypeError),
        ({"size": "smoke", "methods": ("dqn",)}, ValueError),
        ({"size": "smoke", "methods": "ppo"}, ValueError),
        ({"size": "smoke", "parts": ()}, ValueError),
        ({"size": "smoke", "parts": ("all",)}, ValueError),
    ],
)
def test_bad_suite_arguments_raise(tmp_path, kwargs, error):
    with pytest.raises(error):
        run_rl_suite(out_dir=tmp_path, **kwargs)


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
    from benchmarks.rl.suite import _held_out_budgets

    size = SIZES["short"]
    budgets = _held_out_budgets(size)
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
def test_the_report_reads_a_stored_run(smoke, tmp_path):
    from benchmarks.rl.report import held_out_table, plot_fixed_goal

    png = plot_fixed_goal(smoke, tmp_path / "f.png")
    assert png.stat().st_size > 1000
    table = held_out_table(smoke)
    straight = next(t for t in table if t["approach"] == "straight")
    assert straight["median_F_over_straight"] == 1.0 and straight["total_episodes"] == 2
    assert {t["approach"] for t in table} >= {"ppo", "sac", "contextual", "cmaes@1"}


def test_the_report_names_a_missing_run(tmp_path):
    from benchmarks.rl.report import held_out_table, plot_fixed_goal

    with pytest.raises(FileNotFoundError, match="run the rl suite"):
        plot_fixed_goal(tmp_path)
    with pytest.raises(FileNotFoundError, match="run the rl suite"):
        held_out_table(tmp_path)


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
