"""Every constant of the problem, in frozen keyword-only dataclasses.

The paper leaves the plan, the controller and the scene largely unspecified; the defaults below are
the values this library chose (see ``docs/model.md`` for why). Each one is a field, so a study can
change it without editing code: ``dataclasses.replace(PlanSpec(), hold_duration=1.0)``.

Units are SI: metres, seconds, kilograms, newton metres, radians.

Longer than 600 lines because every spec carries the checks of its own fields (each refusal names
the field, the value and what is allowed), and a spec's checks belong beside its fields.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, MappingView
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, fields, replace
from typing import Any, Literal

import numpy as np

from tooldesign_env.objective.registry import (
    BUILTIN_ESTIMATORS,
    BUILTIN_OBJECTIVES,
    estimator_names,
    objective_names,
)
from tooldesign_env.schema import (
    DEFAULT_BOX_MASS,
    DEFAULT_GOAL,
    DEFAULT_GOAL_PRECISION,
    EXPECTED_MASSES,
)

__all__ = [
    "BOX_MASS_MAX",
    "GOAL_PRECISION_MAX",
    "MASS_RANGE_MIN",
    "PLAN_DURATION_MAX",
    "PLAN_DURATION_MIN",
    "DEFAULT_PHYSICS",
    "LOWER_FLOOR",
    "PHYSICS_062B3A0",
    "PHYSICS_PRESETS",
    "ControllerSpec",
    "ObjectiveSpec",
    "PhysicsPreset",
    "PlanSpec",
    "SceneSpec",
    "TaskSpec",
    "check_real",
    "is_unordered",
    "physics_preset",
    "spec_to_dict",
]


#: Largest goal precision p^X accepted, 1/m^2. With it F stays far inside float64: the goal error
#: of a step is at most 1/2 p^X d^2 with d below 10 m in the workspace, over at most ~10^4
#: control steps, so |F| < 10^12 (the paper uses p^X = 20).
GOAL_PRECISION_MAX = 1e6

#: Largest box mass accepted, kg (the Panda's payload is 3 kg; PyBullet's solver is not
#: meaningful for a box a thousand times heavier than the arm's links).
BOX_MASS_MAX = 1e3

#: Lightest low end of ToolDesignRL-v0's ``mass_range``, kg (a milligram). The rl suite checks
#: its ``--mass-range`` against this same number, so a range the env would refuse is refused
#: before a run folder is made.
MASS_RANGE_MIN = 1e-6

#: Regularizer eps of log|Pi_U| accepted, (m/N m)^2: six orders of magnitude either side of the
#: default 10^-6; 10^-320 made log(1 + lambda / eps) overflow (F = -inf).
EPS_MIN = 1e-12
EPS_MAX = 1.0

#: Largest relative ridge of the trajectory estimator, response time (s) and slip speed (m/s)
#: of the contact estimator, and torque perturbation of the resimulation estimator (N m).
RIDGE_MAX = 1e3
RESPONSE_TIME_MAX = 1.0
SLIP_SPEED_MAX = 1.0
PERTURBATION_MAX = 100.0

#: Largest window and horizon of the estimators, control steps.
WINDOW_MAX = 10_000

#: Largest free energy reported for an unusable design: within the optimizers' told values, and
#: far above any F a valid design gets (below 10^12, see GOAL_PRECISION_MAX).
INVALID_PENALTY_MAX = 1e15

#: Most box masses of the ``"expected-goal-error"`` objective (each costs a rollout).
EXPECTED_MASSES_MAX = 64

#: Most scenes F may be averaged over (ObjectiveSpec.scene_samples), and the largest offsets of
#: the box in them: the smoothing is of the chaos of pushing, not a change of the task.
SCENE_SAMPLES_MAX = 64
SCENE_SHIFT_MAX = 0.01
SCENE_TURN_MAX = 0.1

#: Half-width of the workspace in x and y, and its height, m: the env's goals lie in
#: [-2.5, 2.5] x [-2.5, 2.5] x [0, 1] (``tooldesign_env.env.WORKSPACE_LOW``/``HIGH``), and so must
#: the box and the plan's points.
WORKSPACE_HALF_WIDTH = 2.5
WORKSPACE_HEIGHT = 1.0

#: Largest angle accepted for a yaw, rad: one turn either way (a yaw given in degrees, such as 30,
#: is refused instead of being read as 30 rad).
YAW_MAX = 2.0 * math.pi

#: Physics time steps accepted, s: 4 kHz (16 times PyBullet's default 240 Hz) to 50 Hz. With
#: PLAN_DURATION_MAX the finest step bounds an episode to 240,000 physics steps (about 1.2 GB
#: and half a minute for the recorded rollout at one control step per physics step).
TIME_STEP_MIN = 2.5e-4
TIME_STEP_MAX = 0.02

#: Largest control period, physics steps: with TIME_STEP_MAX the slowest control step is 1 s,
#: no longer than the shortest plan (PLAN_DURATION_MIN), so every plan has a control step.
CONTROL_PERIOD_MAX = 50

#: Largest PyBullet solver iterations per step (its default is 50; time grows with them).
SOLVER_ITERATIONS_MAX = 1000

#: Box extents accepted, m: a 1 mm die to a 2 m crate.
BOX_SIZE_MIN = 1e-3
BOX_SIZE_MAX = 2.0

#: Largest friction coefficient (rubber on concrete is about 1; none exceeds a few).
FRICTION_MAX = 10.0

#: Longest settling of the box before the arm is loaded, s (it is at rest after tenths of one).
SETTLE_TIME_MAX = 10.0

#: Largest rest speed (m/s, rad/s) and rest time (s) of the fast-forward of the final hold.
REST_SPEED_MAX = 1.0
REST_TIME_MAX = 60.0

#: Largest feedback gains, 1/s^2 and 1/s, and joint torque limit, N m (the Panda's are 87 N m).
GAIN_KP_MAX = 1e6
GAIN_KD_MAX = 1e4
TORQUE_LIMIT_MAX = 1e4

#: Shortest and longest plan, s (lower + settle + sweep + pull + hold; the default is 14.25 s).
#: The Panda cannot sweep a tool across the workspace in less than a second, and 60 s bounds the
#: episode's memory and time (see TIME_STEP_MIN).
PLAN_DURATION_MIN = 1.0
PLAN_DURATION_MAX = 60.0

#: m: PyBullet's contact breaking threshold: shapes closer than this get contact points
#: (SceneSpec.floor_clearance must exceed it).
FLOOR_CONTACT_THRESHOLD = 0.02


@dataclass(frozen=True, kw_only=True)
class PhysicsPreset:
    """The settings that move results (in their last bits or more), as one named set.

    Each field is the default of the spec field of the same name; :data:`DEFAULT_PHYSICS` is
    the set the specs take their defaults from. A preset other than the default is tried, or
    used, without changing the defaults, by :meth:`specs`, which returns the specs with its
    values: ``ToolDesignEnv(**LOWER_FLOOR.specs())``.

    Flipping the defaults is the one line ``DEFAULT_PHYSICS = ...`` below, and it must go in
    with every committed result regenerated; it was measured and not taken (docs/performance.md,
    "The flip: not taken").

    Attributes:
        name: what the preset is called (``tooldesign_env.specs.PHYSICS_PRESETS``).
        solver_iterations: ``SceneSpec.solver_iterations``.
        rest_time: ``SceneSpec.rest_time``, s.
        gram: ``ObjectiveSpec.gram``.
    """

    name: str
    solver_iterations: int
    rest_time: float
    gram: str

    def specs(
        self,
        *,
        scene: SceneSpec | None = None,
        objective: ObjectiveSpec | None = None,
    ) -> dict[str, Any]:
        """``scene`` and ``objective`` (their defaults if None) with this preset's values.

        Returns:
            ``{"scene": SceneSpec, "objective": ObjectiveSpec}``, keyword arguments of
            ``ToolDesignEnv``, ``gymnasium.make`` and ``ToolSimulator`` (which takes the scene).

        Raises:
            TypeError: ``scene`` or ``objective`` is not a spec of its kind.
        """
        given: tuple[tuple[str, object, type], ...] = (
            ("scene", scene, SceneSpec),
            ("objective", objective, ObjectiveSpec),
        )
        for label, value, kind in given:
            if value is not None and not isinstance(value, kind):
                raise TypeError(
                    f"{label} must be a {kind.__name__} or None, got {type(value).__name__} "
                    f"{value!r}"
                )
        return {
            "scene": replace(
                scene or SceneSpec(),
                solver_iterations=self.solver_iterations,
                rest_time=self.rest_time,
            ),
            "objective": replace(objective or ObjectiveSpec(), gram=self.gram),
        }


#: The physics every committed result was computed with (that of 062b3a0).
PHYSICS_062B3A0 = PhysicsPreset(
    name="062b3a0",
    solver_iterations=50,
    rest_time=0.1,
    gram="joints",
)

#: The candidates of issue 31 that the equivalence rule accepted, together, all three tests
#: (docs/performance.md, "Issue 31, staged: the evaluation at the floor and a lower floor"): fewer
#: solver iterations, a shorter rest before the fast-forward, the 3 x 3 Gram matrix.
LOWER_FLOOR = PhysicsPreset(
    name="lower-floor",
    solver_iterations=20,
    rest_time=0.05,
    gram="box",
)

#: The presets by name.
PHYSICS_PRESETS: dict[str, PhysicsPreset] = {p.name: p for p in (PHYSICS_062B3A0, LOWER_FLOOR)}

#: The preset the specs' defaults come from. A flip to another preset is this one line, in the
#: change that regenerates every committed result (docs/performance.md, "The flip: not taken").
DEFAULT_PHYSICS = PHYSICS_062B3A0


def physics_preset(name: str) -> PhysicsPreset:
    """The preset called ``name``.

    Raises:
        ValueError: no preset has that name (the message lists those that exist).
    """
    if not isinstance(name, str) or name not in PHYSICS_PRESETS:
        raise ValueError(
            f"the physics preset must be one of {sorted(PHYSICS_PRESETS)}, got {name!r}"
        )
    return PHYSICS_PRESETS[name]


def check_real(value: Any, label: str) -> float:
    """``value`` as a finite float, refusing bools, strings and other non-numbers.

    Args:
        value: the number to check.
        label: how the error names it, e.g. ``"SceneSpec.box_mass"``.

    Raises:
        TypeError: a bool, a str or anything that is not a real number.
        ValueError: NaN or infinite.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (numbers.Real, np.floating, np.integer)
    ):
        raise TypeError(f"{label} must be a real number, got {value!r} ({type(value).__name__})")
    try:
        result = float(value)
    except OverflowError:
        raise ValueError(f"{label} must be a finite number, got {value!r}") from None
    if not math.isfinite(result):
        raise ValueError(f"{label} must be a finite number, got {value!r}")
    return result


