"""The one-step Gymnasium environment ``ToolDesign-v0``.

A step checks the action, builds the tool, and hands it to the objective's sequence
(:meth:`ToolDesignEnv.evaluate_geometry`): the scenes the objective names, one rollout each with
what its estimator asks to record, a score per rollout, their combination. Which objective or
estimator runs is the spec's choice, made once in the constructor (:mod:`tooldesign_env.objective`).

Longer than 600 lines because a public entry point checks every argument itself (the env's
constructor, ``reset``, ``step`` and ``render_rollout`` each refuse bad input with a message naming
the value), and the class docstring carries Gymnasium's sections.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tooldesign_env.bullet import not_copyable
from tooldesign_env.geometry import ToolGeometry, ToolSpec, make_tool, validate_coefficients
from tooldesign_env.objective import ObjectiveTerms, Rollout, Score, make_objective
from tooldesign_env.robustness import DEFAULT_MASSES, RobustnessResult, evaluate_robustness
from tooldesign_env.schema import GOAL_HIGH, GOAL_LOW
from tooldesign_env.simulation import ToolSimulator
from tooldesign_env.specs import (
    BOX_MASS_MAX,
    ControllerSpec,
    ObjectiveSpec,
    PlanSpec,
    SceneSpec,
    TaskSpec,
    is_unordered,
)
from tooldesign_env.tasks import DEFAULT_TASK, TaskDefinition, get_task

__all__ = [
    "ACTION_ROUNDING",
    "GOAL_HIGH",
    "GOAL_LOW",
    "SERIES_KEYS",
    "WORKSPACE_HIGH",
    "WORKSPACE_LOW",
    "SCENE_MATCH_POSITION",
    "SCENE_MATCH_YAW",
    "ToolDesignEnv",
    "check_scene_keeps_task_box",
    "default_bounds",
    "past_bounds",
]

#: How far past a bound an action may lie and still be taken as that bound, relative to the
#: larger of the bounds' magnitudes and their width: rounding only. A float32 copy of a bound is
#: off by up to 6e-8 of it, gymnasium's RescaleAction by a few float64 ulps.
ACTION_ROUNDING = 1e-6


def past_bounds(coeffs: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Which coefficients lie past their bound by more than rounding (:data:`ACTION_ROUNDING`).

    The one rule of ``env.step`` and ``tooldesign evaluate``: a coefficient at most
    ``ACTION_ROUNDING`` of the bounds' scale past a bound is taken as that bound
    (``np.clip(coeffs, low, high)``); further out, it is refused.

    Args:
        coeffs: (n,) design (c1, ..., cn).
        low: (n,) lower bounds.
        high: (n,) upper bounds.

    Returns:
        (n,) bool, true where the coefficient is outside.
    """
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    slack = ACTION_ROUNDING * np.maximum(np.maximum(np.abs(low), np.abs(high)), high - low)
    return np.asarray((coeffs < low - slack) | (coeffs > high + slack))


#: ``info`` keys of the per-step series and trajectories, there only with ``info_series=True``.
SERIES_KEYS: tuple[str, ...] = (
    "times",
    "box_trajectory",
    "torques",
    "tool_position",
    "tool_yaw",
    "joint_positions",
    "contact",
    "phase",
    "tracking_error",
    "goal_error_t",
    "confidence_t",
    "free_energy_t",
    "jacobian_norm_t",
)
#: Where a goal may be put at all (the observation space), (x, y, z) in m: the floor around the
#: robot within 2.5 m, up to 1 m high.
WORKSPACE_LOW = (-2.5, -2.5, 0.0)
WORKSPACE_HIGH = (2.5, 2.5, 1.0)


#: Largest magnitude of a coefficient bound; the default box is +-1.5.
COEFFICIENT_MAX = 1e3


def _check_bounds(bounds: Any) -> np.ndarray:
    """``bounds`` as a float array, refusing strings and bools (which numpy would convert)."""
    try:
        items = np.asarray(bounds, dtype=object).ravel().tolist()
        raw = np.asarray(bounds)
    except (TypeError, ValueError) as error:
        raise ValueError(f"bounds must be (degree, 2) numbers, got {bounds!r} ({error})") from None
    if raw.dtype.kind not in "iuf" or any(isinstance(v, (bool, np.bool_)) for v in items):
        raise TypeError(f"bounds must be (degree, 2) real numbers, got {bounds!r}")
    try:
        return raw.astype(float)
    except OverflowError:
        raise ValueError(f"bounds must be numbers that fit a float64, got {bounds!r}") from None


def _render_modes_here() -> list[str]:
    """The render modes of ``ToolDesign-v0`` that work on this machine, as ``metadata`` lists.

    ``"rgb_array"`` always (a software renderer); ``"human"`` (PyBullet's window) only where it
    can open: on Linux with an X display (``DISPLAY`` set), elsewhere always.
    """
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        return ["rgb_array"]
    return ["human", "rgb_array"]


