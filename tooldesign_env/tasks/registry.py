"""The task registry: a name, and the :class:`~tooldesign_env.tasks.base.TaskDefinition` it names.

A task is registered as the definition itself or as a ``"module:attribute"`` string imported on
first use (as Gymnasium's entry points are), so that the names are known without building any
definition. A fifth task is one module that defines a ``TaskDefinition`` and one
:func:`register_task` call (docs/tasks.md, "Adding a task").

:func:`get_task` resolves a task as the optimizers' registry resolves an optimizer:

1. a name given to :func:`register_task` (the built-ins are registered this way);
2. a ``"module:ATTR"`` string naming a ``TaskDefinition`` (imported, not registered);
3. an entry point of the group ``tooldesign.tasks`` of an installed package, loaded only when
   asked for (its name must be the definition's).

The last two reach a task from the command line (``--task``) and from a process that never ran
the ``register_task`` call; :func:`task_names` lists the registered tasks only.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import re
from typing import Any

from tooldesign_env.tasks.base import TaskDefinition

__all__ = [
    "BUILTIN_TASKS",
    "DEFAULT_TASK",
    "ENTRY_POINT_GROUP",
    "env_ids",
    "get_task",
    "register_task",
    "task_names",
    "unregister_task",
]

#: The task ``ToolDesign-v0`` is: the paper's push.
DEFAULT_TASK = "push"

#: The entry-point group an installed package declares its tasks in (``name = "module:ATTR"``).
ENTRY_POINT_GROUP = "tooldesign.tasks"

#: A ``"module:ATTR"`` string, as the optimizers' ``"module:Class"``.
_SPEC = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_][\w.]*$")

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
    if (
        not isinstance(name, str)
        or not name.strip()
        or name != name.strip()
        or " " in name
        or ":" in name
    ):
        # ":" marks a "module:ATTR" string, which get_task imports instead of looking up.
        raise ValueError(
            f"a task name must be a non-empty word without spaces or ':', got {name!r}"
        )
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
    return bool(_SPEC.match(text))


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


def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    """Installed packages' tasks by name; nothing is imported."""
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)}


def _allowed() -> str:
    """What a task may be given as, for the messages: ``known tasks: push, ... (or ...)``."""
    plugins = sorted(set(_entry_points()) - set(_TASKS))
    return (
        f"known tasks: {', '.join([*_TASKS, *plugins])} (or a 'module:ATTR' naming a "
        f"TaskDefinition, or a task an installed package declares in the entry-point group "
        f"{ENTRY_POINT_GROUP!r})"
    )


def _import_definition(spec: str, origin: str) -> Any:
    """The object ``"module:ATTR"`` names; a ValueError naming ``origin`` if there is none."""
    module_name, _, attribute = spec.partition(":")
    try:
        value: Any = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(
            f"{origin}: cannot import module {module_name!r} ({error}); {_allowed()}"
        ) from None
    for part in attribute.split("."):
        try:
            value = getattr(value, part)
        except AttributeError:
            raise ValueError(
                f"{origin}: module {module_name!r} has no {attribute!r}; {_allowed()}"
            ) from None
    return value


def _definition(value: Any, origin: str, name: str | None = None) -> TaskDefinition:
    """``value`` if it is a TaskDefinition (named ``name`` when given), else a TypeError."""
    if not isinstance(value, TaskDefinition):
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise TypeError(
            f"{origin} names {type(value).__name__} {shown}, not a "
            "tooldesign_env.tasks.TaskDefinition (the only thing a task may be)"
        )
    if name is not None and value.name != name:
        raise TypeError(f"{origin} is the task {value.name!r}, not one named {name!r}")
    return value


def get_task(task: Any) -> TaskDefinition:
    """The definition of ``task``: a name, a ``"module:ATTR"``, or a ``TaskDefinition`` itself.

    A name is looked up among the registered tasks, then among the entry points of the group
    :data:`ENTRY_POINT_GROUP` (loaded, never registered); a ``"module:ATTR"`` is imported.

    Raises:
        ValueError: no task has that name, or the module or attribute of a ``"module:ATTR"``
            does not exist (the message lists what is allowed).
        TypeError: neither a str nor a definition, or what a ``"module:ATTR"`` or an entry
            point names is not a TaskDefinition (of that name, for an entry point).
    """
    if isinstance(task, TaskDefinition):
        return task
    if not isinstance(task, str):
        raise TypeError(
            f"task must be a task name ({', '.join(_TASKS)}), a 'module:ATTR' or a "
            f"TaskDefinition, got {type(task).__name__} {task!r}"
        )
    entry = _TASKS.get(task)
    if isinstance(entry, TaskDefinition):
        return entry
    if isinstance(entry, str):
        value = _import_definition(entry, f"the task {task!r} ({entry})")
        _TASKS[task] = entry = _definition(value, f"the task {task!r} ({entry})", task)
        return entry
    if ":" in task:
        if not _SPEC.match(task):
            raise ValueError(f"unknown task {task!r}; {_allowed()}")
        return _definition(_import_definition(task, f"task {task!r}"), f"task {task!r}")
    plugin = _entry_points().get(task)
    if plugin is not None:
        origin = f"the task {task!r} of entry point {plugin.value!r} ({ENTRY_POINT_GROUP})"
        try:
            value = plugin.load()
        except ImportError as error:
            raise ValueError(f"{origin} cannot be loaded: {error}") from None
        return _definition(value, origin, task)
    raise ValueError(f"unknown task {task!r}; {_allowed()}")


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
