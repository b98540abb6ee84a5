"""Semi-amortized design (issue 36): a saved policy's design warm-starts CMA-ES.

``tooldesign design --policy CARD --refine N`` and :mod:`benchmarks.rl.warmstart`: the step
size rules, the designer's ask/tell contract, and the run folder it writes (its first evaluation
is the zero-shot design, its settings the card's SHA-256 and the step size, resume as any run).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from policy_runs import GOAL, contextual_card, design_with_card, refused_design_error

from benchmarks.cli import main
from benchmarks.rl import ContextualPolicy
from benchmarks.rl.policies import design_for_goal, policy_digest
from benchmarks.rl.warmstart import (
    DEFAULT_SIGMA0,
    SIGMA0_COLD,
    SIGMA0_MIN,
    WARM_START_DESIGNER,
    WarmStartDesigner,
    check_warm_settings,
    proposal_spread,
    warm_sigma0,
)
from tooldesign_env import default_bounds


def test_a_kernel_cards_spread_is_the_kernel_weighted_rms_around_the_proposal() -> None:
    policy = ContextualPolicy(
        [(0, 1, 0.1), (0, 1.2, 0.1)], [(0.2, 0, 0), (-0.2, 0, 0)], bandwidth=0.25, mode="kernel"
    )
    obs = np.array([0.0, 1.0, 0.1, 0.1], np.float32)
    # Weights 1 and w = exp(-0.04 / 0.125); the proposal is their weighted mean p (first
    # coordinate), the spread the weighted RMS of (0.2 - p, -0.2 - p) over 3 coordinates.
    w = np.exp(-(0.2**2) / (2 * 0.25**2))
    p = (0.2 - 0.2 * w) / (1 + w)
    expected = np.sqrt(((0.2 - p) ** 2 + w * (-0.2 - p) ** 2) / ((1 + w) * 3))
    assert proposal_spread(policy, obs) == pytest.approx(expected, rel=1e-6)
    one = ContextualPolicy([(0, 1, 0.1)], [(0.2, 0, 0)])
    assert proposal_spread(one, obs) == pytest.approx(0.0, abs=1e-6)  # float32 proposal
    assert proposal_spread(object(), obs) is None  # no spread to read


def test_a_nearest_cards_spread_is_its_runner_ups_distance_not_the_kernels() -> None:
    goals = [(0, 1, 0.1), (0, 1.2, 0.1), (0, 1.5, 0.1)]
    actions = [(0.2, 0, 0), (-0.2, 0, 0), (0.9, 0.9, 0.9)]
    obs = np.array([0.0, 1.0, 0.1, 0.1], np.float32)
    # The proposal is the nearest task's (0.2, 0, 0); the runner-up's design is 0.4 away in one
    # coordinate of 3, whatever the bandwidth (the kernel's weights are not the proposal's).
    expected = np.sqrt(0.4**2 / 3)
    for bandwidth in (0.05, 0.25, 10.0):
        policy = ContextualPolicy(goals, actions, bandwidth=bandwidth, mode="nearest")
        assert policy.predict(obs)[0].tolist() == pytest.approx([0.2, 0, 0])
        assert proposal_spread(policy, obs) == pytest.approx(expected, rel=1e-6)
    # Nearer the second task, the roles swap: the same distance, from (-0.2, 0, 0).
    near_second = np.array([0.0, 1.15, 0.1, 0.1], np.float32)
    assert proposal_spread(policy, near_second) == pytest.approx(expected, rel=1e-6)
    # The mass counts in the task distance as the card's predict counts it: 0.8 kg away, the
    # second task falls behind the third (0.68 against 0.25 m^2), the third is the runner-up.
    with_mass = ContextualPolicy(goals, actions, mode="nearest", masses=[0.1, 0.9, 0.1])
    third = np.sqrt((0.7**2 + 0.9**2 + 0.9**2) / 3)
    assert proposal_spread(with_mass, obs) == pytest.approx(third, rel=1e-6)
    # One training task has no runner-up: no spread, the default step size.
    one = ContextualPolicy([(0, 1, 0.1)], [(0.2, 0, 0)], mode="nearest")
    assert proposal_spread(one, obs) is None
    assert warm_sigma0(proposal_spread(one, obs)) == DEFAULT_SIGMA0


def test_the_step_size_rule() -> None:
    assert warm_sigma0(None) == DEFAULT_SIGMA0
    assert warm_sigma0(float("nan")) == DEFAULT_SIGMA0
    assert warm_sigma0(0.0) == SIGMA0_MIN
    assert warm_sigma0(0.2) == pytest.approx(0.1)
    assert warm_sigma0(5.0) == SIGMA0_COLD
    assert check_warm_settings(None, 8) == (None, 8)
    with pytest.raises(ValueError, match="sigma0 must be in"):
        check_warm_settings(0.0, 8)
    with pytest.raises(TypeError, match="sigma0 must be a number"):
        check_warm_settings("wide", 8)
    with pytest.raises(ValueError, match="popsize must be an int from 2"):
        check_warm_settings(None, 1)
    with pytest.raises(TypeError, match="popsize must be an int"):
        check_warm_settings(None, 2.5)


@pytest.mark.slow
def test_the_designer_asks_the_proposal_then_cmaes_from_it(tmp_path: Path) -> None:
    card = contextual_card(tmp_path / "policy.json")
    bounds = default_bounds(3)
    kwargs = {"policy": card, "goal": GOAL, "box_mass": 0.1, "sha256": policy_digest(card)}
    designer = WarmStartDesigner(bounds, seed=3, popsize=4, **kwargs)
    expected = design_for_goal(card, GOAL, simulate=False).coefficients
    first = designer.ask()
    assert first.x.tolist() == [list(expected)]  # bit for bit the zero-shot design
    designer.tell(first.ids, [100.0])
    samples = []
    for k in range(8):  # two generations of 4, told one at a time
        batch = designer.ask()
        samples.append(batch.x[0])
        designer.tell(batch.ids, [float(k)])
    spread = np.std(np.array(samples), axis=0)
    assert np.all(spread > 0)
    # Same seed, same asks; another seed, other asks.
    again = WarmStartDesigner(bounds, seed=3, popsize=4, **kwargs)
    again.tell(again.ask().ids, [100.0])
    assert np.array_equal(again.ask().x[0], samples[0])
    other = WarmStartDesigner(bounds, seed=4, popsize=4, **kwargs)
    other.tell(other.ask().ids, [100.0])
    assert not np.array_equal(other.ask().x[0], samples[0])
    assert designer.sigma0 == warm_sigma0(designer.spread)


def test_the_designer_refuses_bad_settings(tmp_path: Path) -> None:
    card = contextual_card(tmp_path / "policy.json")
    bounds = default_bounds(3)
    kwargs = {"policy": card, "goal": GOAL, "box_mass": 0.1, "sha256": policy_digest(card)}
    with pytest.raises(ValueError, match="batch_size must be 1"):
        WarmStartDesigner(bounds, batch_size=8, **kwargs)
    with pytest.raises(ValueError, match="has changed"):
        WarmStartDesigner(bounds, **{**kwargs, "sha256": "0" * 64})
    with pytest.raises(ValueError, match="sigma0 must be in"):
        WarmStartDesigner(bounds, sigma0=2.0, **kwargs)
    with pytest.raises(ValueError, match="outside the run's bounds"):
        WarmStartDesigner(np.array([[-0.01, 0.01]] * 3), **kwargs)


@pytest.mark.slow
def test_refine_designs_into_a_run_folder_and_resumes(tmp_path: Path) -> None:
    card = contextual_card(tmp_path / "policy.json")
    out = tmp_path / "run"
    assert design_with_card(card, out, "--refine", "3", "--seed", "2", "--option", "popsize=2") == 0
    log = pd.read_csv(out / "evaluations.csv")
    assert len(log) == 4
    zero = design_for_goal(card, GOAL)
    assert log[["c1", "c2", "c3"]].to_numpy()[0].tolist() == list(zero.coefficients)
    assert log["free_energy"].iloc[0] == zero.free_energy
    config = json.loads((out / "design.json").read_text())["config"]
    assert config["optimizer"] == WARM_START_DESIGNER
    settings = config["optimizer_settings"]
    assert settings["sha256"] == policy_digest(card) and settings["popsize"] == 2
    assert SIGMA0_MIN <= settings["sigma0"] <= SIGMA0_COLD
    assert config["iterations"] == 4 and config["batch_size"] == 1 and config["seed"] == 2
    # More refinement continues the run: the first four evaluations are kept as they were.
    assert (
        design_with_card(
            card, out, "--refine", "5", "--seed", "2", "--option", "popsize=2", "--resume"
        )
        == 0
    )
    longer = pd.read_csv(out / "evaluations.csv")
    assert len(longer) == 6
    pd.testing.assert_frame_equal(
        longer.head(4).drop(columns=["eval_time", "opt_time"]),
        log.drop(columns=["eval_time", "opt_time"]),
    )


@pytest.mark.slow
def test_refine_zero_is_the_zero_shot_design(tmp_path: Path) -> None:
    card = contextual_card(tmp_path / "policy.json")
    out = tmp_path / "run"
    assert design_with_card(card, out, "--refine", "0") == 0
    log = pd.read_csv(out / "evaluations.csv")
    assert len(log) == 1 and log["free_energy"].iloc[0] == design_for_goal(card, GOAL).free_energy


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--refine", "-1"], "--refine must be an int from 0"),
        (["--refine", "2", "--iterations", "3"], "--iterations"),
        (["--refine", "2", "--batch-size", "4"], "--batch-size"),
        (["--refine", "2", "--optimizer", "bo"], "--optimizer"),
        (["--refine", "2", "--option", "lr=0.1"], "--option lr=...: the warm-started design"),
        (["--refine", "2", "--option", "sigma0=3"], "--option sigma0 must be in"),
        (["--refine", "2", "--option", "popsize=1"], "--option popsize must be an int"),
    ],
)
def test_bad_refine_options_are_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], named: str
) -> None:
    assert named in refused_design_error(tmp_path, capsys, extra)


def test_refine_needs_a_policy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as excinfo:
        main(["design", "--refine", "3", "--out", str(tmp_path / "run"), "--no-progress"])
    assert excinfo.value.code == 2
    assert "--refine refines a saved policy's design" in capsys.readouterr().err


def test_the_study_loop_and_the_proposal_refuse_bad_input(tmp_path: Path) -> None:
    from benchmarks.rl.warmstart import run_warm_cmaes, warm_start_proposal

    policy = ContextualPolicy([(0, 1, 0.1)], [(0.2, 0, 0)])
    kwargs = {"total_episodes": 4, "seed": 0, "goal": GOAL, "box_mass": 0.1}
    with pytest.raises(ValueError, match="total_episodes must be an int from 1"):
        run_warm_cmaes(policy, **{**kwargs, "total_episodes": 0})
    with pytest.raises(TypeError, match="seed must be an int"):
        run_warm_cmaes(policy, **{**kwargs, "seed": -1})
    with pytest.raises(ValueError, match="sigma0 must be in"):
        run_warm_cmaes(policy, sigma0=0.001, **kwargs)
    with pytest.raises(ValueError, match="popsize must be an int from 2"):
        run_warm_cmaes(policy, popsize=1, **kwargs)
    with pytest.raises(TypeError, match="predict"):
        run_warm_cmaes(object(), **kwargs)
    with pytest.raises(FileNotFoundError, match="No such file"):
        warm_start_proposal(tmp_path / "none.json", GOAL, box_mass=0.1)