def default_bounds(degree: int) -> np.ndarray:
    """Coefficient bounds (degree, 2): +-1.5 for every coefficient but the linear one, +-0.5.

    For the paper's cubic, c1, c2 in [-1.5, 1.5] and c3 in [-0.5, 0.5]: in this box 0.1 % of
    random tools overlap the box at the start, and the outcomes span hooks, pushers and misses.
    """
    bounds = np.tile([-1.5, 1.5], (degree, 1))
    bounds[-1] = (-0.5, 0.5)
    return bounds


def check_reset_arguments(seed: Any, options: Any) -> tuple[int | None, dict[str, Any]]:
    """``reset``'s seed as a Python int (or None) and its options as a new dict.

    Gymnasium takes only a Python int for the seed, and ``options or {}`` would read ``""``,
    ``0`` and ``False`` as no options at all.

    Args:
        seed: None or an int >= 0; a NumPy integer is converted.
        options: None or a mapping.

    Returns:
        (seed, options).

    Raises:
        TypeError: ``seed`` is a bool or not an int, or ``options`` is not a mapping.
        ValueError: ``seed`` is negative.
    """
    if seed is not None:
        # numpy would take True for the seed 1.
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
            raise TypeError(
                f"seed must be an int >= 0 or None, got {seed!r} ({type(seed).__name__})"
            )
        if seed < 0:
            raise ValueError(f"seed must be an int >= 0 or None, got {seed!r}")
        seed = int(seed)
    if options is None:
        return seed, {}
    if not isinstance(options, Mapping):
        raise TypeError(
            "options must be None or a mapping such as {'goal': (x, y, z), 'box_mass': kg}, "
            f"got {options!r} ({type(options).__name__})"
        )
    return seed, dict(options)


#: How far a given scene's box start may lie from SceneSpec's default (push's) and still be taken
#: for it, m and rad (:func:`check_scene_keeps_task_box`): far beyond the retest's nudges
#: (0.1 mm, 1e-4 rad), far below any move meant to place the box elsewhere.
SCENE_MATCH_POSITION = 0.01
SCENE_MATCH_YAW = 0.01

#: The SceneSpec fields that place the task's object: its start and size.
_BOX_PLACEMENT = ("box_position", "box_yaw", "box_size")


def _check_scene_overrides(overrides: Any, box_mass: Any) -> dict[str, Any]:
    """``scene_overrides`` as a dict of SceneSpec fields, or a one-line error naming the value."""
    if overrides is None:
        return {}
    if not isinstance(overrides, Mapping):
        raise TypeError(
            "scene_overrides must be a mapping of SceneSpec field names to values, e.g. "
            f"{{'box_friction': 0.3}}, got {type(overrides).__name__} {overrides!r}"
        )
    fields = tuple(f.name for f in dataclasses.fields(SceneSpec))
    for key in overrides:
        if key not in fields:
            raise ValueError(
                f"scene_overrides: unknown SceneSpec field {key!r}; allowed: {', '.join(fields)}"
            )
    if "box_mass" in overrides and box_mass is not None:
        raise ValueError(
            f"give box_mass ({box_mass!r}) or scene_overrides['box_mass'] "
            f"({overrides['box_mass']!r}), not both"
        )
    return dict(overrides)


def check_scene_keeps_task_box(
    definition: TaskDefinition, scene: SceneSpec, *, skip: Sequence[str] = ()
) -> None:
    """Refuse a ``scene`` that leaves the task's box where SceneSpec's defaults put it.

    ``ToolDesignEnv(task=..., scene=...)`` builds the scene given, not the task's. A scene made
    to change one field (``SceneSpec(box_friction=0.3)``) keeps SceneSpec's defaults for the
    rest, which place the box where the push task does; for a task whose box starts elsewhere
    or has another size (hook's starts at (-0.4, 1.2) m) that would move the box away from its
    goals without a word. So a field of :data:`_BOX_PLACEMENT` that is at its SceneSpec
    default (within :data:`SCENE_MATCH_POSITION` m, :data:`SCENE_MATCH_YAW` rad) while the
    task's is not is refused. A scene that puts the box anywhere else is taken as meant.

    Args:
        definition: the task.
        scene: the scene given.
        skip: fields set explicitly (``scene_overrides``), never refused.

    Raises:
        ValueError: in one line, naming the field, its value and the task's.
    """
    default = SceneSpec()
    for name in _BOX_PLACEMENT:
        if name in skip:
            continue
        given, ours, usual = (
            np.atleast_1d(np.asarray(getattr(spec, name), dtype=float))
            for spec in (scene, definition.scene, default)
        )
        limit = SCENE_MATCH_YAW if name == "box_yaw" else SCENE_MATCH_POSITION
        at_default = bool(np.all(np.abs(given - usual) <= limit))
        if at_default and bool(np.any(np.abs(ours - given) > limit)):
            raise ValueError(
                f"scene leaves {name} at SceneSpec's default {np.round(given, 4).tolist()} "
                f"(the push task's), but the {definition.name} task's is "
                f"{np.round(ours, 4).tolist()}: a scene given replaces the task's whole scene; "
                "change fields of the task's scene with scene_overrides={...} (as tooldesign "
                f"--scene does), or move the box on purpose with scene_overrides={{{name!r}: ...}}"
            )


