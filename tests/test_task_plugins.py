"""Tasks of the user's (review 43, items 1 and 2): registered in a function, by ``module:ATTR``,
by entry point; the "Adding a task" example of docs/tasks.md runs as printed.

A task registered with ``register_task`` lives in this process's registry only: the workers of
the process pool (forkserver) never ran the call, so a design run sends them the definition
itself. The command line cannot run the call at all: ``--task`` takes a ``module:ATTR`` or an
installed package's entry point (group ``tooldesign.tasks``).
"""

from __future__ import annotations

import importlib.metadata
import json
import re
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import pytest

from benchmarks.cli import main
from tooldesign_env.tasks import Obstacle, TaskDefinition, get_task, register_task, task_names
from tooldesign_env.tasks import registry as task_registry
from tooldesign_env.tasks.registry import ENTRY_POINT_GROUP, env_ids, unregister_task

DOCS = Path(__file__).resolve().parents[1] / "docs" / "tasks.md"

#: A module of the user's, written under tmp_path: a walled hook task and something else.
USER_MODULE = '''
from dataclasses import replace

from tooldesign_env.tasks import Obstacle, get_task

WALLED = replace(
    get_task("hook"),
    name="walled-hook-cli",
    title="hook the box out from beside a wall",
    obstacles=(Obstacle(name="wall", position=(-0.7, 1.2), size=(0.05, 0.4, 0.3)),),
)
NOT_A_TASK = 3
'''


def _forget(name: str) -> None:
    """Remove a task a test registered, and its Gymnasium ids, so other tests never see it."""
    if name in task_names():
        unregister_task(name)
    for env_id in env_ids(name):
        gym.registry.pop(env_id, None)


@pytest.fixture
def user_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """The name of an importable module (under tmp_path, on sys.path) defining ``WALLED``."""
    package = tmp_path / "usertasks"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "walled.py").write_text(USER_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "usertasks.walled"
    for name in [m for m in sys.modules if m == "usertasks" or m.startswith("usertasks.")]:
        del sys.modules[name]


# ------------------------------------------------------------------ docs/tasks.md's example
def _adding_a_task_block() -> str:
    text = DOCS.read_text(encoding="utf-8")
    found = re.search(r"### Adding a task\n.*?```python\n(.*?)```\n", text, re.S)
    assert found, "no python block under 'Adding a task' in docs/tasks.md"
    return found.group(1)


def test_the_adding_a_task_example_of_the_docs_runs_as_printed():
    code = _adding_a_task_block()
    assert 'register_task("walled-hook", WALLED)' in code  # the block that is documented
    namespace: dict[str, object] = {}
    try:
        exec(compile(code, str(DOCS), "exec"), namespace)  # noqa: S102 - the page's own example
        walled = namespace["WALLED"]
        assert isinstance(walled, TaskDefinition)
        assert get_task("walled-hook") is walled
        assert gym.spec("ToolDesign-WalledHook-v0").kwargs == {"task": "walled-hook"}
        from benchmarks.design import DesignConfig

        # Designable: a config of it (its default goal, its scene) is accepted.
        config = DesignConfig(task_name="walled-hook", executor="serial")
        assert config.goal == walled.goal == get_task("hook").goal
    finally:
        _forget("walled-hook")


# ------------------------------------------------------------------ the workers
def _register_in_a_function(name: str) -> TaskDefinition:
    """As a user's ``main()`` does: the registration is not at any module's top level."""
    walled = replace(
        get_task("hook"),
        name=name,
        title="hook the box out from beside a wall",
        obstacles=(Obstacle(name="wall", position=(-0.7, 1.2), size=(0.05, 0.4, 0.3)),),
    )
    register_task(name, walled)
    return walled


def test_a_design_run_sends_the_workers_the_definition_and_stores_the_name():
    from benchmarks.design import DesignConfig

    name = "walled-hook-sent"
    try:
        walled = _register_in_a_function(name)
        config = DesignConfig(task_name=name, executor="serial")
        assert dict(config.task().env_kwargs)["task"] is walled
        assert config.to_json()["task_name"] == name  # the folder records the name
        assert config.task().task_scene() == walled.scene
    finally:
        _forget(name)


@pytest.mark.slow  # a process pool and 3 rollouts (2 designs, the final test)
def test_a_task_registered_in_a_function_runs_in_the_process_pool(tmp_path: Path):
    from benchmarks.design import DesignConfig, run_design
    from benchmarks.execution import make_executor

    name = "walled-hook-pool"
    try:
        _register_in_a_function(name)
        with make_executor("process", 1) as pool:
            # The condition of the bug: the workers do not know the task by its name.
            assert name not in pool.submit(task_names).result()
        config = DesignConfig(
            task_name=name, seed=0, iterations=1, batch_size=2, workers=1, executor="process"
        )
        result = run_design(config, tmp_path / "run", progress=False)
    finally:
        _forget(name)
    evaluations = result.evaluations
    assert len(evaluations) == 2 and set(evaluations["status"]) <= {"ok", "invalid"}, evaluations
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["config"]["task_name"] == name


# ------------------------------------------------------------------ module:ATTR
def test_get_task_imports_a_module_attr(user_module: str):
    walled = get_task(f"{user_module}:WALLED")
    assert walled.name == "walled-hook-cli"
    assert "walled-hook-cli" not in task_names()  # imported, never registered


@pytest.mark.parametrize(
    ("value", "error", "words"),
    [
        ("nosuchmod:X", ValueError, "cannot import module 'nosuchmod'"),
        ("usertasks.walled:NOTHERE", ValueError, "module 'usertasks.walled' has no 'NOTHERE'"),
        ("usertasks.walled:NOT_A_TASK", TypeError, "names int 3, not a"),
        ("usertasks.walled:", ValueError, "unknown task"),
        ("pushh", ValueError, "unknown task 'pushh'"),
    ],
)
def test_get_task_refuses_a_bad_task_in_one_line(user_module, value, error, words):
    with pytest.raises(error) as refused:
        get_task(value)
    message = str(refused.value)
    assert words in message and "\n" not in message
    assert repr(value) in message
    if error is ValueError:  # says what is allowed
        assert "known tasks: push, hook" in message and "'module:ATTR'" in message
        assert ENTRY_POINT_GROUP in message
    else:
        assert "TaskDefinition" in message


def test_a_registered_name_may_not_look_like_module_attr():
    with pytest.raises(ValueError, match=r"without spaces or ':', got 'my:task'"):
        register_task("my:task", get_task("hook"))


@pytest.mark.parametrize("command", ["design", "evaluate"])
@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("nosuchmod:X", "cannot import module 'nosuchmod'"),
        ("usertasks.walled:NOT_A_TASK", "names int 3, not a tooldesign_env.tasks.TaskDefinition"),
    ],
)
def test_the_cli_refuses_a_bad_module_attr_in_one_line(
    tmp_path, capsys, user_module, command, value, words
):
    extra = ["--coeffs", "0", "0", "0"] if command == "evaluate" else []
    with pytest.raises(SystemExit) as exited:
        main([command, *extra, "--task", value, "--out", str(tmp_path / "out")])
    assert exited.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--task: task {value!r}" in err[0] and words in err[0], err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow  # one rollout, and a design run of 2 designs in the process pool
