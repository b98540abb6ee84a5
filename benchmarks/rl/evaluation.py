"""A policy over many tasks at once, through the project's executors (process pool, Dask).

An RL agent is usually evaluated one environment at a time: reset, predict, step, in one
process. A policy's design for a task needs only the task, so the designs of many tasks are
asked first (cheap: one forward pass each) and then simulated like any batch of designs, on the
executors every optimizer uses (:func:`benchmarks.execution.make_executor`: ``serial``,
``process`` or ``dask``; the worker keeps one ``ToolDesign-v0`` env per setting). F is bit for
bit what ``ToolDesignRL-v0`` gives for the same action (``tests/test_rl_evaluation.py``).

- :class:`RLTask`: one task (goal, box mass and, optionally, box friction) with an id.
- :func:`load_designer`: a user's policy from a policy card (``.json``), a Stable-Baselines3
  ``.zip`` (unpickled: only with ``allow_pickle``) or a ``"module:callable"`` from the task to
  the action.
- :func:`policy_actions`: the policy's action for each task.
- :func:`evaluate_policy_on_tasks`: simulate them through an executor; one row per task.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from tooldesign_env.schema import DEFAULT_GOAL_PRECISION
from tooldesign_env.specs import BOX_MASS_MAX, FRICTION_MAX, WORKSPACE_HALF_WIDTH, WORKSPACE_HEIGHT

__all__ = [
    "POLICY_EVALUATION_COLUMNS",
    "SB3_ALGORITHMS",
    "CallablePolicy",
    "RLTask",
    "action_to_coefficients",
    "evaluate_policy_on_tasks",
    "load_designer",
    "policy_actions",
]

#: The Stable-Baselines3 algorithms whose ``.zip`` :func:`load_designer` loads (by name).
SB3_ALGORITHMS: tuple[str, ...] = ("ppo", "sac", "td3", "a2c", "ddpg")


def _real(value: Any) -> float | None:
    """``value`` as a float if it is a real number (not a bool, a string or an array), else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        return None
    return float(value)


@dataclasses.dataclass(frozen=True, kw_only=True)
class RLTask:
    """One task of ``ToolDesignRL-v0``: what a policy observes, and the scene it is scored in.

    Attributes:
        id: A name for tables (``"i03"``, ``"f01"``).
        goal: X^g, (x, y, z) in m, inside the env's workspace [-2.5, 2.5] x [-2.5, 2.5] x
            [0, 1] m.
        box_mass: kg, in (0, 1000] (the policy observes it).
        box_friction: The box's lateral friction, in [0, 10], or None for the scene's default
            (0.4). The policy does not observe it: ``ToolDesignRL-v0``'s observation is the goal
            and mass.
        set: Where the task comes from (``"held-out"``, ``"fresh"``, ...), free text.

    Raises:
        ValueError: A value of the wrong type (a bool, a string, ...) or outside its range, named
            in the message with what is allowed; checked here, before any policy runs, with the
            limits the scene itself applies (``tooldesign_env.specs``).
        TypeError: ``set`` not a string.
    """

    id: str
    goal: tuple[float, float, float]
    box_mass: float
    box_friction: float | None = None
    set: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id:
            raise ValueError(f"task id must be a non-empty string, got {self.id!r}")
        name = f"task {self.id}"
        half, height = WORKSPACE_HALF_WIDTH, WORKSPACE_HEIGHT
        workspace = f"[-{half:g}, {half:g}] x [-{half:g}, {half:g}] x [0, {height:g}] m"
        try:
            values = list(self.goal)
        except TypeError:
            values = []
        goal = tuple(_real(v) for v in values)
        if len(goal) != 3 or not all(v is not None and math.isfinite(v) for v in goal):
            raise ValueError(f"{name}: goal must be 3 finite numbers (m), got {self.goal!r}")
        x, y, z = cast("tuple[float, float, float]", goal)
        if not (abs(x) <= half and abs(y) <= half and 0.0 <= z <= height):
            raise ValueError(f"{name}: goal must lie in the workspace {workspace}, got {goal}")
        object.__setattr__(self, "goal", goal)
        mass = _real(self.box_mass)
        if mass is None or not (math.isfinite(mass) and 0 < mass <= BOX_MASS_MAX):
            raise ValueError(
                f"{name}: box_mass must be a number of kg in (0, {BOX_MASS_MAX:g}], "
                f"got {self.box_mass!r}"
            )
        object.__setattr__(self, "box_mass", mass)
        if self.box_friction is not None:
            friction = _real(self.box_friction)
            if friction is None or not (math.isfinite(friction) and 0 <= friction <= FRICTION_MAX):
                raise ValueError(
                    f"{name}: box_friction must be None (the scene's default) or a number in "
                    f"[0, {FRICTION_MAX:g}], got {self.box_friction!r}"
                )
            object.__setattr__(self, "box_friction", friction)
        if not isinstance(self.set, str):
            raise TypeError(f"{name}: set must be a string, got {self.set!r}")

    def observation(self) -> np.ndarray:
        """What ``ToolDesignRL-v0`` observes for this task: (x, y, z, box mass) float32."""
        return np.array([*self.goal, self.box_mass], dtype=np.float32)

    def row_fields(self) -> dict[str, Any]:
        """The task's columns of an evaluation row.

        ``task`` (the id), ``goal_x``, ``goal_y``, ``goal_z`` (m), ``box_mass`` (kg) and
        ``box_friction`` (NaN for the scene's default).
        """
        return {
            "task": self.id,
            "goal_x": self.goal[0],
            "goal_y": self.goal[1],
            "goal_z": self.goal[2],
            "box_mass": self.box_mass,
            "box_friction": math.nan if self.box_friction is None else self.box_friction,
        }