class ToolDesignEnv(gym.Env[np.ndarray, np.ndarray]):
    """Design a hand tool for a Franka Panda: one action is one tool, the reward is -F.

    ## Description

    The reproduction of "Designing Tools with Control Confidence" (Anil Meera, Torres, Lanillos).
    A tool is a planar polynomial curve y = c1 x^3 + c2 x^2 + c3 x of fixed arc length L0 = 1.1 m
    with a straight 0.15 m handle, 0.03 m thick: a round section by default, or the paper's
    square one (``ToolSpec.section_shape``; the square's contact is chaotic, see docs/model.md).
    A simulated Panda holds it and follows a fixed plan (lower, sweep, pull, hold) under
    computed-torque control, and the tool moves a 0.1 x 0.1 x 0.2 m box toward a goal X^g. The
    designer minimizes the free energy F = sum_t [1/2 p^X |X_t - X^g|^2 - 1/2 log|Pi_U,t|], where
    the control confidence Pi_U is the curvature of the goal error with respect to the joint
    torques U. Each episode is one step: a contextual bandit whose context is the task. See
    ``docs/model.md``.

    ## Action Space

    ``Box(low, high, (degree,), float64)``: the coefficients C = (c1, ..., cn), highest power
    first. Default bounds (``default_bounds``): c1, c2 in [-1.5, 1.5], c3 in [-0.5, 0.5].
    Actions with NaN or inf, the wrong shape or a non-numeric type, or outside the bounds,
    raise ``ValueError`` / ``TypeError`` (rescale an agent's [-1, 1] output with
    ``gymnasium.wrappers.RescaleAction``). An action past a bound by rounding only, at most
    ``ACTION_ROUNDING`` (1e-6) of the bounds' scale, is the bound: RescaleAction's arithmetic
    or a float32 copy of a bound lands a few ulps outside.

    ## Observation Space

    ``Box(WORKSPACE_LOW, WORKSPACE_HIGH, (3,), float64)``: the goal X^g = (x, y, z) in m, anywhere
    in [-2.5, 2.5] x [-2.5, 2.5] x [0, 1]. The fixed default goal is (0, 1.5, 0.1); with
    ``randomize_goal=True`` each reset draws x in [-0.5, 0.5], y in [0.5, 1.5], z = 0.1 (the
    paper's range) from ``self.np_random``.

    ## Rewards

    reward = -F. ``info`` holds scalars: ``free_energy`` (= -reward), ``goal_error``
    (sum_t E_t), ``confidence`` (sum_t 1/2 log|Pi_U,t|), ``penalty``, ``final_distance``,
    ``valid``, ``success`` (a usable design left the box within the task's tolerance of the
    goal, 0.1 m for every built-in task, and standing: its up axis at most the task's
    ``max_tilt``, 10 degrees, from the vertical at the end, ``final_tilt`` in rad, and its
    centre's final height, ``final_height``, within the task's ``height_tolerance``, 0.01 m, of
    its resting height; ``is_success`` is the same bool under Stable-Baselines3's name, which
    its ``EvalCallback`` reads for ``eval/success_rate``),
    ``task`` (its name) and the goal and box mass;
    F = goal_error - confidence + penalty. With
    ``ObjectiveSpec(scene_samples=K)`` every term is the mean over K scenes whose box differs by
    a fixed small offset (smoothing the chaos of pushing), ``free_energy_std`` is the standard
    deviation of F over them (0 with K = 1), and the trajectories are the nominal scene's. With
    ``info_series=True`` it also holds the per-step series (``goal_error_t``, ``confidence_t``,
    ``free_energy_t``, ``jacobian_norm_t``) and the trajectories (``times``, ``box_trajectory``,
    ``torques``, ``tool_position``, ``tool_yaw``, ``joint_positions``, ``contact``, ``phase``,
    ``tracking_error``): :data:`SERIES_KEYS`. They are left out by default because an optimizer
    or an agent that reads only the reward would pay for 13 arrays per step.

    ## Starting State

    The box rests at radius 1.35 m, 30 degrees from the robot's x axis (the push task; other
    tasks place it elsewhere); the arm holds the tool 0.25 m above the start of the sweep.
    Nothing is random except the goal when randomized.

    ## Episode End

    Every episode ends after one step (``terminated=True``). A design that cannot be used (the
    tube folds into itself, or it overlaps the box at the start of the sweep) is not simulated:
    ``info["valid"]`` is False, ``info["invalid_reason"]`` says why, and F is the free energy of
    leaving the box where it is for the whole episode plus ``ObjectiveSpec.invalid_penalty``.

    ## Arguments

    ``gym.make("ToolDesign-v0", task="push", goal=None, randomize_goal=False, goal_precision=20.0,
    box_mass=None, estimator="contact", objective_kind=None, bounds=None, tool=ToolSpec(),
    scene=None, scene_overrides=None, plan=PlanSpec(), controller=ControllerSpec(),
    objective=ObjectiveSpec(), info_series=False, render_mode=None)``. ``task`` is a registered
    task's name or a ``tooldesign_env.tasks.TaskDefinition`` (docs/tasks.md): ``"push"``, the
    paper's, is this id; ``"hook"``, ``"obstacle"`` and ``"puck"`` are also
    ``ToolDesign-Hook-v0``, ``ToolDesign-Obstacle-v0`` and ``ToolDesign-Puck-v0``, which take
    no other ``task``. The task supplies the scene, the
    plan, the fixed obstacles, the default goal (``goal=None``) and the goal range that
    ``randomize_goal`` draws from. ``scene_overrides={"box_friction": 0.3}`` changes fields of
    the task's scene (``SceneSpec`` field names; what ``tooldesign design --scene`` does);
    ``scene`` and ``plan`` given here replace the task's whole scene and plan. Since
    ``SceneSpec()``'s defaults place the box where push does, a ``scene`` that leaves the box's
    start or size at those defaults for a task whose box is elsewhere (hook's) is refused
    (``ValueError``, :func:`check_scene_keeps_task_box`): give ``scene_overrides`` instead, or
    a scene that places the box explicitly; ``scene_overrides`` apply on top of ``scene`` when
    both are given. A goal outside the range of a task other than push, an unknown task, a
    scene whose box starts inside an obstacle, or a puck whose ``box_size[0]`` (its diameter)
    differs from ``box_size[1]`` is refused (``ValueError``). ``goal_precision``, ``estimator``,
    ``objective_kind`` and ``box_mass`` are shortcuts for the fields of ``objective`` and
    ``scene``; ``objective_kind=
    "expected-goal-error"`` scores the robust-design baseline instead of F (see
    ``ObjectiveSpec.kind``). Both take any name registered with
    ``tooldesign_env.objective.register_estimator`` / ``register_objective``.
    ``reset(options={"goal": (x, y, z), "box_mass": m})`` changes the task of one episode.

    ``render_mode="rgb_array"`` renders headless (PyBullet's software renderer, no display):
    ``render()`` returns a (360, 480, 3) uint8 frame of the scene with the goal as a green sphere,
    after a step also the arm, the tool and the box path as a blue line; ``render_rollout()``
    returns frames of the last rollout (for a GIF: ``benchmarks.design.video.write_gif``).
    ``render_mode="human"`` opens PyBullet's window and needs a display: ``metadata`` of an
    instance lists it only where one is (``DISPLAY`` set on Linux), so that Gymnasium's
    ``check_env`` passes headless; the class's ``metadata`` lists both modes.

    ## Version History

    * v0: the initial version. ``info["success"]`` and ``info["task"]`` and the ``task``
      argument were added on 2026-11-27; nothing a push episode computes changed. The same
      day ``info["final_height"]`` and ``info["final_tilt"]`` were added and ``success``
      also asks the box to end standing (``TaskDefinition.max_tilt``, ``height_tolerance``),
      and the obstacle task (``ToolDesign-Obstacle-v0``, not yet released) had its post
      beyond the box's way replaced by a curb across it, with goals beyond the curb. Later
      that day ``scene_overrides`` was added, a ``scene`` that leaves the box at
      ``SceneSpec()``'s start or size for a task whose box is elsewhere became an error (it
      had silently moved the box), and the task ids refuse ``task=`` another task; push and
      every scene derived from a task's are unchanged. Later that day ``info["is_success"]``
      (a copy of ``success``, for Stable-Baselines3) was added; nothing else changed.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 4}

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise not_copyable("a ToolDesignEnv")

    def __init__(
        self,
        *,
        task: str | TaskDefinition = DEFAULT_TASK,
        goal: Sequence[float] | None = None,
        randomize_goal: bool = False,
        goal_precision: float | None = None,
        box_mass: float | None = None,
        estimator: str | None = None,
        objective_kind: str | None = None,
        scene_samples: int | None = None,
        bounds: Any = None,
        tool: ToolSpec | None = None,
        scene: SceneSpec | None = None,
        scene_overrides: Mapping[str, Any] | None = None,
        plan: PlanSpec | None = None,
        controller: ControllerSpec | None = None,
        objective: ObjectiveSpec | None = None,
        info_series: bool = False,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        if render_mode == "human" and "human" not in _render_modes_here():
            # PyBullet's GUI ends the whole process when it finds no X server.
            raise RuntimeError(
                "render_mode='human' opens a PyBullet window and needs a display, but "
                "DISPLAY is not set; use render_mode='rgb_array' on a headless machine"
            )
        # The modes that work on this machine: Gymnasium's check_env makes the env in every
        # mode its metadata lists, so "human" is listed only where a window can open.
        self.metadata = {**type(self).metadata, "render_modes": _render_modes_here()}
        for name, value, kind in (
            ("tool", tool, ToolSpec),
            ("scene", scene, SceneSpec),
            ("plan", plan, PlanSpec),
            ("controller", controller, ControllerSpec),
            ("objective", objective, ObjectiveSpec),
        ):
            if value is not None and not isinstance(value, kind):
                raise TypeError(
                    f"{name} must be a {kind.__name__} (or None for the default), got "
                    f"{type(value).__name__} {value!r}; e.g. {name}={kind.__name__}(...)"
                )
        self.tool_spec = tool or ToolSpec()
        # The task supplies the scene, the plan, the goal and the obstacles; a scene or plan
        # given here replaces the task's (a nudged scene of the noise floor, a study's plan),
        # and scene_overrides change fields of it, as the command line's --scene does.
        definition = self.task_definition = get_task(task)
        overrides = _check_scene_overrides(scene_overrides, box_mass)
        if scene is not None:
            check_scene_keeps_task_box(definition, scene, skip=tuple(overrides))
        scene = scene or definition.scene
        if overrides:
            scene = replace(scene, **overrides)
        plan = plan or definition.plan
        definition.check_scene(scene)
        if goal is None:
            goal = definition.goal
        if box_mass is not None:
            scene = replace(scene, box_mass=box_mass)
        objective = objective or ObjectiveSpec()
        if goal_precision is not None:
            objective = replace(objective, goal_precision=goal_precision)
        if estimator is not None:
            objective = replace(objective, estimator=estimator)
        if objective_kind is not None:
            objective = replace(objective, kind=objective_kind)
        if scene_samples is not None:
            objective = replace(objective, scene_samples=scene_samples)
        self.objective = objective
        if isinstance(goal, (str, bytes)) or is_unordered(goal) or not hasattr(goal, "__len__"):
            raise TypeError(
                "goal must be 3 numbers (x, y, z) in m, in order (a list, tuple or 1-D array), "
                f"got {type(goal).__name__} {goal!r}"
            )
        self.task = TaskSpec(goal=goal)  # type: ignore[arg-type]
        definition.check_goal(self.task.goal, "goal")
        if not isinstance(randomize_goal, (bool, np.bool_)):
            # bool("no") is True: a string or number here is a mistake, not a choice.
            raise TypeError(f"randomize_goal must be True or False, got {randomize_goal!r}")
        self.randomize_goal = bool(randomize_goal)
        if not isinstance(info_series, (bool, np.bool_)):
            raise TypeError(f"info_series must be True or False, got {info_series!r}")
        self.info_series = bool(info_series)
        self.render_mode = render_mode

        degree = self.tool_spec.degree
        bounds = default_bounds(degree) if bounds is None else _check_bounds(bounds)
        if bounds.shape != (degree, 2) or not np.all(np.isfinite(bounds)):
            raise ValueError(
                f"bounds must be {degree} finite [low, high] pairs, got shape {bounds.shape}"
            )
        if not np.all(bounds[:, 0] < bounds[:, 1]):
            raise ValueError(f"bounds must have low < high in every row, got {bounds.tolist()}")
        if np.any(np.abs(bounds) > COEFFICIENT_MAX):
            raise ValueError(
                f"bounds must lie within +-{COEFFICIENT_MAX:g} (coefficients of a 1.1 m tool), "
                f"got {bounds.tolist()}"
            )
        self.action_space = spaces.Box(bounds[:, 0], bounds[:, 1], dtype=np.float64)
        self.observation_space = spaces.Box(
            np.asarray(WORKSPACE_LOW), np.asarray(WORKSPACE_HIGH), dtype=np.float64
        )
        self.check_goal(np.asarray(self.task.goal, dtype=float), "goal")

        self.simulator = ToolSimulator(
            scene=scene,
            plan=plan,
            controller=controller,
            render_mode=render_mode,
            obstacles=definition.obstacles,
            object_shape=definition.object_shape,
        )
        # The objective and its estimator, behind one interface: step never asks which.
        self._scoring = make_objective(objective)
        self._goal = np.asarray(self.task.goal, dtype=float)
        self._box_mass = scene.box_mass
        # What render() shows: the box path of the last step, and whether the world holds the
        # scene of that step (a tool that cannot be built is never put into the world).
        self._last_series: dict[str, Any] | None = None
        self._world_shows_last_step = False
        # Whether the last evaluation ran the episode's own scene in the world it checked the
        # tool in (so that the world now shows that rollout's end).
        self._nominal_world = False

    # ------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode: set the task and return it as the observation.

        Args:
            seed: seeds ``self.np_random`` (used for goal randomization): an int >= 0 (a
                NumPy integer too) or None.
            options: ``{"goal": (x, y, z)}`` and/or ``{"box_mass": kg}`` for this episode, or
                None.

        Raises:
            TypeError: ``seed`` is not an int (a bool neither) or None, ``options`` not a
                mapping or None, or an option not a number.
            ValueError: a negative seed, an unknown option, or an option out of range.
        """
        seed, options = check_reset_arguments(seed, options)
        super().reset(seed=seed)
        unknown = set(options) - {"goal", "box_mass"}
        if unknown:
            raise ValueError(f"unknown reset options {sorted(unknown)}; allowed: goal, box_mass")
        if "goal" in options:
            self._goal = self.check_goal(options["goal"], "options['goal']")
            self.task_definition.check_goal(self._goal, "options['goal']")
        elif self.randomize_goal:
            self._goal = self.task_definition.sample_goal(self.np_random)
        else:
            self._goal = np.asarray(self.task.goal, dtype=float)
        mass = options.get("box_mass", self.simulator.scene.box_mass)
        if isinstance(mass, bool) or not isinstance(mass, (int, float, np.floating, np.integer)):
            raise TypeError(f"options['box_mass'] must be a number (kg), got {type(mass).__name__}")
        try:
            number = float(mass)
        except OverflowError:
            number = math.inf
        if not (math.isfinite(number) and 0 < number <= BOX_MASS_MAX):
            raise ValueError(
                f"options['box_mass'] must be finite, > 0 and <= {BOX_MASS_MAX:g} kg, got {mass!r}"
            )
        self._box_mass = float(mass)
        self._last_series = None
        self._world_shows_last_step = False
        return self._observation(), {"goal": self._goal.copy(), "box_mass": self._box_mass}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Build, use and score the tool ``action``; the episode ends."""
        coeffs = self.check_action(action)
        geometry = make_tool(coeffs, self.tool_spec)
        info = self.evaluate_geometry(geometry, series=True)
        self._last_series = {key: info[key] for key in SERIES_KEYS}
        if not self.info_series:
            info = {k: v for k, v in info.items() if k not in SERIES_KEYS}
        self._world_shows_last_step = geometry.buildable and self._nominal_world
        if self.render_mode == "human":
            self.render()
        return self._observation(), -info["free_energy"], True, False, info

    def render(self) -> np.ndarray | None:
        """The scene, headless: an RGB array (360, 480, 3) uint8, or None in ``"human"`` mode.

        After ``reset``: the floor, the box at its start and the goal (a green sphere). After a
        step: the arm and the tool where the rollout ended, the box, the goal, and the box path
        (a blue line). Rendering needs ``render_mode="rgb_array"`` (or ``"human"``) at
        construction; it uses PyBullet's software renderer, so no display is needed.
        """
        if self.render_mode != "rgb_array":
            return None
        if not self._world_shows_last_step:
            self._show_start_scene()
        path = None if self._last_series is None else self._last_series["box_trajectory"]
        return self.simulator.world.render(goal=tuple(self._goal), path=path)

    def render_rollout(
        self, *, frames: int = 40, show_goal_range: bool = False
    ) -> list[np.ndarray]:
        """Frames of the last step's rollout, replayed from its recorded joint and box positions.

        The replay is kinematic: the arm and the box are placed where they were at evenly
        spaced control steps (the box keeps its final orientation), with the goal and the box
        path so far drawn. Needs ``render_mode="rgb_array"``.

        Args:
            frames: number of frames, >= 2.
            show_goal_range: also outline the task's goal range (``goal_low`` to
                ``goal_high`` in x and y) on the floor, in dark green.

        Returns:
            ``frames`` RGB arrays (360, 480, 3) uint8; a single frame of the start scene when the
            last design was invalid (nothing was simulated).

        Raises:
            RuntimeError: the env does not render to arrays, or no step was taken since reset.
            ValueError: ``frames`` is not an int >= 2.
        """
        if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 2:
            raise ValueError(f"frames must be an int >= 2, got {frames!r}")
        if not isinstance(show_goal_range, (bool, np.bool_)):
            raise TypeError(f"show_goal_range must be True or False, got {show_goal_range!r}")
        definition = self.task_definition
        region = (
            (
                (definition.goal_low[0], definition.goal_low[1]),
                (definition.goal_high[0], definition.goal_high[1]),
            )
            if show_goal_range
            else None
        )
        if self.render_mode != "rgb_array":
            raise RuntimeError("render_rollout needs the env made with render_mode='rgb_array'")
        if self._last_series is None:
            raise RuntimeError("render_rollout shows the last step: call step() first")
        info = self._last_series
        q, x = info["joint_positions"], info["box_trajectory"]
        # ToolSimulator keeps the handles of the bodies it built; it offers no accessor yet.
        robot = getattr(self.simulator, "_robot", None)
        box = getattr(self.simulator, "_box", None)
        if len(x) == 0 or not self._world_shows_last_step or robot is None or box is None:
            frame = self.render()
            assert frame is not None
            return [frame]
        world = self.simulator.world
        out = []
        for k in np.unique(np.linspace(0, len(x) - 1, int(frames)).round().astype(int)):
            world.set_joint_positions(robot, q[k])
            world.place_body(box, tuple(x[k]))
            out.append(world.render(goal=tuple(self._goal), path=x[: k + 1], region=region))
        return out

    def _show_start_scene(self) -> None:
        """Put the floor and the box at its start into the world (no arm: no tool was chosen).

        The same bodies as ``ToolSimulator.build`` makes, without the robot.
        """
        scene = self.simulator.scene
        world = self.simulator.world
        world.reset()
        world.add_floor(friction=scene.floor_friction)
        self.simulator.add_bodies(self._box_mass, scene.box_position, scene.box_yaw)
        self._world_shows_last_step = True

    def close(self) -> None:
        """Release the physics client."""
        self.simulator.close()

    # ------------------------------------------------------------ helpers
    def check_action(self, action: Any) -> np.ndarray:
        """The action as (degree,) float64, or a clear error saying what is wrong."""
        coeffs = validate_coefficients(action, self.tool_spec.degree)
        assert isinstance(self.action_space, spaces.Box)
        low, high = self.action_space.low, self.action_space.high
        # Rounding past a bound (a rescaled or float32 action) is taken as the bound itself.
        if np.any(past_bounds(coeffs, low, high)):
            raise ValueError(
                f"action {coeffs.tolist()} is outside the action space: each c_i must lie in "
                f"[low, high] = {np.stack([low, high], 1).tolist()}; clip it, or make the env "
                "with wider bounds=..."
            )
        return np.clip(coeffs, low, high)

    def evaluate_geometry(self, geometry: ToolGeometry, *, series: bool = True) -> dict[str, Any]:
        """Simulate and score a tool for the current task.

        Args:
            geometry: the tool.
            series: also return the per-step series and trajectories (:data:`SERIES_KEYS`).

        Returns:
            The ``info`` of a step with this tool (with the series when ``series`` is true).
        """
        info = self._evaluate_geometry(geometry)
        return info if series else {k: v for k, v in info.items() if k not in SERIES_KEYS}

    def _evaluate_geometry(self, geometry: ToolGeometry) -> dict[str, Any]:
        """Check the tool in the episode's scene, use it in the objective's scenes, score it.

        Each rollout is scored while the world still holds it (an estimator may replay it),
        then its snapshots are released.
        """
        self._nominal_world = False
        if not geometry.buildable:
            return self._invalid_info(geometry, f"cannot be built: {geometry.why_not_buildable}")
        built = self.simulator.build(geometry, box_mass=self._box_mass)
        self._nominal_world = True
        if not built.usable:
            return self._invalid_info(geometry, built.reason)
        objective = self._scoring
        scenes = objective.scenes(self._box_mass)
        rollouts: list[Rollout] = []
        terms: list[ObjectiveTerms] = []
        for index, scene in enumerate(scenes):
            if index or not scene.is_nominal:  # else the world of the check is that scene
                self.simulator.build(
                    geometry,
                    box_mass=self._box_mass if scene.box_mass is None else scene.box_mass,
                    box_offset=scene.box_offset,
                )
                self._nominal_world = False
            with self.simulator.recorded(objective.recording) as rollout:
                terms.append(objective.score(rollout, self._goal))
            rollouts.append(rollout)
        return self._info(geometry, objective.combine(scenes, rollouts, terms))

    def evaluate_robustness(
        self, action: Any, masses: Sequence[float] = DEFAULT_MASSES
    ) -> RobustnessResult:
        """The paper's robustness, accuracy and control deviation of a design (see robustness.py).

        The nominal mass is the current episode's box mass; the goal is the current goal.
        """
        geometry = make_tool(self.check_action(action), self.tool_spec)
        return evaluate_robustness(
            self.simulator,
            geometry,
            tuple(float(v) for v in self._goal),
            masses=masses,
            nominal_mass=self._box_mass,
        )

    def check_goal(self, goal: Any, label: str = "goal") -> np.ndarray:
        """``goal`` as a (3,) float array in the workspace, or an error naming ``label``."""
        if isinstance(goal, (str, bytes)) or (
            hasattr(goal, "__iter__") and any(isinstance(v, (bool, np.bool_, str)) for v in goal)
        ):
            raise TypeError(f"{label} must be 3 numbers (x, y, z) in m, got {goal!r}")
        if np.ma.isMaskedArray(goal) and np.ma.getmaskarray(goal).any():
            raise ValueError(
                f"{label} must be 3 numbers (x, y, z) in m, got masked values {goal!r}"
            )
        try:
            arr = np.asarray(goal, dtype=float)
        except OverflowError:
            raise ValueError(
                f"{label} must be 3 finite numbers (x, y, z) in m, got {goal!r}"
            ) from None
        except (TypeError, ValueError):
            raise TypeError(f"{label} must be 3 numbers (x, y, z) in m, got {goal!r}") from None
        if arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"{label} must be 3 finite numbers (x, y, z) in m, got {goal!r}")
        if not self.observation_space.contains(arr):
            raise ValueError(
                f"{label} {arr.tolist()} is outside the workspace: x, y in [-2.5, 2.5] m, "
                "z in [0, 1] m"
            )
        return arr

    def _observation(self) -> np.ndarray:
        return self._goal.astype(np.float64, copy=True)

    def box_start(self) -> np.ndarray:
        """The box centre's starting position (x, y, z) in m, in this env's scene."""
        scene = self.simulator.scene
        return np.array([*scene.box_position, scene.box_size[2] / 2.0])

    def idle_goal_error(self) -> float:
        """The summed goal error of a box that never moves, at the current task.

        T * 1/2 p^X |X_start - X^g|^2 over the T control steps: what an unusable tool achieves
        (its F adds ``ObjectiveSpec.invalid_penalty``), and the scale ``ToolDesignRL-v0``
        normalizes its reward by.
        """
        steps = len(self.simulator.reference.times)
        dist2 = float(np.sum((self.box_start() - self._goal) ** 2))
        return steps * 0.5 * self.objective.goal_precision * dist2

    def success(
        self,
        final_distance: float,
        valid: bool,
        final_height: float | None = None,
        final_tilt: float | None = None,
    ) -> bool:
        """Whether an episode succeeded: a usable tool left the box at the goal, standing.

        Args:
            final_distance: the box's final distance to the goal, m.
            valid: whether the design was usable (an unusable one never succeeds).
            final_height: the box centre's final height, m. Given, it must be within the task's
                ``height_tolerance`` of the box's resting height; None does not check it.
            final_tilt: the final angle of the box's up axis from the vertical, rad. Given, it
                must be at most the task's ``max_tilt``: a box lying on its side or tipped
                onto an obstacle is not at the goal. None does not check it.
        """
        return bool(valid) and self.task_definition.succeeded(
            final_distance, final_height, self.simulator.scene, final_tilt=final_tilt
        )

    def _common_info(self, geometry: ToolGeometry) -> dict[str, Any]:
        return {
            "task": self.task_definition.name,
            "coefficients": np.asarray(geometry.coeffs, dtype=float).copy(),
            "goal": self._goal.copy(),
            "box_mass": self._box_mass,
            "goal_precision": self.objective.goal_precision,
            "estimator": self.objective.estimator,
            "tool_mass": float(geometry.mass),
        }

    def _info(self, geometry: ToolGeometry, score: Score) -> dict[str, Any]:
        traj, terms = score.trajectory, score.terms
        success = self.success(
            terms.final_distance, True, float(traj.box_position[-1, 2]), traj.box_final_tilt
        )
        info = self._common_info(geometry)
        info.update(
            valid=True,
            invalid_reason="",
            free_energy=terms.free_energy,
            free_energy_std=score.free_energy_std,
            goal_error=terms.goal_error,
            confidence=terms.confidence,
            penalty=0.0,
            final_distance=terms.final_distance,
            final_height=float(traj.box_position[-1, 2]),
            final_tilt=traj.box_final_tilt,
            success=success,
            is_success=success,  # Stable-Baselines3's name (EvalCallback's success rate)
            times=traj.times,
            box_trajectory=traj.box_position,
            torques=traj.torques,
            tool_position=traj.tool_position,
            tool_yaw=traj.tool_yaw,
            joint_positions=traj.joint_positions,
            contact=traj.contact,
            phase=traj.phase,
            tracking_error=traj.tracking_error,
            goal_error_t=terms.goal_error_t,
            confidence_t=terms.confidence_t,
            free_energy_t=terms.free_energy_t,
            jacobian_norm_t=terms.jacobian_norm_t,
            fast_forward_from=traj.fast_forward_from,
        )
        return info

    def _invalid_info(self, geometry: ToolGeometry, reason: str) -> dict[str, Any]:
        idle = self.idle_goal_error()
        penalty = float(self.objective.invalid_penalty)
        info = self._common_info(geometry)
        info.update(
            valid=False,
            invalid_reason=reason,
            free_energy=idle + penalty,
            free_energy_std=0.0,
            goal_error=idle,
            confidence=0.0,
            penalty=penalty,
            final_distance=float(np.linalg.norm(self.box_start() - self._goal)),
            final_height=float(self.box_start()[2]),
            final_tilt=0.0,
            success=False,
            is_success=False,
            times=np.zeros(0),
            box_trajectory=np.zeros((0, 3)),
            torques=np.zeros((0, 7)),
            tool_position=np.zeros((0, 3)),
            tool_yaw=np.zeros(0),
            joint_positions=np.zeros((0, 7)),
            contact=np.zeros(0, dtype=bool),
            phase=np.zeros(0, dtype=np.int8),
            tracking_error=np.zeros(0),
            goal_error_t=np.zeros(0),
            confidence_t=np.zeros(0),
            free_energy_t=np.zeros(0),
            jacobian_norm_t=np.zeros(0),
            fast_forward_from=0,
        )
        return info
