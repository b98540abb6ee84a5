"""The robust-design baseline: the goal error averaged over box masses, no confidence term."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.execution import TaskSettings
from benchmarks.suites import builtin_suite
from tooldesign_env import ObjectiveSpec, ToolDesignEnv, make_tool
from tooldesign_env.objective import goal_error


@pytest.mark.slow
def test_expected_goal_error_is_the_mean_over_masses():
    masses = (0.1, 0.6)
    env = ToolDesignEnv(objective=ObjectiveSpec(kind="expected-goal-error", expected_masses=masses))
    env.reset(seed=0)
    info = env.step([0.0, 0.0, 0.0])[4]
    assert info["valid"] and info["confidence"] == 0.0
    assert info["free_energy"] == info["goal_error"]
    goal = np.asarray(info["goal"])
    expected = []
    for m in masses:
        run = env.unwrapped.simulator.rollout(make_tool(np.zeros(3)), box_mass=m)
        expected.append(goal_error(run.box_position, goal, 20.0).sum())
    assert info["free_energy"] == pytest.approx(np.mean(expected), rel=1e-12)
    # The heavier box changes the outcome: the mean is not the nominal goal error.
    nominal = ToolDesignEnv()
    nominal.reset(seed=0)
    assert nominal.step([0.0, 0.0, 0.0])[4]["goal_error"] != pytest.approx(info["goal_error"])


@pytest.mark.parametrize(
    "kwargs",
    [
        {"kind": "robust"},
        {"expected_masses": ()},
        {"expected_masses": (0.0,)},
        {"expected_masses": (math.nan,)},
        {"expected_masses": (True,)},
    ],
)
def test_bad_objective_kinds_and_masses_are_refused(kwargs):
    with pytest.raises(ValueError, match="ObjectiveSpec"):
        ObjectiveSpec(**kwargs)


@pytest.mark.parametrize("masses", [0.5, 1, "0.5", None])
def test_expected_masses_that_are_not_a_sequence_are_refused_naming_the_field(masses):
    with pytest.raises(ValueError, match=r"ObjectiveSpec.expected_masses must be 1 to 64 masses"):
        ObjectiveSpec(kind="expected-goal-error", expected_masses=masses)


@pytest.mark.slow
def test_expected_goal_error_without_goal_precision_is_refused():
    # p^X = 0 makes every design's expected goal error 0: nothing to optimize, at 3 rollouts.
    with pytest.raises(
        ValueError, match=r"ObjectiveSpec.goal_precision must be > 0 .*expected-goal-error"
    ):
        ObjectiveSpec(kind="expected-goal-error", goal_precision=0.0)
    assert ObjectiveSpec(kind="expected-goal-error", goal_precision=1e-3).goal_precision == 1e-3
    assert ObjectiveSpec(goal_precision=0.0).goal_precision == 0.0  # pure confidence: fine


def test_the_objective_travels_from_suite_to_task():
    suite = builtin_suite("robust-design", "smoke")
    assert suite.objective == "expected-goal-error"
    assert {run.design.task().objective for run in suite.runs()} == {"expected-goal-error"}
    with pytest.raises(ValueError, match="objective"):
        TaskSettings(objective="free energy")
    robustness = builtin_suite("robustness", "full")
    full = builtin_suite("robust-design", "full")
    assert full.tasks() == robustness.tasks()
    assert full.evaluations() * 7 == robustness.evaluations()
