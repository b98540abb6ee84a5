"""The task registry: a name, and the :class:`~tooldesign_env.tasks.base.TaskDefinition` it names.

A task is registered as the definition itself or as a ``"module:attribute"`` string imported on
first use (as Gymnasium's entry points are), so that the names are known without building any
definition. A fourth task is one module that defines a ``TaskDefinition`` and one
:func:`register_task` call (docs/tasks.md, "Adding a task").
"""

from __future__ import annotations

import importlib
from typing import Any

from tooldesign_env.tasks.base import TaskDefinition

__all__ = [
    "BUILTIN_TASKS",
    "DEFAULT_TASK",
    "env_ids",
    "get_task",
    "register_task",
    "task_names",
    "unregister_task",
]

#: The task ``ToolDesign-v0`` is: the paper's push.
DEFAULT_TASK = "push"

_TASKS: dict[str, TaskDefinition | str] = {}


def register_task(name: str, definition: TaskDefinition | str) -> None:
    """Register a task under ``name``.

    Args:
        name: what ``ToolDesignEnv(task=...)`` and ``tooldesign design --task`` take.
        definition: the :class:`TaskDefinition` (its ``name`` must be ``name``), or its
            ``"module:attribute"``.

    Raises:
        ValueError: ``name`` is taken (registries never replace silently), empty, not the
            definition's own name, or its Gymnasium ids (:func:`env_ids`) are another task's
            (``walled-hook`` and ``walled_hook`` would both be ``ToolDesign-WalledHook-v0``).
        TypeError: ``definition`` is neither a TaskDefinition nor a ``"module:attribute"``.
    """
    if not isinstance(name, str) or not name.strip() or name != name.strip() or " " in name:
        raise ValueError(f"a task name must be a non-empty word without spaces, got {name!r}")
    if isinstance(definition, TaskDefinition):
        if definition.name != name:
            raise ValueError(
                f"the task registered as {name!r} is named {definition.name!r}: use one name"
            )
    elif not (isinstance(definition, str) and _is_entry_point(definition)):
        raise TypeError(
            f"the task {name!r} needs a TaskDefinition or a 'module:attribute' string naming "
            f"one, got {definition!r}"
        )
    if name in _TASKS:
        raise ValueError(
            f"a task named {name!r} is registered already; pick another name, or "
            f"unregister_task({name!r}) first"
        )
    ids = env_ids(name)
    for other in _TASKS:
        if env_ids(other) == ids:
            raise ValueError(
                f"the task {name!r} would have the Gymnasium id {ids[0]}, which is the task "
                f"{other!r}'s already; pick a name that differs by more than case or - and _"
            )
    _TASKS[name] = definition


def _is_entry_point(text: str) -> bool:
    module, _, attribute = text.partition(":")
    return bool(module) and bool(attribute) and " " not in text


def unregister_task(name: str) -> None:
    """Remove a task registered with :func:`register_task` (not a built-in one)."""
    if name in BUILTIN_TASKS:
        raise ValueError(f"the built-in task {name!r} cannot be unregistered")
    if name not in _TASKS:
        raise ValueError(f"no task named {name!r}; known tasks: {', '.join(_TASKS)}")
    del _TASKS[name]


def env_ids(name: str) -> tuple[str, str]:
    """The Gymnasium ids of the task ``name``: its env's and its RL variant's.

    ``push`` is ``ToolDesign-v0`` and ``ToolDesignRL-v0`` (the paper's task, as always); every
    other task ``ToolDesign-<Name>-v0`` and ``ToolDesignRL-<Name>-v0``, ``<Name>`` its name with
    the first letter of each ``-`` or ``_`` separated part capitalized.
    """
    if name == DEFAULT_TASK:
        return "ToolDesign-v0", "ToolDesignRL-v0"
    title = "".join(part[:1].upper() + part[1:] for part in name.replace("_", "-").split("-"))
    return f"ToolDesign-{title}-v0", f"ToolDesignRL-{title}-v0"


def task_names() -> tuple[str, ...]:
    """The registered tasks' names, built-in ones first."""
    return tuple(_TASKS)


def get_task(task: Any) -> TaskDefinition:
    """The definition of ``task``: a registered name, or a ``TaskDefinition`` itself.

    Raises:
        ValueError: no task has that name (the message lists the known ones).
        TypeError: neither a name nor a definition.
    """
    if isinstance(task, TaskDefinition):
        return task
    if not isinstance(task, str):
        raise TypeError(
            f"task must be a task name ({', '.join(_TASKS)}) or a TaskDefinition, got "
            f"{type(task).__name__} {task!r}"
        )
    try:
        entry = _TASKS[task]
    except KeyError:
        raise ValueError(f"unknown task {task!r}; known tasks: {', '.join(_TASKS)}") from None
    if isinstance(entry, str):
        module, _, attribute = entry.partition(":")
        value: Any = importlib.import_module(module)
        for part in attribute.split("."):
            value = getattr(value, part)
        if not isinstance(value, TaskDefinition) or value.name != task:
            raise TypeError(
                f"the task {task!r} ({entry}) is not a TaskDefinition named {task!r}: {value!r}"
            )
        _TASKS[task] = entry = value
    return entry


#: The built-in tasks and the modules that define them.
_BUILTIN: dict[str, str] = {
    "push": "tooldesign_env.tasks.push:PUSH",
    "hook": "tooldesign_env.tasks.hook:HOOK",
    "obstacle": "tooldesign_env.tasks.obstacle:OBSTACLE",
    "puck": "tooldesign_env.tasks.puck:PUCK",
}
BUILTIN_TASKS: tuple[str, ...] = tuple(_BUILTIN)
for _name, _path in _BUILTIN.items():
    register_task(_name, _path)