class CallablePolicy:
    """A function from the task's observation to an action, with a ``predict`` as SB3's.

    Args:
        function: Called with the observation (x, y, z in m, box mass in kg) as a float32
            array of shape (4,); returns the action, 3 numbers in [-1, 1].
        name: Its name, for messages.
    """

    def __init__(self, function: Callable[[np.ndarray], Any], name: str = "") -> None:
        if not callable(function):
            raise TypeError(f"function must be callable, got {function!r}")
        self.function = function
        self.name = name or getattr(function, "__qualname__", repr(function))

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[np.ndarray, None]:
        """The function's action for ``observation``, checked: (3,) float32 in [-1, 1]."""
        obs = np.asarray(observation, dtype=np.float32).ravel()
        try:
            action = np.asarray(self.function(obs.copy()), dtype=np.float64).ravel()
        except (TypeError, ValueError) as error:
            raise type(error)(
                f"{self.name} did not return an action for {obs.tolist()}: {error}"
            ) from error
        if action.shape != (3,) or not np.all(np.isfinite(action)):
            raise ValueError(
                f"{self.name} must return 3 finite numbers in [-1, 1] for the task "
                f"{obs.tolist()}, got {action.tolist()}"
            )
        if np.any(np.abs(action) > 1.0):
            raise ValueError(
                f"{self.name} returned the action {action.tolist()} for the task {obs.tolist()}, "
                "outside [-1, 1]; the action box is [-1, 1]^3 (clip it if that is what you mean)"
            )
        return action.astype(np.float32), None


