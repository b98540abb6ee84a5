"""Tasks: named definitions of the scene's objects, the plan, the goal range and success.

``ToolDesignEnv(task="hook")`` (or ``gym.make("ToolDesign-Hook-v0")``) composes the task's scene,
plan and obstacles with the same tool, controller and F as the paper's push task. The built-in
tasks are ``push`` (``ToolDesign-v0``, the paper's), ``hook``, ``obstacle`` and ``puck``; a new
task is one module defining a :class:`TaskDefinition` and one :func:`register_task` call
(docs/tasks.md).
"""

from __future__ import annotations

from tooldesign_env.tasks.base import OBJECT_SHAPES, Obstacle, TaskDefinition, footprints_overlap
from tooldesign_env.tasks.registry import (
    BUILTIN_TASKS,
    DEFAULT_TASK,
    get_task,
    register_task,
    task_names,
    unregister_task,
)

__all__ = [
    "BUILTIN_TASKS",
    "DEFAULT_TASK",
    "OBJECT_SHAPES",
    "Obstacle",
    "TaskDefinition",
    "footprints_overlap",
    "get_task",
    "register_task",
    "task_names",
    "unregister_task",
]
