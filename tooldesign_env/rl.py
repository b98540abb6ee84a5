"""``ToolDesignRL-v0``: the tool-design problem with the interface RL libraries expect.

``ToolDesign-v0`` is made for optimizers: its action is the physical coefficient vector and its
reward is -F, whose scale (about -2,000 to -30,000) depends on the goal. This module wraps the same
simulation for RL agents: a [-1, 1] float32 action, the task (goal and box mass) as a float32
observation, a reward normalized per task, and :func:`make_rl_vector_env`, the vector-env recipe
with the autoreset mode a one-step env needs. Nothing here changes ``ToolDesign-v0``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv

from tooldesign_env.bullet import not_copyable
from tooldesign_env.env import (
    WORKSPACE_HIGH,
    WORKSPACE_LOW,
    ToolDesignEnv,
    check_reset_arguments,
)
from tooldesign_env.geometry.validation import validate_coefficients
from tooldesign_env.schema import METRICS
from tooldesign_env.specs import BOX_MASS_MAX, MASS_RANGE_MIN

__all__ = [
    "MIN_GOAL_DISTANCE",
    "REWARD_CEILING",
    "REWARD_FLOOR",
    "normalized_reward",
    "RL_ENV_ID",
    "ToolDesignRLEnv",
    "make_rl_vector_env",
]

RL_ENV_ID = "ToolDesignRL-v0"

#: Lowest normalized reward: every unusable design gets it, whatever the goal (its F, F_idle plus
#: the invalid penalty, would fall short of 2 F_idle at a goal whose F_idle exceeds the penalty),
#: and 1 - F / F_idle is clipped here, so does the rare usable design with F >= 2 F_idle, which
#: leaves the box more than twice as far off as not touching it (the straight tool at the
#: paper's corner (0.5, 0.5, 0.1); 20 of the 75,457 usable episodes of the committed rl suite,
#: docs/rl.md). The floor keeps a design that sends the box far away from outweighing the rest.
#: Above 1 (F < 0, when the confidence term outweighs the goal error) the reward is
#: 1 + tanh(-F / F_idle): it goes on rising as F falls, with the same slope at F = 0, and stays
#: below REWARD_CEILING = 2. F < 0 is common where F_idle is small: in the hook task at p^X = 20
#: (F_idle 1,710 at its default goal) CMA-ES's best design has F -187 and the curl (1.5, 1.5,
#: 0.5) F -40 (docs/results/tasks/baselines.json). A clip at 1 gave all of them the same reward,
#: above designs that succeed with F > 0; the linear 1 - F / F_idle without a bound reached 5e11
#: at p^X = 1e-12 (F_idle near 0). No episode of the committed rl and breakeven results reached
#: 1 (the largest reward was 0.845), so neither change moved any of them.
REWARD_FLOOR = -1.0
#: The normalized reward's upper bound, approached as F / F_idle goes to minus infinity.
REWARD_CEILING = 2.0

#: Closest a goal may be to the box's starting position (m) under ``reward="normalized"``: the
#: box's own width. F_idle grows with the squared distance, so at the start it is 0 and
#: 1 - F / F_idle is undefined, and a few cm away every design would sit at the floor. The
#: paper's goals are at least 0.67 m away.
MIN_GOAL_DISTANCE = 0.1

#: Keys of the base env's ``info`` kept by default: the scalars (the per-step arrays are large
#: and would be pickled through every worker's pipe of an async vector env).
_SCALAR_INFO = (
    *METRICS,
    "penalty",
    "free_energy_std",
    "fast_forward_from",
    "estimator",
    "goal_precision",
    "valid",
    "success",
    "is_success",
    "final_height",
    "final_tilt",
    "task",
    "invalid_reason",
    "coefficients",
    "goal",
    "box_mass",
    "tool_mass",
)


def _check_range(value: Any, name: str, low: float, high: float, unit: str) -> tuple[float, float]:
    """``value`` as a (lo, hi) pair of finite floats with low <= lo <= hi <= high.

    ``value`` is any sequence or 1-D array of two real numbers (not bools).
    """
    if isinstance(value, np.ndarray):
        value = value.tolist() if value.ndim == 1 else value
    if (
        isinstance(value, (str, bytes))
        or not isinstance(value, Sequence)
        or len(value) != 2
        or any(
            isinstance(v, (bool, np.bool_))
            or not isinstance(v, (int, float, np.integer, np.floating))
            for v in value
        )
    ):
        raise TypeError(f"{name} must be a pair (low, high) of numbers in {unit}, got {value!r}")
    lo, hi = float(value[0]), float(value[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and low <= lo <= hi <= high):
        raise ValueError(
            f"{name} must satisfy {low:g} <= low <= high <= {high:g} ({unit}), got {value!r}"
        )
    return lo, hi



def normalized_reward(free_energy: float, idle_free_energy: float) -> float:
    """The normalized reward of a usable design: ``1 - F / F_idle`` in [-1, 1], and above 1.

    Args:
        free_energy: F of the design (finite).
        idle_free_energy: F_idle at the goal (finite, > 0).

    Returns:
        ``max(1 - F / F_idle, REWARD_FLOOR)`` for F >= 0 and ``1 + tanh(-F / F_idle)``, in
        [1, ``REWARD_CEILING``), for F < 0: strictly decreasing in F above the floor, with the
        same slope on both sides of F = 0.

    Raises:
        ValueError: A value that is not finite, or F_idle <= 0.
    """
    if not (math.isfinite(free_energy) and math.isfinite(idle_free_energy)):
        raise ValueError(
            f"free_energy {free_energy!r} and idle_free_energy {idle_free_energy!r} must be finite"
        )
    if idle_free_energy <= 0.0:
        raise ValueError(f"idle_free_energy must be > 0, got {idle_free_energy!r}")
    ratio = free_energy / idle_free_energy
    if ratio < 0.0:
        return 1.0 + math.tanh(-ratio)
    return max(1.0 - ratio, REWARD_FLOOR)

class ToolDesignRLEnv(gym.Env[np.ndarray, np.ndarray]):
    """``ToolDesign-v0`` for RL agents: normalized action, task observation, per-task reward.

    ## Description

    The same one-step problem as ``ToolDesign-v0`` (see ``docs/model.md``): one action is one
    tool, the Panda uses it on the box, and the episode ends. Each episode is a contextual bandit
    whose context, the task, is the observation. See ``docs/rl.md``.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``, mapped affinely onto the coefficient bounds of the base env
    (default c1, c2 in [-1.5, 1.5], c3 in [-0.5, 0.5]): -1 is the lower bound, 1 the upper one.
    Actions that are not finite, have the wrong shape, or lie outside [-1, 1] raise
    ``ValueError`` / ``TypeError`` (SB3 clips its agents' actions to the box before a step).

    ## Observation Space

    ``Box(float32)`` of shape (4,): the goal X^g = (x, y, z) in m (within x, y in [-2.5, 2.5],
    z in [0, 1]) and the box mass in kg (within (0, 1000]). The observation is the whole task:
    the starting scene is otherwise fixed.

    ## Rewards

    With ``reward="normalized"`` (the default) the reward is ``1 - F / F_idle``, clipped below
    at ``REWARD_FLOOR`` = -1, where F_idle = T * 1/2 p^X |X_start - X^g|^2 is the free energy
    of leaving the box where it is for the T control steps of the episode, at this goal. 0
    means "no better than not touching the box", 1 means "goal error and confidence cancel"
    (F = 0), and the scale is the same at every goal. Every unusable design is at the floor, at
    every goal, and so is every design with F >= 2 F_idle: a usable one that does more than
    twice as badly as leaving the box where it is (the straight tool at the paper's corner
    (0.5, 0.5, 0.1) does; 20 of the 75,457 usable episodes of the committed rl suite did). A
    goal (or a ``goal_range``) closer than ``MIN_GOAL_DISTANCE`` = 0.1 m to the box's starting
    position is refused with ``reward="normalized"`` (``ValueError``), since F_idle is 0 there.
    A reward above 1 means F < 0, the confidence term outweighs the goal error: there the
    reward is ``1 + tanh(-F / F_idle)``, which keeps rising as F falls (the same slope as
    ``1 - F / F_idle`` at F = 0) and stays below ``REWARD_CEILING`` = 2. That happens at small
    p^X (with p^X = 1e-3 F_idle is a few units) and also at p^X = 20 where F_idle is small, as
    in the hook task, whose goals lie near the box (F_idle 1,710 at its default goal, where
    CMA-ES's best design has F -187 and scores 1.11). So the reward is in [-1, 2), strictly
    decreasing in F above the floor; F still ranks designs at one goal, and a lower F is not
    always a success (hook's F -187 design leaves the box 0.12 m off). ``reward="free-energy"``
    gives -F as ``ToolDesign-v0`` does, at any goal and any p^X (``info``'s
    ``normalized_reward`` is then NaN closer than 0.1 m, and at p^X = 0). ``info`` holds
    ``free_energy``, ``idle_free_energy``, ``normalized_reward`` and the base env's scalar terms
    (``goal_error``, ``confidence``, ``penalty``, ``final_distance``, ``valid``, ``success``,
    ...), and with ``full_info=True`` also its per-step arrays. ``info["is_success"]`` is
    ``success`` under Stable-Baselines3's name: its ``EvalCallback`` logs
    ``eval/success_rate`` from it (the usable design left the box standing within the task's
    tolerance of the goal, docs/tasks.md).

    ## Starting State

    The box rests where the task puts it (``TaskDefinition.scene``): for push, the paper's
    task, at radius 1.35 m, 30 degrees from the robot's x axis; for hook at (-0.4, 1.2) m. The
    goal is ``goal`` (default the task's default goal), or with ``randomize_goal=True`` uniform
    in ``goal_range`` (default the task's goal range: for push the paper's x in [-0.5, 0.5], y in
    [0.5, 1.5], z = 0.1 m; docs/tasks.md lists the others). A ``goal_range`` that is not inside
    the task's range (push takes any) is refused naming it (``ValueError``). The box mass is
    ``box_mass`` (default 0.1 kg), or with ``mass_range=(low, high)`` uniform in it. Both are
    drawn from ``self.np_random``.
    ``goal_range`` without ``randomize_goal=True``, or ``box_mass`` with ``mass_range``, would
    be ignored and is refused (``ValueError``).

    ## Episode End

    Every episode ends after its one step (``terminated=True``, ``truncated=False``). A vector env
    must therefore reset in the same step: use :func:`make_rl_vector_env`, or
    ``vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}``. (Gymnasium's default,
    next-step autoreset, returns a reward of 0 on every second step of a one-step env.)

    ## Arguments

    ``gym.make("ToolDesignRL-v0", goal=None, randomize_goal=False, goal_range=None,
    box_mass=None, mass_range=None, reward="normalized", full_info=False, render_mode=None,
    **base_kwargs)``; ``base_kwargs`` go to ``ToolDesign-v0`` (``task``, ``goal_precision``,
    ``estimator``, ``objective_kind``, ``bounds``, ``tool``, ``scene``, ``plan``, ``controller``,
    ``objective``). ``task`` (default ``"push"``, the paper's) picks the registered task
    (docs/tasks.md); ``ToolDesignRL-Hook-v0``, ``-Obstacle-v0`` and ``-Puck-v0`` are this env
    with ``task`` set. ``goal=None`` is the task's default goal and ``goal_range=None`` its
    goal range ((0, 1.5, 0.1) and the paper's range for push).
    ``reset(options={"goal": (x, y, z), "box_mass": m})`` sets one episode's task.
    ``render_mode="rgb_array"`` renders headless as ``ToolDesign-v0`` does; ``"human"``
    is not offered (it needs a display).

    ## Version History

    * v0: the initial version. On 2026-11-27 ``task`` and ``info``'s ``success`` and ``task``
      were added (a push episode is unchanged), then ``final_height`` and ``final_tilt``,
      with ``success`` also asking the box to end standing (no committed result had a box
      lying or tipped within 0.1 m of its goal). On 2026-11-26 an unusable design was put at
      the reward floor at every goal, as this docstring always said; before, at goals whose
      F_idle exceeded the invalid penalty (beyond about 2.4 m from the box at p^X = 20) it
      got -1e5 / F_idle. The
      id stayed v0: the documented reward did not change, and every committed rl result ran
      at p^X = 20, where no goal of the paper's range is that far (at p^X = 50 its corner
      (-0.5, 1.5, 0.1) is: there an unusable design had scored -0.68, now -1). On
      2026-11-27 the clip at 1 was replaced: a design with F < 0 scores 1 + tanh(-F / F_idle),
      in (1, 2), instead of 1, so that designs with F < 0 (common in the hook task) are told
      apart; no committed rl or breakeven episode had reached 1 (the largest reward 0.845), so
      the id stayed v0. The same day a ``goal_range`` outside the task's range became an error at
      construction (it failed at the first reset before), and ``info["is_success"]`` (a copy
      of ``success``, for Stable-Baselines3's ``EvalCallback``) was added.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise not_copyable("a ToolDesignRLEnv")

    def __init__(
        self,
        *,
        goal: Sequence[float] | None = None,
        randomize_goal: bool = False,
        goal_range: tuple[Sequence[float], Sequence[float]] | None = None,
        box_mass: float | None = None,
        mass_range: tuple[float, float] | None = None,
        reward: str = "normalized",
        full_info: bool = False,
        render_mode: str | None = None,
        **base_kwargs: Any,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        if reward not in ("normalized", "free-energy"):
            raise ValueError(f"reward must be 'normalized' or 'free-energy', got {reward!r}")
        if "info_series" in base_kwargs:
            raise TypeError(
                "ToolDesignRL-v0 takes full_info=True for the base env's per-step series in "
                "info (info_series is ToolDesign-v0's name for it)"
            )
        for name, flag in (("randomize_goal", randomize_goal), ("full_info", full_info)):
            if not isinstance(flag, (bool, np.bool_)):
                raise TypeError(f"{name} must be True or False, got {flag!r}")
        # Each would be ignored otherwise: the goal is drawn only with randomize_goal, and a
        # drawn mass replaces box_mass at every reset.
        if goal_range is not None and not randomize_goal:
            raise ValueError(
                "goal_range is used only with randomize_goal=True (goals are drawn from it); "
                f"got goal_range={goal_range!r} with randomize_goal=False"
            )
        if box_mass is not None and mass_range is not None:
            raise ValueError(
                f"give box_mass ({box_mass!r}) or mass_range ({mass_range!r}), not both: "
                "with mass_range every episode draws its box mass"
            )
        self.base = ToolDesignEnv(
            goal=goal,
            box_mass=box_mass,
            render_mode=render_mode,
            info_series=bool(full_info),
            **base_kwargs,
        )
        if reward == "normalized" and self.base.objective.goal_precision <= 0:
            raise ValueError(
                "reward='normalized' divides by the idle goal error, which is 0 at "
                f"goal_precision={self.base.objective.goal_precision!r}; use "
                "reward='free-energy' for pure confidence"
            )
        self.reward_kind = reward
        self.full_info = bool(full_info)
        self.randomize_goal = bool(randomize_goal)
        if goal_range is None:
            definition = self.base.task_definition
            self.goal_range = (
                np.asarray(definition.goal_low, float),
                np.asarray(definition.goal_high, float),
            )
        else:
            self.goal_range = self._check_goal_range(goal_range)
        self.mass_range = (
            None
            if mass_range is None
            else _check_range(mass_range, "mass_range", MASS_RANGE_MIN, BOX_MASS_MAX, "kg")
        )
        self.render_mode = render_mode
        if self.reward_kind == "normalized":
            if self.randomize_goal:
                self._check_goal_distance(self._nearest_goal(), "goal_range")
            else:
                self._check_goal_distance(np.asarray(self.base.task.goal, float), "goal")

        base_space = self.base.action_space
        assert isinstance(base_space, spaces.Box)
        bounds = np.stack([base_space.low, base_space.high], axis=1)
        self.coefficient_bounds = bounds.astype(np.float64)
        degree = int(bounds.shape[0])
        self._degree = degree
        self.action_space = spaces.Box(-1.0, 1.0, (degree,), dtype=np.float32)
        low = np.array([*WORKSPACE_LOW, 0.0], dtype=np.float32)
        high = np.array([*WORKSPACE_HIGH, BOX_MASS_MAX], dtype=np.float32)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self._goal = np.asarray(self.base.task.goal, dtype=float)
        self._mass = float(self.base.simulator.scene.box_mass)
        self.last_info: dict[str, Any] | None = None

    # ------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Draw (or set) the task and return it as the observation.

        Args:
            seed: seeds ``self.np_random``, which draws the randomized goal and box mass: an
                int >= 0 (a NumPy integer too) or None.
            options: ``{"goal": (x, y, z)}`` (m) and/or ``{"box_mass": kg}`` for this episode,
                or None.

        Returns:
            The observation (x, y, z, box mass) as float32 and ``{"goal", "box_mass"}``.

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
        if "goal" not in options:
            if self.randomize_goal:
                options["goal"] = self.np_random.uniform(*self.goal_range)
            else:
                options["goal"] = np.asarray(self.base.task.goal, dtype=float)
        if "box_mass" not in options:
            if self.mass_range is not None:
                options["box_mass"] = float(self.np_random.uniform(*self.mass_range))
            else:
                options["box_mass"] = float(self.base.simulator.scene.box_mass)
        if self.reward_kind == "normalized":
            goal = self.base.check_goal(options["goal"], "goal")
            self._check_goal_distance(goal, "goal")
        # The base env validates both and raises naming the option.
        _, info = self.base.reset(options=options)
        self._goal = np.asarray(info["goal"], dtype=float)
        self._mass = float(info["box_mass"])
        self.last_info = None
        return self._observation(), {"goal": self._goal.copy(), "box_mass": self._mass}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Build, use and score the tool ``action`` (in [-1, 1]); the episode ends."""
        coefficients = self.to_coefficients(action)
        _, raw_reward, _, _, base_info = self.base.step(coefficients)
        self.last_info = base_info
        free = float(base_info["free_energy"])
        idle = self.idle_free_energy()
        if idle > 0.0 and self.goal_distance(self._goal) >= MIN_GOAL_DISTANCE:
            # An unusable design scores F_idle + the invalid penalty, which reaches the floor
            # only while F_idle <= the penalty (goals within about 2.4 m at p^X = 20, 1.5 m at
            # 50): beyond, it would outrank usable designs that do worse than that.
            valid = base_info["valid"]
            normalized = normalized_reward(free, idle) if valid else REWARD_FLOOR
        else:  # only with reward="free-energy" (p^X = 0, or a goal at the box): no scale
            normalized = math.nan
        if self.full_info:
            info = dict(base_info)
        else:
            info = {key: base_info[key] for key in _SCALAR_INFO if key in base_info}
        info.update(idle_free_energy=idle, normalized_reward=normalized)
        reward = normalized if self.reward_kind == "normalized" else float(raw_reward)
        return self._observation(), float(reward), True, False, info

    def render(self) -> np.ndarray | None:
        """The scene as an RGB array (360, 480, 3) uint8 (headless), or None without a mode."""
        if self.render_mode != "rgb_array":
            return None
        return self.base.render()

    def close(self) -> None:
        """Release the physics client (safe to call twice)."""
        self.base.close()

    # ------------------------------------------------------------ helpers
    def to_coefficients(self, action: Any) -> np.ndarray:
        """The physical coefficients (degree,) float64 of a [-1, 1] action.

        ``action`` is checked as ``ToolDesign-v0`` checks its coefficients
        (``tooldesign_env.geometry.validate_coefficients``).

        Raises:
            TypeError: ``action`` is not real numbers (a string, None, bools, complex numbers).
            ValueError: wrong shape, masked values, not finite, or outside [-1, 1].
        """
        try:
            # ToolDesign-v0's own check: refuses bools, complex and masked values too.
            a = validate_coefficients(action, self._degree)
        except (TypeError, ValueError) as error:
            message = str(error).replace("coeffs", "action", 1).replace(" (c1, ..., cn)", "")
            raise type(error)(f"{message} in [-1, 1]; got {action!r}") from None
        if np.any(np.abs(a) > 1.0):
            raise ValueError(
                f"action {a.tolist()} is outside [-1, 1]; clip it (SB3 does) or use the "
                "physical coefficients with ToolDesign-v0"
            )
        low, high = self.coefficient_bounds[:, 0], self.coefficient_bounds[:, 1]
        return np.clip(low + (a + 1.0) * 0.5 * (high - low), low, high)

    def to_action(self, coefficients: Any) -> np.ndarray:
        """The [-1, 1] float32 action of physical coefficients inside the bounds.

        float32, as the action space: ``to_coefficients(to_action(C))`` is C to about 1e-8 of
        the bounds, not bit for bit, and the pushes are chaotic enough for that to move F
        (0.4 % for the README's designed tool). Score a design found elsewhere with
        ``ToolDesign-v0`` at C itself.

        Raises:
            ValueError: wrong shape, not finite, or outside the coefficient bounds.
        """
        c = self.base.check_action(coefficients)
        low, high = self.coefficient_bounds[:, 0], self.coefficient_bounds[:, 1]
        return np.clip(2.0 * (c - low) / (high - low) - 1.0, -1.0, 1.0).astype(np.float32)

    def idle_free_energy(self) -> float:
        """F_idle of the current task: the summed goal error of a box that never moves.

        T * 1/2 p^X |X_start - X^g|^2 over the T control steps, the same as the goal-error part
        of the score of an unusable design.
        """
        return self.base.idle_goal_error()

    def goal_distance(self, goal: Any) -> float:
        """How far ``goal`` (x, y, z in m, checked like the env's goals) is from the box's start.

        The normalized reward needs at least :data:`MIN_GOAL_DISTANCE`; ``reward="free-energy"``
        takes any goal in the workspace.
        """
        checked = self.base.check_goal(goal, "goal")
        return float(np.linalg.norm(checked - self.base.box_start()))

    def _nearest_goal(self) -> np.ndarray:
        """The point of ``goal_range`` nearest the box's starting position."""
        low, high = self.goal_range
        return np.asarray(np.clip(self.base.box_start(), low, high), dtype=float)

    def _check_goal_distance(self, goal: np.ndarray, name: str) -> None:
        distance = self.goal_distance(goal)
        if distance < MIN_GOAL_DISTANCE:
            where = "reaches" if name == "goal_range" else "is"
            raise ValueError(
                f"{name} {where} {distance:.3g} m from the box's starting position "
                f"{self.base.box_start().round(4).tolist()}; reward='normalized' needs goals at "
                f"least MIN_GOAL_DISTANCE = {MIN_GOAL_DISTANCE:g} m from the box (F_idle, its "
                "scale, is 0 there); use reward='free-energy' for goals closer to it"
            )

    def _observation(self) -> np.ndarray:
        return np.array([*self._goal, self._mass], dtype=np.float32)

    def _check_goal_range(self, goal_range: Any) -> tuple[np.ndarray, np.ndarray]:
        if isinstance(goal_range, np.ndarray) and goal_range.shape == (2, 3):
            goal_range = tuple(goal_range)  # (low, high) rows, as mass_range takes arrays
        if not isinstance(goal_range, Sequence) or len(goal_range) != 2:
            raise TypeError(
                f"goal_range must be (low, high), two (x, y, z) points in m, got {goal_range!r}"
            )
        low = self.base.check_goal(goal_range[0], "goal_range[0]")
        high = self.base.check_goal(goal_range[1], "goal_range[1]")
        # Both corners in the task's own range (a box: then so is every goal drawn from it),
        # so that a bad range is refused here and not at the first reset, as options['goal'].
        definition = self.base.task_definition
        definition.check_goal(low, "goal_range[0]")
        definition.check_goal(high, "goal_range[1]")
        if np.any(low > high):
            raise ValueError(f"goal_range must have low <= high per axis, got {goal_range!r}")
        return low, high


def make_rl_vector_env(
    num_envs: int,
    *,
    vectorization_mode: str = "async",
    context: str | None = "spawn",
    **env_kwargs: Any,
) -> VectorEnv:
    """``num_envs`` copies of ``ToolDesignRL-v0`` in a Gymnasium vector env that resets right.

    A one-step env must reset in the step that ends its episode: with Gymnasium's default
    (next-step autoreset) every second step of the vector env is a reset step with reward 0.
    This sets ``autoreset_mode=AutoresetMode.SAME_STEP``: each step returns the reward of the
    episode it ended and the observation (task) of the next one; the ended episode's observation
    and info are in ``infos["final_obs"]`` and ``infos["final_info"]``.

    Args:
        num_envs: number of environments, an int >= 1.
        vectorization_mode: ``"async"`` (one process per env) or ``"sync"`` (one process).
        context: multiprocessing start method for ``"async"``; ``"spawn"`` (the default) keeps
            the workers from inheriting this process's PyBullet client. Ignored for ``"sync"``.
        **env_kwargs: arguments of ``ToolDesignRL-v0`` (e.g. ``randomize_goal=True``).

    With ``"async"`` and ``"spawn"`` each worker imports the script that made the vector env
    again, as its ``__main__``: call this under ``if __name__ == "__main__":`` in a script (not
    at its top level), or every worker makes vector envs of its own and multiprocessing stops
    with "An attempt has been made to start a new process before the current process has
    finished its bootstrapping phase". Notebooks and ``python -c`` need no guard.

    Returns:
        The vector env; close it when done.

    Raises:
        TypeError: ``num_envs`` is not an int.
        ValueError: ``num_envs`` < 1 or an unknown ``vectorization_mode``.
    """
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
        raise TypeError(f"num_envs must be an int >= 1, got {num_envs!r}")
    if num_envs < 1:
        raise ValueError(f"num_envs must be an int >= 1, got {num_envs!r}")
    if vectorization_mode not in ("async", "sync"):
        raise ValueError(
            f"vectorization_mode must be 'async' or 'sync', got {vectorization_mode!r}"
        )
    # AutoresetMode exists from Gymnasium 1.1 (the `rl` extra asks for it); the env itself
    # works with 1.0, so it is imported only here.
    from gymnasium.vector import AutoresetMode

    vector_kwargs: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP}
    if vectorization_mode == "async" and context is not None:
        vector_kwargs["context"] = context
    return gym.make_vec(
        RL_ENV_ID,
        num_envs=int(num_envs),
        vectorization_mode=vectorization_mode,
        vector_kwargs=vector_kwargs,
        **env_kwargs,
    )