def is_unordered(value: object) -> bool:
    """Whether ``value`` is a container whose order is not the caller's: a set or a mapping.

    ``tuple({1.0, 0.5, 0.1})`` is ``(0.5, 1.0, 0.1)``: a set given for (x, y, z) would be read
    in hash order, and a mapping (or one of its views) names its items by key, not by place.
    """
    return isinstance(value, (AbstractSet, Mapping, MappingView))


def _check_positive(obj: object, *names: str, allow_zero: bool = False) -> None:
    for name in names:
        value = getattr(obj, name)
        label = f"{type(obj).__name__}.{name}"
        number = check_real(value, label)
        if not (number >= 0 if allow_zero else number > 0):
            bound = ">= 0" if allow_zero else "> 0"
            raise ValueError(f"{label} must be a finite number {bound}, got {value!r}")
        # A Fraction, Decimal or NumPy scalar stored as given would reach info dicts and JSON.
        object.__setattr__(obj, name, number)


def _check_range(
    obj: object, name: str, low: float, high: float, unit: str, *, open_low: bool = False
) -> float:
    """``obj.name`` as a finite float in [low, high] (in (low, high] with ``open_low``), stored."""
    value = getattr(obj, name)
    label = f"{type(obj).__name__}.{name}"
    number = check_real(value, label)
    if not ((low < number if open_low else low <= number) and number <= high):
        interval = f"{'(' if open_low else '['}{low:g}, {high:g}]"
        unit = f" {unit}" if unit else ""
        raise ValueError(f"{label} must be a number in {interval}{unit}, got {value!r}")
    object.__setattr__(obj, name, number)
    return number


