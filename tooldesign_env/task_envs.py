"""The entry points of the task ids: ``ToolDesign-Hook-v0`` makes the hook task and no other.

Each task's ids (``ToolDesign-<Name>-v0``, ``ToolDesignRL-<Name>-v0``) are registered with
``kwargs={"task": name}``; Gymnasium lets ``gym.make(id, task=...)`` replace any registered
keyword, so a plain class entry point would make another task's env under the hook's id. The
entry point ``"tooldesign_env.task_envs:<Class>.<task>"`` (:func:`entry_point`) names a
:class:`TaskEnvCreator`, built on first use by this module's ``__getattr__``, which refuses a
``task`` that is not its own in one line. It stays a string, so the id's ``EnvSpec`` is still
JSON (``spec.to_json()``) and picklable.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["TaskEnvCreator", "entry_point"]

#: The env classes a task id can make, by the name its entry point uses.
_CLASSES = {
    "ToolDesignEnv": "tooldesign_env.env",
    "ToolDesignRLEnv": "tooldesign_env.rl",
}


def entry_point(kind: str, task: str) -> str:
    """The Gymnasium entry point of a ``kind`` env made with ``task`` and no other.

    ``kind`` is ``"ToolDesignEnv"`` or ``"ToolDesignRLEnv"``.
    """
    if kind not in _CLASSES:
        raise ValueError(f"kind must be one of {sorted(_CLASSES)}, got {kind!r}")
    return f"{__name__}:{kind}.{task}"


class TaskEnvCreator:
    """Makes ``kind(task=task, **kwargs)``; a ``task`` keyword that is another task is refused.

    Attributes:
        kind: the env class's name, a key of the registered classes.
        task: the task's registered name.
    """

    def __init__(self, kind: str, task: str) -> None:
        if kind not in _CLASSES:
            raise AttributeError(f"module {__name__!r} makes no env of kind {kind!r}")
        self.kind = kind
        self.task = task

    def _class(self) -> Any:
        return getattr(importlib.import_module(_CLASSES[self.kind]), self.kind)

    @property
    def metadata(self) -> dict[str, Any]:
        """The class's metadata: ``gym.make`` reads its render modes from the entry point."""
        metadata: dict[str, Any] = self._class().metadata
        return metadata

    def __call__(self, **kwargs: Any) -> Any:
        """The env, made with this task.

        Raises:
            ValueError: ``task`` is given and is neither this task's name nor its registered
                definition.
        """
        from tooldesign_env.tasks import TaskDefinition, get_task
        from tooldesign_env.tasks.registry import env_ids

        given = kwargs.setdefault("task", self.task)
        if given != self.task and not (
            isinstance(given, TaskDefinition) and given == get_task(self.task)
        ):
            rl = self.kind == "ToolDesignRLEnv"
            own = env_ids(self.task)[rl]
            name = given.name if isinstance(given, TaskDefinition) else given
            instead = f"{self.kind}(task=...)"
            if isinstance(name, str):
                try:
                    get_task(name)
                    instead = f"gym.make({env_ids(name)[rl]!r}) or {instead}"
                except (TypeError, ValueError):
                    pass
            raise ValueError(
                f"{own} makes the {self.task} task and takes no other, got task={given!r}; "
                f"for another task use {instead}"
            )
        return self._class()(**kwargs)

    def __repr__(self) -> str:
        return f"{entry_point(self.kind, self.task)}"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, TaskEnvCreator) and (other.kind, other.task) == (
            self.kind,
            self.task,
        )

    def __hash__(self) -> int:
        return hash((self.kind, self.task))


def __getattr__(name: str) -> TaskEnvCreator:
    """``<Class>.<task>``: the creator of a task id (Gymnasium's ``load_env_creator`` asks)."""
    kind, dot, task = name.partition(".")
    if not dot or kind not in _CLASSES or not task:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return TaskEnvCreator(kind, task)