def load_designer(
    spec: str | os.PathLike[str],
    *,
    allow_pickle: bool = False,
    algorithm: str | None = None,
) -> tuple[Any, dict[str, Any]]:
    """A user's policy, from a card, a Stable-Baselines3 ``.zip`` or a ``"module:callable"``.

    Args:
        spec: A policy card (``.json``, :func:`benchmarks.rl.save_policy`); a Stable-Baselines3
            model file (``.zip``, with ``algorithm``); or ``"package.module:function"``, a
            function from the observation (x, y, z, box mass) float32 (4,) to an action in
            [-1, 1]^3.
        allow_pickle: Needed for a ``.zip``: Stable-Baselines3 loads it by unpickling, which
            runs any code it holds (only for a file you trust).
        algorithm: The ``.zip``'s algorithm, one of :data:`SB3_ALGORITHMS`.

    Returns:
        The policy (with ``predict(observation, deterministic=True)``) and what is known of it:
        ``kind`` (``card``, ``sb3`` or ``callable``), ``name``, and for a card its fields
        ``section_shape`` and ``merge_fixed_links`` (the tool and arm it was trained with).

    Raises:
        FileNotFoundError: No such file.
        ValueError / TypeError: Not a card, ``.zip`` or ``module:callable``; a ``.zip`` without
            ``allow_pickle`` or ``algorithm``; a module or name that does not exist or is not
            callable. Each message names the value and what is allowed.
    """
    if not isinstance(spec, (str, os.PathLike)):
        raise TypeError(
            f"policy must be a path (.json card, .zip) or 'module:callable', got {spec!r}"
        )
    text = os.fspath(spec)
    if not text.strip():
        raise ValueError("policy must be a path (.json card, .zip) or 'module:callable', got ''")
    path = Path(text)
    if path.suffix == ".json":
        from benchmarks.rl.policies import load_policy

        policy, card = load_policy(path)
        return policy, {
            "kind": "card",
            "name": path.stem,
            "section_shape": card["section_shape"],
            "merge_fixed_links": card["merge_fixed_links"],
        }
    if path.suffix == ".zip":
        if not path.is_file():
            raise FileNotFoundError(f"no Stable-Baselines3 model file {text}")
        if algorithm not in SB3_ALGORITHMS:
            raise ValueError(
                f"a Stable-Baselines3 .zip needs its algorithm, one of {', '.join(SB3_ALGORITHMS)}"
                f"; got {algorithm!r}"
            )
        if allow_pickle is not True:
            from benchmarks.rl.policies import UnsafePolicyError

            raise UnsafePolicyError(
                f"{text} is loaded by unpickling, which runs any code it holds: score it only "
                "if you trust where it came from, with --allow-pickle (API: allow_pickle=True)"
            )
        from benchmarks.rl.agents import _torch_single_thread, import_sb3

        sb3 = import_sb3()
        _torch_single_thread()
        model = getattr(sb3, algorithm.upper()).load(text, device="cpu")
        return model, {"kind": "sb3", "name": path.stem}
    module_name, sep, attribute = text.partition(":")
    if not sep or not module_name or not attribute or "/" in text:
        raise ValueError(
            f"policy must be a policy card (.json), a Stable-Baselines3 model (.zip) or "
            f"'module:callable', got {text!r}"
        )
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(f"cannot import the module of the policy {text!r}: {error}") from None
    target: Any = module
    for part in attribute.split("."):
        if not hasattr(target, part):
            raise ValueError(f"the module {module_name} has no {attribute!r} (policy {text!r})")
        target = getattr(target, part)
    if hasattr(target, "predict"):
        return target, {"kind": "callable", "name": text}
    if not callable(target):
        raise TypeError(f"{text} is not callable: the policy must be a function task -> action")
    return CallablePolicy(target, text), {"kind": "callable", "name": text}


def policy_actions(policy: Any, tasks: Sequence[RLTask]) -> np.ndarray:
    """The policy's deterministic action for each task: (n, 3) float32 in [-1, 1].

    Raises:
        TypeError: ``policy`` has no ``predict``.
        ValueError: an action that is not 3 finite numbers.
    """
    if not hasattr(policy, "predict"):
        raise TypeError(f"policy must have a predict(observation) method, got {policy!r}")
    actions = []
    for task in tasks:
        action, _ = policy.predict(task.observation(), deterministic=True)
        a = np.asarray(action, dtype=np.float32).ravel()
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise ValueError(
                f"the policy's action for task {task.id} must be 3 finite numbers, got {a.tolist()}"
            )
        actions.append(np.clip(a, -1.0, 1.0))  # as evaluate_design and SB3 do
    return np.array(actions, dtype=np.float32).reshape(-1, 3)


def action_to_coefficients(action: Any, bounds: Any) -> np.ndarray:
    """The physical coefficients of an action, as ``ToolDesignRLEnv.to_coefficients`` maps it.

    Args:
        action: (d,) in [-1, 1] (float32, as the action space).
        bounds: (d, 2) coefficient bounds [low, high].

    Returns:
        (d,) float64 coefficients, bit for bit the env's.

    Raises:
        ValueError: bounds that are not one [low, high] row per coordinate, or an action that
            is not finite or outside [-1, 1].
    """
    a = np.asarray(np.asarray(action, dtype=np.float32), dtype=np.float64).ravel()
    b = np.asarray(bounds, dtype=np.float64)
    if b.ndim != 2 or b.shape != (a.size, 2):
        raise ValueError(
            f"bounds must be ({a.size}, 2) [low, high] rows, one per action coordinate, got "
            f"shape {b.shape}"
        )
    if not (np.all(np.isfinite(a)) and np.all(np.abs(a) <= 1.0)):
        raise ValueError(f"action must be finite and within [-1, 1], got {a.tolist()}")
    low, high = b[:, 0], b[:, 1]
    return np.asarray(np.clip(low + (a + 1.0) * 0.5 * (high - low), low, high))


def _task_settings(
    task: RLTask, *, section_shape: str | None, merge_fixed_links: bool | None
) -> Any:
    from benchmarks.execution import TaskSettings
    from tooldesign_env.geometry import ToolSpec
    from tooldesign_env.specs import SceneSpec

    scene: dict[str, Any] = {}
    if merge_fixed_links is not None:
        scene["merge_fixed_links"] = merge_fixed_links
    if task.box_friction is not None:
        scene["box_friction"] = task.box_friction
    extra: dict[str, Any] = {}
    if section_shape is not None:
        extra["tool"] = ToolSpec(section_shape=section_shape)
    if scene:
        extra["scene"] = SceneSpec(**scene)
    return TaskSettings(
        goal=task.goal,
        goal_precision=DEFAULT_GOAL_PRECISION,
        box_mass=task.box_mass,
        env_kwargs=extra,
    )