def _check_vector(obj: object, name: str, length: int) -> tuple[float, ...]:
    """``obj.name`` as a tuple of ``length`` floats, stored, or an error naming the field.

    Raises:
        TypeError: a set or a mapping (no order of their own), or an item that is not a number.
        ValueError: not a sequence of ``length`` items (a string, a scalar, a 2-D array).
    """
    value = getattr(obj, name)
    label = f"{type(obj).__name__}.{name}"
    allowed = f"{length} finite numbers in order (a list, tuple or 1-D array)"
    if is_unordered(value):
        raise TypeError(
            f"{label} must be {allowed}, got a {type(value).__name__}, which has no order: "
            f"{value!r}"
        )
    # Any ordered 1-D container of numbers (a list, tuple, array or pandas Series) reads in
    # its own order; a string or a scalar is refused, as is an array of another shape.
    array = None if isinstance(value, (str, bytes)) else np.asarray(value, dtype=object)
    if array is None or array.ndim != 1 or len(array) != length:
        raise ValueError(f"{label} must be {allowed}, got {value!r}")
    # A tuple of floats, not the array or list given: a frozen spec must compare, hash and
    # serialize, which an ndarray field does not.
    items = tuple(check_real(v, label) for v in array)
    object.__setattr__(obj, name, items)
    return items


def _check_int(obj: object, name: str, low: int, high: int) -> None:
    value = getattr(obj, name)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(
            f"{type(obj).__name__}.{name} must be an int from {low} to {high}, got {value!r} "
            f"({type(value).__name__})"
        )
    if not low <= value <= high:
        raise ValueError(f"{type(obj).__name__}.{name} must be from {low} to {high}, got {value!r}")
    object.__setattr__(obj, name, int(value))


def _check_bool(obj: object, name: str, also: str = "") -> None:
    value = getattr(obj, name)
    if not isinstance(value, (bool, np.bool_)):
        allowed = f"True, False or {also}" if also else "True or False"
        raise TypeError(
            f"{type(obj).__name__}.{name} must be {allowed}, got {value!r} ({type(value).__name__})"
        )
    # np.True_ is not True, and JSON has no encoding for it.
    object.__setattr__(obj, name, bool(value))


