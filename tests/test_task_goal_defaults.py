"""A config without a goal takes its task's default goal (review 43, item 7).

``DesignConfig(task_name="hook")`` was refused with "goal [0.0, 1.5, 0.1] is outside the hook
task's goal range": push's goal, which the user never gave. ``goal=None`` (the default) is now
the task's own goal in every config that names a task; a push config stores the paper's goal,
so its JSON (and every run folder's manifest) is what it was.
"""

from __future__ import annotations

import json

import pytest

from benchmarks.design import DesignConfig
from benchmarks.execution import TaskSettings
from benchmarks.suites import SuiteConfig
from tooldesign_env.schema import DEFAULT_GOAL
from tooldesign_env.tasks import BUILTIN_TASKS, get_task

#: A push design run's and a push suite's config JSON, as 09d7aa5 (main before this change)
#: wrote them: recorded, not computed.
PUSH_CONFIG_09D7AA5 = (
    '{"optimizer": "cmaes", "optimizer_settings": {}, "seed": 0, "iterations": 15, '
    '"batch_size": 8, "workers": null, "executor": "process", "scheduler": null, '
    '"max_retries": 0, "goal": [0.0, 1.5, 0.1], "goal_precision": 20.0, "box_mass": 0.1, '
    '"estimator": "contact", "objective": "free-energy", "scene_samples": 1, "bounds": '
    '[[-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5]], "scene": {"merge_fixed_links": true}, '
    '"robustness_masses": [0.3, 0.5, 0.7, 0.9], "section_shape": "round"}'
)
PUSH_SUITE_09D7AA5 = (
    '{"name": "s", "description": "", "env_id": "ToolDesign-v0", "goal": [0.0, 1.5, 0.1], '
    '"goal_box": null, "goal_precision": 20.0, "box_mass": 0.1, "estimator": "contact", '
    '"objective": "free-energy", "scene_samples": 1, "bounds": [[-1.5, 1.5], [-1.5, 1.5], '
    '[-0.5, 0.5]], "scene": {"merge_fixed_links": true}, "section_shape": "round", "variants": '
    '[{"name": "", "goal_precision": null, "label": ""}], "optimizers": [{"name": "cmaes", '
    '"settings": {}, "label": ""}], "batch_size": 8, "iterations": 15, "root_seed": 0, '
    '"n_seeds": 1, "test_robustness": false, "robustness_masses": [0.3, 0.5, 0.7, 0.9], '
    '"keep_paths": false, "figures": [], "executor": "process", "workers": null, '
    '"scheduler": null, "max_retries": 0}'
)


@pytest.mark.parametrize("task", BUILTIN_TASKS)
def test_a_design_config_without_a_goal_takes_its_tasks(task):
    config = DesignConfig(task_name=task, workers=1)
    assert config.goal == get_task(task).goal
    assert config == DesignConfig(task_name=task, workers=1, goal=get_task(task).goal)
    assert config.to_json()["goal"] == list(get_task(task).goal)


def test_a_push_config_without_a_goal_is_stored_as_before():
    config = DesignConfig(workers=None)
    assert json.dumps(config.to_json()) == PUSH_CONFIG_09D7AA5
    assert config.goal == tuple(DEFAULT_GOAL) and config == DesignConfig(goal=DEFAULT_GOAL)


def test_a_suite_without_a_goal_takes_its_tasks():
    hook = SuiteConfig(name="s", task_name="hook", n_seeds=1)
    assert hook.goal == get_task("hook").goal
    assert all(run.design.goal == get_task("hook").goal for run in hook.runs())
    push = SuiteConfig(name="s", n_seeds=1)
    assert json.dumps(push.to_json()) == PUSH_SUITE_09D7AA5
    assert push == SuiteConfig(name="s", n_seeds=1, goal=DEFAULT_GOAL)


def test_task_settings_without_a_goal_take_their_tasks():
    assert TaskSettings().goal == tuple(DEFAULT_GOAL)
    assert TaskSettings(env_kwargs={"task": "hook"}).goal == get_task("hook").goal
    assert TaskSettings(env_kwargs={"task": get_task("obstacle")}).goal == get_task("obstacle").goal
    assert TaskSettings(env_kwargs={"task": "hook"}, goal=(1.0, 1.0, 0.1)).goal == (1.0, 1.0, 0.1)


@pytest.mark.parametrize(
    ("make", "error", "words"),
    [
        # A goal given is still checked against the task's range, in the old words.
        (
            lambda: DesignConfig(task_name="hook", goal=(0.0, 1.5, 0.1)),
            ValueError,
            r"goal \[0.0, 1.5, 0.1\] is outside the hook task's goal range",
        ),
        (lambda: DesignConfig(task_name="nope"), ValueError, "unknown task 'nope'"),
        (lambda: SuiteConfig(name="s", task_name="nope"), ValueError, "unknown task 'nope'"),
        (
            lambda: TaskSettings(env_kwargs={"task": "nope"}),
            ValueError,
            "unknown task 'nope'; known tasks: push",
        ),
        (lambda: TaskSettings(env_kwargs=3), TypeError, "env_kwargs must be a mapping"),
    ],
)
def test_a_config_without_a_goal_still_refuses_bad_input(make, error, words):
    with pytest.raises(error, match=words):
        make()