def test_the_cli_runs_a_module_attr_task(tmp_path, capsys, user_module):
    spec = f"{user_module}:WALLED"
    assert main(["evaluate", "--coeffs", "0", "1.5", "0", "--task", spec,
                 "--out", str(tmp_path / "e")]) == 0
    terms = json.loads((tmp_path / "e" / "terms.json").read_text())
    assert terms["task"] == "walled-hook-cli" and terms["settings"]["task"] == "walled-hook-cli"
    assert terms["goal"] == list(get_task(spec).goal)
    assert main(["design", "--task", spec, "--iterations", "1", "--batch-size", "2",
                 "--workers", "1", "--executor", "process", "--no-video", "--no-progress",
                 "--out", str(tmp_path / "d")]) == 0
    manifest = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert manifest["config"]["task_name"] == spec  # a resumed run finds it the same way
    assert f"task {spec}: " in capsys.readouterr().out


# ------------------------------------------------------------------ entry points
def _entry_point(name: str, value: str) -> importlib.metadata.EntryPoint:
    return importlib.metadata.EntryPoint(name=name, value=value, group=ENTRY_POINT_GROUP)


def test_get_task_loads_an_installed_entry_point_by_name(monkeypatch, user_module):
    points = {"walled-hook-cli": _entry_point("walled-hook-cli", f"{user_module}:WALLED")}
    monkeypatch.setattr(task_registry, "_entry_points", lambda: points)
    assert get_task("walled-hook-cli").obstacles[0].name == "wall"
    assert "walled-hook-cli" not in task_names()  # loaded when asked for, never registered
    with pytest.raises(ValueError, match=r"known tasks: push, hook, obstacle, puck, walled-hook"):
        get_task("pushh")  # the installed ones are named among what is allowed


@pytest.mark.parametrize(
    ("name", "value", "error", "words"),
    [
        ("other", "usertasks.walled:WALLED", TypeError, "is the task 'walled-hook-cli', not one"),
        ("three", "usertasks.walled:NOT_A_TASK", TypeError, "names int 3"),
        ("gone", "nosuchmod:WALLED", ValueError, "cannot be loaded"),
    ],
)
def test_a_bad_entry_point_is_refused_naming_it(monkeypatch, user_module, name, value, error,
                                                 words):
    monkeypatch.setattr(task_registry, "_entry_points", lambda: {name: _entry_point(name, value)})
    with pytest.raises(error, match=re.escape(words)) as refused:
        get_task(name)
    assert repr(name) in str(refused.value) and ENTRY_POINT_GROUP in str(refused.value)