#: The phases' durations of :class:`PlanSpec`, in order.
PHASE_DURATIONS = (
    "lower_duration",
    "settle_duration",
    "sweep_duration",
    "pull_duration",
    "hold_duration",
)


@dataclass(frozen=True, kw_only=True)
class PlanSpec:
    """The fixed tool-use plan pi_0 of the paper: lower, sweep, pull, hold.

    The grasp point (the centre of the tool's handle) follows straight Cartesian segments with
    minimum-jerk timing. Positions are in the world frame, whose origin is the robot's base on the
    floor, z up.

    Attributes:
        reach: q_a, the distance of the grasp point from the base during the sweep, m.
        pull_to: q_b, the y coordinate at the end of the pull, m.
        height: h, the height of the grasp point during sweep and pull, m.
        lift: how far above ``height`` the tool starts before it is lowered, m.
        lower_duration: time to lower the tool from ``height + lift`` to ``height``, s.
        settle_duration: pause after lowering, s.
        sweep_duration: time of the straight sweep from (q_a, 0, h) to (0, q_a, h), s.
        pull_duration: time of the pull from (0, q_a, h) to (0, q_b, h), s.
        hold_duration: final hold at (0, q_b, h), s. It decides how much the final box position
            weighs in the time-summed objective (see docs/model.md).
        yaw_start: tool yaw (x axis of the tool frame from the world x axis) at the sweep's start,
            rad.
        yaw_end: tool yaw at the sweep's end and during the pull, rad.

    Limits (a ValueError names the field otherwise): ``reach`` in (0, 2.5] m and ``pull_to`` in
    [0, 2.5] m (the workspace), ``height`` in (0, 1] m, ``lift`` in [0, 1] m, the yaws within
    +-2 pi rad, and the durations together 1 to 60 s (:data:`PLAN_DURATION_MIN`,
    :data:`PLAN_DURATION_MAX`), which bounds an episode's memory and time.
    """

    reach: float = 0.70
    pull_to: float = 0.35
    height: float = 0.08
    lift: float = 0.25
    lower_duration: float = 1.0
    settle_duration: float = 0.25
    sweep_duration: float = 5.0
    pull_duration: float = 2.0
    hold_duration: float = 6.0
    yaw_start: float = 0.0
    yaw_end: float = math.pi / 2

    def __post_init__(self) -> None:
        _check_positive(
            self, "reach", "height", "lower_duration", "sweep_duration", "pull_duration"
        )
        _check_positive(
            self, "pull_to", "lift", "settle_duration", "hold_duration", allow_zero=True
        )
        _check_range(self, "reach", 0.0, WORKSPACE_HALF_WIDTH, "m", open_low=True)
        _check_range(self, "pull_to", 0.0, WORKSPACE_HALF_WIDTH, "m")
        _check_range(self, "height", 0.0, WORKSPACE_HEIGHT, "m", open_low=True)
        _check_range(self, "lift", 0.0, WORKSPACE_HEIGHT, "m")
        for name in ("yaw_start", "yaw_end"):
            _check_range(self, name, -YAW_MAX, YAW_MAX, "rad")
        names = PHASE_DURATIONS
        for name in names:
            _check_range(self, name, 0.0, PLAN_DURATION_MAX, "s")
        total = self.duration
        if not PLAN_DURATION_MIN <= total <= PLAN_DURATION_MAX:
            raise ValueError(
                f"PlanSpec: the plan must last {PLAN_DURATION_MIN:g} to {PLAN_DURATION_MAX:g} s "
                f"in all ({' + '.join(names)}), got {total!r} s"
            )

    @property
    def duration(self) -> float:
        """Total length of the plan, s."""
        return (
            self.lower_duration
            + self.settle_duration
            + self.sweep_duration
            + self.pull_duration
            + self.hold_duration
        )