#: The columns of :func:`evaluate_policy_on_tasks`' frame, in order.
POLICY_EVALUATION_COLUMNS: tuple[str, ...] = (
    "task",
    "goal_x",
    "goal_y",
    "goal_z",
    "box_mass",
    "box_friction",
    "a1",
    "a2",
    "a3",
    "c1",
    "c2",
    "c3",
    "free_energy",
    "goal_error",
    "confidence",
    "final_distance",
    "status",
    "message",
    "eval_time",
)


def evaluate_policy_on_tasks(
    policy: Any,
    tasks: Sequence[RLTask],
    *,
    executor: str | Executor = "serial",
    workers: int | None = None,
    scheduler: str | None = None,
    section_shape: str | None = None,
    merge_fixed_links: bool | None = None,
) -> pd.DataFrame:
    """Simulate the policy's design for every task, through an executor: one row per task.

    The actions are asked here, in order; the designs are simulated where ``executor`` says,
    each with its task's goal, mass and friction, on ``ToolDesign-v0`` at p^X = 20 (the RL id's
    default). A design that cannot be simulated is a row with status ``invalid`` (its F the
    env's penalty) or ``failed`` (NaN), never an exception.

    Args:
        policy: Anything with ``predict(observation, deterministic=True)``.
        tasks: The tasks, at least one.
        executor: ``"serial"``, ``"process"`` or ``"dask"`` (made and shut down here, with
            ``workers`` and ``scheduler``), or an executor already made
            (:func:`benchmarks.execution.make_executor`).
        workers: Worker processes of a ``"process"`` or ``"dask"`` executor made here.
        scheduler: A Dask scheduler's address (with ``"dask"``).
        section_shape: The tool's section (a policy card's ``section_shape``); None: today's.
        merge_fixed_links: The arm (a card's ``merge_fixed_links``); None: today's.

    Returns:
        :data:`POLICY_EVALUATION_COLUMNS`, one row per task in order.

    Raises:
        TypeError / ValueError: no tasks, a task that is not an :class:`RLTask`, a bad
            executor name, or a policy without ``predict``.
    """
    from benchmarks.execution import (
        EXECUTORS,
        EvaluationRequest,
        evaluate_design,
        make_executor,
        map_robust,
        outcome_row,
    )
    from tooldesign_env import default_bounds

    tasks = list(tasks)
    if not tasks:
        raise ValueError("tasks must hold at least one RLTask")
    bad = [t for t in tasks if not isinstance(t, RLTask)]
    if bad:
        raise TypeError(f"tasks must be RLTask objects, got {bad[0]!r}")
    if isinstance(executor, str) and executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS} or an Executor, got {executor!r}")
    if not isinstance(executor, (str, Executor)):
        raise TypeError(f"executor must be one of {EXECUTORS} or an Executor, got {executor!r}")
    actions = policy_actions(policy, tasks)
    bounds = default_bounds(3)
    coefficients = [action_to_coefficients(a, bounds) for a in actions]
    requests = [
        EvaluationRequest(
            coeffs=c,
            task=_task_settings(
                t, section_shape=section_shape, merge_fixed_links=merge_fixed_links
            ),
        )
        for c, t in zip(coefficients, tasks, strict=True)
    ]
    if isinstance(executor, Executor):
        outcomes = map_robust(executor, evaluate_design, requests)
    else:
        with make_executor(executor, workers, scheduler) as made:
            outcomes = map_robust(made, evaluate_design, requests)
    rows = []
    for task, action, c, outcome in zip(tasks, actions, coefficients, outcomes, strict=True):
        result = outcome_row(*outcome)
        rows.append(
            {
                **task.row_fields(),
                **{f"a{i + 1}": float(v) for i, v in enumerate(action)},
                **{f"c{i + 1}": float(v) for i, v in enumerate(c)},
                "free_energy": float(result["free_energy"]),
                "goal_error": float(result["goal_error"]),
                "confidence": float(result["confidence"]),
                "final_distance": float(result["final_distance"]),
                "status": str(result["status"]),
                "message": str(result.get("message", "")),
                "eval_time": float(result["eval_time"]),
            }
        )
    return pd.DataFrame(rows, columns=list(POLICY_EVALUATION_COLUMNS))
