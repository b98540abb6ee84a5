"""tooldesign_env: the tool-design problem of "Designing Tools with Control Confidence".

Importing the package registers the Gymnasium environment ``ToolDesign-v0``::

    import gymnasium as gym
    import tooldesign_env  # noqa: F401  (or gym.make("tooldesign_env:ToolDesign-v0"))

    env = gym.make("ToolDesign-v0")
    goal, _ = env.reset(seed=0)
    _, reward, terminated, _, info = env.step([0.0, 0.0, 0.0])
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gymnasium.envs.registration import register, registry

from tooldesign_env.lazy import lazy_attribute

if TYPE_CHECKING:
    from tooldesign_env.env import (
        GOAL_HIGH,
        GOAL_LOW,
        WORKSPACE_HIGH,
        WORKSPACE_LOW,
        ToolDesignEnv,
        default_bounds,
        past_bounds,
    )
    from tooldesign_env.geometry import (
        ToolGeometry,
        ToolSpec,
        export_mesh,
        make_tool,
        tool_mesh,
        tool_urdf,
    )
    from tooldesign_env.objective import ObjectiveTerms, free_energy
    from tooldesign_env.robustness import DEFAULT_MASSES, RobustnessResult, evaluate_robustness
    from tooldesign_env.simulation import ToolSimulator, Trajectory
    from tooldesign_env.specs import ControllerSpec, ObjectiveSpec, PlanSpec, SceneSpec, TaskSpec

#: Where each public name lives. They are imported on first use (PEP 562), so that
#: ``import tooldesign_env.schema`` (the storage layer and the reports, which read stored results
#: only) does not load PyBullet, trimesh and SciPy.
_LAZY: dict[str, str] = {
    **dict.fromkeys(
        ("GOAL_HIGH", "GOAL_LOW", "WORKSPACE_HIGH", "WORKSPACE_LOW", "ToolDesignEnv"),
        "tooldesign_env.env",
    ),
    "default_bounds": "tooldesign_env.env",
    "past_bounds": "tooldesign_env.env",
    **dict.fromkeys(
        ("ToolGeometry", "ToolSpec", "export_mesh", "make_tool", "tool_mesh", "tool_urdf"),
        "tooldesign_env.geometry",
    ),
    "ObjectiveTerms": "tooldesign_env.objective",
    "free_energy": "tooldesign_env.objective",
    "DEFAULT_MASSES": "tooldesign_env.robustness",
    "RobustnessResult": "tooldesign_env.robustness",
    "evaluate_robustness": "tooldesign_env.robustness",
    "ToolSimulator": "tooldesign_env.simulation",
    "Trajectory": "tooldesign_env.simulation",
    **dict.fromkeys(
        ("ControllerSpec", "ObjectiveSpec", "PlanSpec", "SceneSpec", "TaskSpec"),
        "tooldesign_env.specs",
    ),
}


def __getattr__(name: str) -> Any:
    return lazy_attribute(__name__, _LAZY, name)


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


__version__ = "0.1.0"

__all__ = [
    "DEFAULT_MASSES",
    "GOAL_HIGH",
    "GOAL_LOW",
    "ControllerSpec",
    "ObjectiveSpec",
    "ObjectiveTerms",
    "PlanSpec",
    "RobustnessResult",
    "SceneSpec",
    "TaskSpec",
    "WORKSPACE_HIGH",
    "WORKSPACE_LOW",
    "ToolDesignEnv",
    "ToolGeometry",
    "ToolSimulator",
    "ToolSpec",
    "Trajectory",
    "default_bounds",
    "evaluate_robustness",
    "export_mesh",
    "free_energy",
    "make_tool",
    "past_bounds",
    "register_envs",
    "tool_mesh",
    "tool_urdf",
]

ENV_ID = "ToolDesign-v0"
#: The same problem with the interface RL libraries expect (``tooldesign_env.rl``, docs/rl.md).
RL_ENV_ID = "ToolDesignRL-v0"


def register_envs() -> None:
    """Register ``ToolDesign-v0``, ``ToolDesignRL-v0`` and every task's ids (idempotent).

    Each registered task (``tooldesign_env.tasks``) other than ``push`` gets
    ``ToolDesign-<Name>-v0`` and ``ToolDesignRL-<Name>-v0``: the same envs made with
    ``task=<name>``. Call it again after ``register_task`` to register a new task's ids.
    """
    if ENV_ID not in registry:
        register(
            id=ENV_ID,
            # No max_episode_steps: the env terminates after its one step by itself, and a
            # TimeLimit would also flag that step as truncated.
            entry_point="tooldesign_env.env:ToolDesignEnv",
            # Gymnasium's passive checker breaks an env for good after one refused reset (it
            # marks reset as checked before the reset raises); the envs check their own input,
            # and tests/test_env.py runs Gymnasium's full check_env on them.
            disable_env_checker=True,
        )
    if RL_ENV_ID not in registry:
        # Imported lazily by Gymnasium: importing the package stays as cheap as before.
        register(
            id=RL_ENV_ID, entry_point="tooldesign_env.rl:ToolDesignRLEnv", disable_env_checker=True
        )
    from tooldesign_env.task_envs import entry_point as task_entry_point
    from tooldesign_env.tasks.registry import DEFAULT_TASK, env_ids, task_names

    for name in task_names():
        if name == DEFAULT_TASK:
            continue
        env_id, rl_id = env_ids(name)
        # An entry point of the task's own, which refuses gym.make(id, task=<another task>).
        for id_, entry_point in (
            (env_id, task_entry_point("ToolDesignEnv", name)),
            (rl_id, task_entry_point("ToolDesignRLEnv", name)),
        ):
            if id_ not in registry:
                register(
                    id=id_,
                    entry_point=entry_point,
                    kwargs={"task": name},
                    disable_env_checker=True,
                )
            elif registry[id_].kwargs != {"task": name} or registry[id_].entry_point not in (
                entry_point,
                # Registered by a version of this package before the ids had their own.
                f"tooldesign_env.{'rl:ToolDesignRLEnv' if id_ == rl_id else 'env:ToolDesignEnv'}",
            ):
                # Skipping it would leave the id making another env than the task named.
                raise ValueError(
                    f"the Gymnasium id {id_} of the task {name!r} is registered already for "
                    f"{registry[id_].kwargs.get('task', registry[id_].entry_point)!r}; "
                    f"rename the task or gymnasium.registry.pop({id_!r})"
                )


register_envs()