@dataclass(frozen=True, kw_only=True)
class ControllerSpec:
    """The computed-torque controller that turns the plan into joint torques U.

    tau = ID(q, qd, qdd_ref + kp (q_ref - q) + kd (qd_ref - qd)), clipped to ``torque_limits``,
    where ID is the inverse dynamics of the arm INCLUDING the tool (a link of the robot).

    Attributes:
        kp: proportional gain, 1/s^2.
        kd: derivative gain, 1/s.
        torque_limits: per-joint limits of the Panda, N m.
        control_period: physics steps per control step; torques are held in between.

    Limits: ``kp`` in (0, 10^6] 1/s^2 and ``kd`` in (0, 10^4] 1/s (a natural frequency of up to
    1000 rad/s, critically damped at kd = 2000), ``torque_limits`` in (0, 10^4] N m (the
    Panda's are 87 and 12), ``control_period`` from 1 to 50 (with the coarsest time step, a
    control step of 1 s: every plan, at least 1 s long, has one).
    """

    kp: float = 400.0
    kd: float = 40.0
    torque_limits: tuple[float, ...] = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
    control_period: int = 2

    def __post_init__(self) -> None:
        _check_positive(self, "kp", "kd")
        _check_range(self, "kp", 0.0, GAIN_KP_MAX, "1/s^2", open_low=True)
        _check_range(self, "kd", 0.0, GAIN_KD_MAX, "1/s", open_low=True)
        _check_vector(self, "torque_limits", 7)
        if not all(0 < v <= TORQUE_LIMIT_MAX for v in self.torque_limits):
            raise ValueError(
                f"ControllerSpec.torque_limits must be > 0 and <= {TORQUE_LIMIT_MAX:g} N m, got "
                f"{self.torque_limits}"
            )
        # Stored as Python floats: with NumPy 2, a np.float32 gain would make the feedback law
        # round to float32 in the Python loop (and not in the C loop, which computes in double).
        object.__setattr__(self, "kp", float(self.kp))
        object.__setattr__(self, "kd", float(self.kd))
        object.__setattr__(self, "torque_limits", tuple(float(v) for v in self.torque_limits))
        if (
            isinstance(self.control_period, bool)
            or not isinstance(self.control_period, int)
            or not 1 <= self.control_period <= CONTROL_PERIOD_MAX
        ):
            raise ValueError(
                f"ControllerSpec.control_period must be an int from 1 to {CONTROL_PERIOD_MAX}, "
                f"got {self.control_period!r}"
            )


@dataclass(frozen=True, kw_only=True)
class SceneSpec:
    """The physical world: time step, the box, friction.

    Attributes:
        time_step: physics time step, s.
        solver_iterations: PyBullet constraint-solver iterations per step. The default (50)
            comes from :data:`DEFAULT_PHYSICS`; 20 passes the equivalence rule and is the
            ``LOWER_FLOOR`` preset's (docs/performance.md, "Issue 31, staged").
        box_size: box extents (x, y, z), m.
        box_mass: box mass, kg.
        box_position: box centre at the start, (x, y) on the floor, m (z is half the height).
            The default is radius 1.35 m at 30 degrees from the x axis.
        box_yaw: box yaw at the start, rad.
        box_friction: lateral friction coefficient of the box.
        floor_friction: lateral friction coefficient of the floor.
        tool_friction: lateral friction coefficient of the tool.
        box_settle_time: the box rests alone on the floor for this long before the arm is
            loaded, so the episode starts with the box at rest (PyBullet resolves the initial
            contact over the first tenths of a second), s.
        fast_forward_rest: during the final hold, once the box and the arm have been at rest
            for ``rest_time``, stop stepping and repeat the rest state for the remaining steps.
            The scene is static then, so this changes the trajectory by less than the rest
            tolerance and saves about 40 % of the simulation time (see docs/model.md).
        rest_speed: box speed (m/s) and joint speed (rad/s) below which the scene is at rest.
        rest_time: how long the scene must stay at rest before fast-forwarding, s. The
            default (0.1) comes from :data:`DEFAULT_PHYSICS`; ``LOWER_FLOOR`` uses 0.05.
        arm_floor_contacts: whether the arm and the tool can touch the floor: True, False or
            ``"auto"`` (the default). With False only the box touches it, and PyBullet no
            longer tests the arm's 12 links and the tool's ~31 boxes against the floor on every
            step (about 16 % of an evaluation, see docs/performance.md); a tool lowered onto the
            floor would pass through it. ``"auto"`` simulates without those contacts, then
            checks a lower bound on how close the arm and the tool came to the floor; if it is
            below ``floor_clearance`` the episode is simulated again with them (so a plan that
            lowers the tool onto the floor costs two rollouts, and gives True's result). With
            the default plan they stay more than 5 cm above it and results are bit for bit
            those of True.
        floor_clearance: with ``arm_floor_contacts="auto"``, the clearance from the floor (m)
            below which an episode is simulated again with the arm's floor contacts. It must
            exceed 0.02 m, PyBullet's contact breaking threshold, within which a contact point
            enters the solver before the shapes touch; for a large tool, whose threshold grows
            with its size, the guard uses the larger of the two (docs/performance.md).
        merge_fixed_links: fold the links that no joint moves below the last arm joint (the
            flange, the hand and the two fingers) into the last arm link, as one rigid body with
            the same shapes and the parts' exact mass, centre of mass and inertia. The model is
            the same, the arithmetic is not: PyBullet spends about 14 % less per physics step
            on a multibody of 9 links instead of 13, and results move by rounding
            amplified by the pushes' chaos (docs/performance.md, "Fewer links"). The grasp
            target and the tool stay links of their own. The fingers' own contact settings
            (friction 1.0) give way to the last link's; only the tool touches the box here.
            On by default since 2026-11-25; a run folder stored before records no value and
            is read as ``False``, the 13-link arm it ran with (docs/benchmarks.md).

    Limits (a ValueError names the field otherwise): ``time_step`` 2.5e-4 to 0.02 s (4 kHz to
    50 Hz), ``solver_iterations`` 1 to 1000, each ``box_size`` extent 1 mm to 2 m,
    ``box_mass`` > 0 and <= 1000 kg, ``box_position`` inside the workspace (x, y within
    +-2.5 m), ``box_yaw`` within +-2 pi rad, frictions 0 to 10, ``box_settle_time`` 0 to
    10 s, ``rest_speed`` in (0, 1], ``rest_time`` 0 to 60 s, ``floor_clearance`` in
    (0.02, 1] m.
    """

    time_step: float = 1.0 / 240.0
    solver_iterations: int = DEFAULT_PHYSICS.solver_iterations
    box_size: tuple[float, float, float] = (0.1, 0.1, 0.2)
    box_mass: float = DEFAULT_BOX_MASS
    box_position: tuple[float, float] = (
        1.35 * math.cos(math.radians(30.0)),
        1.35 * math.sin(math.radians(30.0)),
    )
    box_yaw: float = 0.0
    box_friction: float = 0.4
    floor_friction: float = 1.0
    tool_friction: float = 0.5
    box_settle_time: float = 0.25
    fast_forward_rest: bool = True
    rest_speed: float = 1e-3
    rest_time: float = DEFAULT_PHYSICS.rest_time
    arm_floor_contacts: bool | Literal["auto"] = "auto"
    floor_clearance: float = 0.03
    merge_fixed_links: bool = True

    def __post_init__(self) -> None:
        _check_positive(self, "time_step", "box_mass", "rest_speed")
        _check_positive(self, "rest_time", "box_settle_time", allow_zero=True)
        _check_positive(self, "box_friction", "floor_friction", "tool_friction", allow_zero=True)
        _check_range(self, "time_step", TIME_STEP_MIN, TIME_STEP_MAX, "s")
        _check_range(self, "rest_speed", 0.0, REST_SPEED_MAX, "m/s and rad/s", open_low=True)
        _check_range(self, "rest_time", 0.0, REST_TIME_MAX, "s")
        _check_range(self, "box_settle_time", 0.0, SETTLE_TIME_MAX, "s")
        for name in ("box_friction", "floor_friction", "tool_friction"):
            _check_range(self, name, 0.0, FRICTION_MAX, "(a friction coefficient)")
        _check_vector(self, "box_size", 3)
        _check_vector(self, "box_position", 2)
        if not all(BOX_SIZE_MIN <= v <= BOX_SIZE_MAX for v in self.box_size):
            raise ValueError(
                f"SceneSpec.box_size must be three extents from {BOX_SIZE_MIN:g} to "
                f"{BOX_SIZE_MAX:g} m, got {self.box_size}"
            )
        if not all(abs(v) <= WORKSPACE_HALF_WIDTH for v in self.box_position):
            raise ValueError(
                f"SceneSpec.box_position must be inside the workspace: x, y in "
                f"[-{WORKSPACE_HALF_WIDTH:g}, {WORKSPACE_HALF_WIDTH:g}] m, got {self.box_position}"
            )
        if (
            isinstance(self.solver_iterations, bool)
            or not isinstance(self.solver_iterations, int)
            or not 1 <= self.solver_iterations <= SOLVER_ITERATIONS_MAX
        ):
            raise ValueError(
                f"SceneSpec.solver_iterations must be an int from 1 to {SOLVER_ITERATIONS_MAX}, "
                f"got {self.solver_iterations!r}"
            )
        _check_range(self, "box_yaw", -YAW_MAX, YAW_MAX, "rad")
        _check_bool(self, "fast_forward_rest")
        _check_bool(self, "merge_fixed_links")
        if isinstance(self.arm_floor_contacts, str) and self.arm_floor_contacts == "auto":
            object.__setattr__(self, "arm_floor_contacts", "auto")
        else:
            # Stored as a bool: np.True_ is not True, and the simulator tests `is True`.
            _check_bool(self, "arm_floor_contacts", also="'auto'")
        clearance = check_real(self.floor_clearance, "SceneSpec.floor_clearance")
        if not FLOOR_CONTACT_THRESHOLD < clearance <= 1.0:
            raise ValueError(
                f"SceneSpec.floor_clearance must be a number of metres in "
                f"({FLOOR_CONTACT_THRESHOLD:g}, 1], got {self.floor_clearance!r}"
            )
        object.__setattr__(self, "floor_clearance", clearance)
        if self.box_mass > BOX_MASS_MAX:
            raise ValueError(
                f"SceneSpec.box_mass must be <= {BOX_MASS_MAX:g} kg, got {self.box_mass!r}"
            )


@dataclass(frozen=True, kw_only=True)
class TaskSpec:
    """What the tool is for: where the box should go.

    Attributes:
        goal: X^g, the goal position of the box centre (x, y, z), m.
    """

    goal: tuple[float, float, float] = DEFAULT_GOAL

    def __post_init__(self) -> None:
        _check_vector(self, "goal", 3)


#: The built-in estimators and objectives; ``ObjectiveSpec`` takes every registered one
#: (:mod:`tooldesign_env.objective.registry`).
ESTIMATORS = BUILTIN_ESTIMATORS
KINDS = BUILTIN_OBJECTIVES
FORMS = ("clamped", "gauss-newton")
#: The matrices whose eigenvalues give the Gauss-Newton confidence (ObjectiveSpec.gram).
GRAMS = ("joints", "box")


@dataclass(frozen=True, kw_only=True)
class ObjectiveSpec:
    """The free energy F and how control confidence is estimated.

    Attributes:
        kind: ``"free-energy"``: F of the paper (the default). ``"expected-goal-error"``: the
            robust-design baseline, which asks for robustness directly: the mean over the box
            masses ``expected_masses`` of the summed goal error sum_t E_t, with no confidence
            term (it costs one rollout per mass). Or any objective registered with
            :func:`tooldesign_env.objective.register_objective`.
        expected_masses: box masses of ``"expected-goal-error"``, kg.
        goal_precision: p^X, the weight of the squared goal error (P^X = p^X I_3), 1/m^2.
        eps: regularizer of log|Pi_U|, (m/N m)^2: the confidence of one step is
            1/2 sum_k log(1 + max(lambda_k, 0) / eps) over the eigenvalues lambda_k of Pi_U.
        form: ``"clamped"``: Pi_U with the second-order term, negative eigenvalues clamped at 0;
            ``"gauss-newton"``: Pi_U = J^T J only.
        gram: where Pi_U is the Gauss-Newton J^T J (``form="gauss-newton"``, or an estimator
            that gives no second derivative, such as the default ``"contact"``), which matrix
            is decomposed: ``"joints"``, the 7 x 7 J^T J (the default, the arithmetic of every
            committed result), or ``"box"``, the 3 x 3 J J^T. Their non-zero eigenvalues are
            the same (J is 3 x 7), so c_t is the same up to rounding, and the 3 x 3 costs
            less (docs/performance.md, "The confidence from the 3 x 3 J J^T"). With the
            second-order term the 7 x 7 Pi_U is decomposed whatever this says.
        estimator: how dX/dU (and d2X/dU2) are estimated: ``"contact"`` (the default: a
            linearization of the tool-box contact along the rollout, from the arm's Jacobian
            and mass matrix; stable under nudges of the scene), ``"trajectory"`` (a sliding
            regression over the recorded torques; noisy, kept for comparison) or
            ``"resimulation"`` (small torque perturbations replayed in the simulator), or any
            registered with :func:`tooldesign_env.objective.register_estimator`.
        window: trajectory estimator: control steps in the sliding regression window.
        ridge: trajectory estimator: ridge penalty relative to the mean torque-change energy.
        response_time: contact estimator: how long a torque perturbation acts before the box's
            response is read, s.
        slip_speed: contact estimator: the box's speed over the floor at which it counts as
            sliding (below it static friction holds it against a small push), m/s.
        perturbation: resimulation estimator: torque perturbation, N m.
        horizon: resimulation estimator: control steps between checkpoints, and the length of
            each replay.
        invalid_penalty: the free energy reported for a design that cannot be used (it cannot be
            built, or it overlaps the box at the start); see docs/model.md.
        scene_samples: K, the number of scenes F is averaged over (randomized smoothing). Pushing
            is chaotic: a 0.1 mm change of the box's place moves F by about 1.4 % (docs/model.md,
            "Noise floor"). With K > 1 the design is used in K scenes, the first the nominal one
            and the others with the box moved by fixed offsets drawn with ``scene_seed`` (the
            same for every design: common random numbers), and every term is their mean. Costs
            K rollouts. 1 (the default) is the nominal scene alone.
        scene_jitter: standard deviations of the box's offsets in the K - 1 other scenes:
            position (m, along x and y) and yaw (rad).
        scene_seed: seed of the offsets.

    Limits (a ValueError names the field otherwise): ``goal_precision`` 0 to 10^6 1/m^2
    (above 0 with ``kind="expected-goal-error"``, whose objective p^X = 0 would make 0),
    ``eps`` 10^-12 to 1 (m/N m)^2 (below, log|Pi_U| overflows: 10^-320 gave F = -inf),
    ``expected_masses`` a sequence of 1 to 64 masses in (0, 1000] kg, ``window`` and
    ``horizon`` 2 to 10,000 control steps, ``ridge`` in (0, 1000], ``response_time`` in (0, 1] s,
    ``slip_speed`` in (0, 1] m/s, ``perturbation`` in (0, 100] N m, ``invalid_penalty`` in
    (0, 10^15], ``scene_samples`` 1 to 64, ``scene_jitter`` at most (0.01 m, 0.1 rad),
    ``scene_seed`` 0 to 2^32 - 1.
    """

    kind: str = "free-energy"
    expected_masses: tuple[float, ...] = EXPECTED_MASSES
    goal_precision: float = DEFAULT_GOAL_PRECISION
    eps: float = 1e-6
    form: str = "clamped"
    gram: str = DEFAULT_PHYSICS.gram
    estimator: str = "contact"
    window: int = 24
    ridge: float = 0.1
    response_time: float = 0.1
    slip_speed: float = 0.01
    perturbation: float = 0.5
    horizon: int = 6
    invalid_penalty: float = 1e5
    scene_samples: int = 1
    scene_jitter: tuple[float, float] = (1e-3, 1e-2)
    scene_seed: int = 0

    def __post_init__(self) -> None:
        _check_positive(self, "goal_precision", allow_zero=True)
        if self.goal_precision > GOAL_PRECISION_MAX:
            raise ValueError(
                f"ObjectiveSpec.goal_precision must be <= {GOAL_PRECISION_MAX:g} 1/m^2 so that F "
                f"stays finite, got {self.goal_precision!r}"
            )
        _check_positive(
            self,
            "eps",
            "ridge",
            "response_time",
            "slip_speed",
            "perturbation",
            "invalid_penalty",
        )
        _check_range(self, "eps", EPS_MIN, EPS_MAX, "(m/N m)^2")
        _check_range(self, "ridge", 0.0, RIDGE_MAX, "(relative)", open_low=True)
        _check_range(self, "response_time", 0.0, RESPONSE_TIME_MAX, "s", open_low=True)
        _check_range(self, "slip_speed", 0.0, SLIP_SPEED_MAX, "m/s", open_low=True)
        _check_range(self, "perturbation", 0.0, PERTURBATION_MAX, "N m", open_low=True)
        _check_range(self, "invalid_penalty", 0.0, INVALID_PENALTY_MAX, "", open_low=True)
        kinds = objective_names()
        if self.kind not in kinds:
            raise ValueError(f"ObjectiveSpec.kind must be one of {kinds}, got {self.kind!r}")
        if self.kind == "expected-goal-error" and self.goal_precision == 0:
            raise ValueError(
                "ObjectiveSpec.goal_precision must be > 0 with kind='expected-goal-error': its "
                "objective is the goal error weighted by p^X alone, so p^X = 0 scores every "
                f"design 0; got {self.goal_precision!r}"
            )
        masses_given = self.expected_masses
        if is_unordered(masses_given):
            raise TypeError(
                f"ObjectiveSpec.expected_masses must be 1 to {EXPECTED_MASSES_MAX} masses in order "
                f"(a list, tuple or 1-D array), got a {type(masses_given).__name__}, which has no "
                f"order: {masses_given!r}"
            )
        masses = (
            tuple(masses_given)
            if isinstance(masses_given, Iterable) and not isinstance(masses_given, (str, bytes))
            else ()
        )
        if (
            not masses
            or len(masses) > EXPECTED_MASSES_MAX
            or not all(
                not isinstance(m, bool)
                and isinstance(m, (int, float))
                and math.isfinite(m)
                and 0 < m <= BOX_MASS_MAX
                for m in masses
            )
        ):
            raise ValueError(
                f"ObjectiveSpec.expected_masses must be 1 to {EXPECTED_MASSES_MAX} masses > 0 "
                f"and <= {BOX_MASS_MAX:g} kg, got {self.expected_masses!r}"
            )
        object.__setattr__(self, "expected_masses", tuple(float(m) for m in masses))
        if self.form not in FORMS:
            raise ValueError(f"ObjectiveSpec.form must be one of {FORMS}, got {self.form!r}")
        if not isinstance(self.gram, str) or self.gram not in GRAMS:
            raise ValueError(f"ObjectiveSpec.gram must be one of {GRAMS}, got {self.gram!r}")
        estimators = estimator_names()
        if self.estimator not in estimators:
            raise ValueError(
                f"ObjectiveSpec.estimator must be one of {estimators}, got {self.estimator!r}"
            )
        for name in ("window", "horizon"):
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, int)
                or not 2 <= value <= WINDOW_MAX
            ):
                raise ValueError(
                    f"ObjectiveSpec.{name} must be an int from 2 to {WINDOW_MAX}, got {value!r}"
                )
        _check_int(self, "scene_samples", 1, SCENE_SAMPLES_MAX)
        _check_int(self, "scene_seed", 0, 2**32 - 1)
        shift, turn = _check_vector(self, "scene_jitter", 2)
        if not (0 <= shift <= SCENE_SHIFT_MAX and 0 <= turn <= SCENE_TURN_MAX):
            raise ValueError(
                f"ObjectiveSpec.scene_jitter must be (position 0 to {SCENE_SHIFT_MAX:g} m, yaw 0 "
                f"to {SCENE_TURN_MAX:g} rad), got {self.scene_jitter!r}"
            )


def spec_to_dict(spec: Any) -> dict[str, Any]:
    """A spec as a plain JSON-ready dict (tuples become lists)."""
    out: dict[str, Any] = {}
    for f in fields(spec):
        value = getattr(spec, f.name)
        out[f.name] = list(value) if isinstance(value, tuple) else value
    return out
