"""What a design run is: the designer (optimizer, seed, budget), the executor and the task.

:class:`DesignConfig` is frozen and validated on construction; its :meth:`DesignConfig.to_json`
form is what a run folder's manifest records and what a resumed run is compared with.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping, Sequence
from typing import Any, cast

import numpy as np

from benchmarks.execution import (
    EXECUTORS,
    WORKERS_MAX,
    RobustnessRequest,
    TaskSettings,
    check_max_retries,
)
from tooldesign_env.schema import (
    DEFAULT_BOX_MASS,
    DEFAULT_GOAL_PRECISION,
    ROBUSTNESS_MASSES,
)
from tooldesign_env.specs import SCENE_SAMPLES_MAX, SceneSpec

DESIGN_SUITE = "design"

"""Suite name of a design run in its evaluation log."""


#: Fields that do not change the results, so a resumed run may set them differently.
RUNTIME_FIELDS = frozenset({"iterations", "workers", "executor", "scheduler", "max_retries"})

#: Config fields added after runs were first stored, with the value older runs had: a run
#: folder whose manifest lacks one is resumed as if it held that value. A table adds its keys to
#: the stored table of that name (``benchmarks.storage.with_added_fields``): a ``scene`` stored
#: before the hand was merged by default ran with the 13-link arm.
ADDED_FIELDS: dict[str, Any] = {
    "scene_samples": 1,
    "scene": {"merge_fixed_links": False},
    "section_shape": "square",
}

#: ``SceneSpec`` fields whose default has changed since configs were first stored. A config
#: always records them in ``scene`` (today's default where the user set none), so that a run
#: folder keeps the scene it ran with whatever the default becomes.
RECORDED_SCENE_FIELDS: tuple[str, ...] = ("merge_fixed_links",)

#: SceneSpec fields a config may not override in ``scene``: they have a field of their own.
_SCENE_OWN_FIELDS = {"box_mass": "box_mass"}


def check_section_shape(value: Any) -> str:
    """``value`` if it is one of ``tooldesign_env.geometry.SECTION_SHAPES``, else a ValueError."""
    from tooldesign_env.geometry import SECTION_SHAPES

    if not isinstance(value, str) or value not in SECTION_SHAPES:
        raise ValueError(f"section_shape must be one of {SECTION_SHAPES}, got {value!r}")
    return value


def _int(name: str, value: Any, minimum: int, maximum: int = 2**63 - 1) -> int:
    # The maximum is int64's: seeds and counts are stored in Parquet and SQLite columns.
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if value > maximum:
        why = " (int64)" if maximum == 2**63 - 1 else ""
        raise ValueError(f"{name} must be <= {maximum}{why}, got {value}")
    return int(value)


#: Keywords the harness gives every optimizer itself (:mod:`benchmarks.design.stepper`), with
#: the field that sets each: a setting of the same name would reach ``optimizers.make`` twice
#: ("got multiple values for keyword argument"). ``low`` and ``high`` are the other spelling of
#: ``bounds``, which the optimizers refuse next to it.
HARNESS_SETTINGS = {
    "seed": "seed",
    "batch_size": "batch_size",
    "bounds": "bounds",
    "low": "bounds",
    "high": "bounds",
}


def _settings(value: Any) -> tuple[tuple[str, Any], ...]:
    if isinstance(value, Mapping):
        value = tuple(value.items())
    if isinstance(value, (str, bytes)):  # iterating "" gives no pairs: it would pass as empty
        raise TypeError(f"optimizer_settings must be a mapping of names to values, got {value!r}")
    try:
        pairs = tuple(sorted((k, v) for k, v in value))
    except (TypeError, ValueError):
        raise TypeError(
            f"optimizer_settings must be a mapping of names to values, got {value!r}"
        ) from None
    for key, item in pairs:
        if not isinstance(key, str) or not key.isidentifier():
            raise ValueError(f"optimizer_settings keys must be identifiers, got {key!r}")
        if key in HARNESS_SETTINGS:
            raise ValueError(
                f"optimizer_settings must not set {key!r}: the run gives the optimizer its "
                f"{HARNESS_SETTINGS[key]} (DesignConfig.{HARNESS_SETTINGS[key]}); set that instead"
            )
        try:
            json.dumps(item, allow_nan=False)
        except (TypeError, ValueError):
            raise TypeError(
                f"optimizer_settings[{key!r}] must be a JSON value (number, string, bool, list, "
                f"null) so the run folder can record it, got {item!r}"
            ) from None
    return pairs


def _frozen(value: Any) -> Any:
    """A JSON value with its lists as tuples: hashable, and what the frozen specs hold."""
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return value


def scene_overrides(value: Any) -> tuple[tuple[str, Any], ...]:
    """Check a mapping of ``SceneSpec`` field overrides; return it as sorted (name, value) pairs.

    The overrides are checked by building the ``SceneSpec`` they make, so a value is refused
    with the message the spec gives (it names the field and what it accepts). Lists become
    tuples, as the spec's fields are.

    Args:
        value: ``{"box_position": [x, y], ...}`` (JSON values), or (name, value) pairs.

    Returns:
        The overrides as sorted pairs; ``()`` for none.

    Raises:
        TypeError: Not a mapping, a key that is not a string, or a value of the wrong type.
        ValueError: An unknown field, ``box_mass`` (a field of its own), or a value the spec
            refuses.
    """
    if isinstance(value, Mapping):
        value = tuple(value.items())
    if isinstance(value, (str, bytes)):
        raise TypeError(f"scene must be a mapping of SceneSpec fields to values, got {value!r}")
    try:
        pairs = tuple(sorted((k, _frozen(v)) for k, v in value))
    except (TypeError, ValueError):
        raise TypeError(
            f"scene must be a mapping of SceneSpec fields to values, got {value!r}"
        ) from None
    allowed = sorted(
        f.name for f in dataclasses.fields(SceneSpec) if f.name not in _SCENE_OWN_FIELDS
    )
    for key, item in pairs:
        if not isinstance(key, str):
            raise TypeError(f"scene keys must be SceneSpec field names, got {key!r}")
        if key in _SCENE_OWN_FIELDS:
            raise ValueError(
                f"scene must not set {key!r}: it is the config's own field "
                f"{_SCENE_OWN_FIELDS[key]!r}; allowed in scene: {allowed}"
            )
        if key not in allowed:
            raise ValueError(f"scene: unknown SceneSpec field {key!r}; allowed: {allowed}")
        try:
            json.dumps(item, allow_nan=False)
        except (TypeError, ValueError) as err:
            # NaN and inf are values of the right type but not JSON: a ValueError.
            raise type(err)(
                f"scene[{key!r}] must be a finite JSON value (number, bool, list of numbers) so "
                f"the run folder can record it, got {item!r}"
            ) from None
    try:
        SceneSpec(**dict(pairs))
    except (TypeError, ValueError) as err:
        raise type(err)(f"scene: {err}") from None
    return pairs


def recorded_scene(value: Any) -> tuple[tuple[str, Any], ...]:
    """The form of ``scene`` a config stores: checked, with every recorded field present.

    :func:`scene_overrides` of ``value``, with each of :data:`RECORDED_SCENE_FIELDS` it lacks set
    to today's default.
    """
    pairs = dict(scene_overrides(value))
    default = SceneSpec()
    for name in RECORDED_SCENE_FIELDS:
        pairs.setdefault(name, getattr(default, name))
    return tuple(sorted(pairs.items()))


def scene_spec(overrides: Any) -> SceneSpec | None:
    """The ``SceneSpec`` that ``overrides`` (see :func:`scene_overrides`) make, or ``None``.

    ``None`` when they make the default scene: the env then builds its own, so a config that
    changes nothing gives bit for bit the results it gave before the field existed.
    """
    spec = SceneSpec(**dict(scene_overrides(overrides)))
    return None if spec == SceneSpec() else spec


def _bounds(value: Any) -> tuple[tuple[float, float], ...]:
    if value is None:
        from tooldesign_env import default_bounds

        value = default_bounds(3)
    from optimizers import check_bounds
    from tooldesign_env.env import COEFFICIENT_MAX
    from tooldesign_env.geometry.tool import DEGREE_MAX

    # The optimizers' check refuses bools, strings, ragged rows and overflowing ints by name.
    low, high = check_bounds(value)
    if len(low) > DEGREE_MAX:
        raise ValueError(
            f"bounds must have at most {DEGREE_MAX} rows (one per coefficient: a polynomial of "
            f"degree <= {DEGREE_MAX}), got {len(low)}"
        )
    array = np.stack([low, high], axis=1)
    if np.any(np.abs(array) > COEFFICIENT_MAX):
        raise ValueError(
            f"bounds must lie within +-{COEFFICIENT_MAX:g} (coefficients of a 1.1 m tool), "
            f"got {array.tolist()}"
        )
    return tuple((float(lo), float(hi)) for lo, hi in array.tolist())


@dataclasses.dataclass(frozen=True, kw_only=True)
class TaskConfig:
    """The task every design of a run is scored on: what a design run and a suite share.

    :class:`DesignConfig` and :class:`~benchmarks.suites.SuiteConfig` are made of it (plus the
    designer, the budget and the executor), so each task field is declared, defaulted, checked
    and documented once, here; a suite file, a design run's flags and both configs' JSON keep
    the flat field names below.

    Attributes:
        goal: X^g, (x, y, z) in m (a suite with ``goal_box`` draws one per task instead);
            ``None`` (the default) is the task's default goal (``TaskDefinition.goal``: the
            paper's (0, 1.5, 0.1) for push), stored as that goal.
        goal_precision: p^X in 1/m^2, >= 0 (the paper's Figure 3 uses 40, its comparisons 20).
        box_mass: Box mass in kg (the paper's 0.1).
        estimator: ``"contact"``, ``"trajectory"`` or ``"resimulation"`` estimate of dX/dU.
        objective: ``"free-energy"`` (F) or ``"expected-goal-error"`` (the robust-design
            baseline, see ``ObjectiveSpec.kind``).
        scene_samples: K, the scenes each design's F is averaged over (1 to 64; see
            ``ObjectiveSpec.scene_samples``): K times the simulation, a smoother objective.
        bounds: (n, 2) coefficient bounds [low, high]; ``None`` is ``default_bounds(3)``
            (c1, c2 in [-1.5, 1.5], c3 in [-0.5, 0.5]). n is the polynomial degree.
        scene: Overrides of ``SceneSpec`` fields (a mapping; stored as sorted pairs, lists as
            tuples), JSON values, e.g. ``{"box_position": [-0.4, 1.1]}`` to move the box. Not
            ``box_mass`` (its own field). Empty (the default) is the default scene. The fields
            of :data:`RECORDED_SCENE_FIELDS` are always stored (today's default where not set),
            so a run folder keeps its scene when a default changes.
        robustness_masses: Altered box masses m_i in kg of the final tool's robustness test.
        section_shape: The tool's section, ``"round"`` (the default: far less chaotic contact,
            see docs/model.md) or ``"square"`` (the paper's) (``ToolSpec.section_shape``). A
            config file without the field, written before the field existed, reads as
            ``"square"``.
    """

    # None, the default, becomes the task's default goal on construction: a config always holds
    # three floats, so the field is typed as what it holds (DesignConfig(goal=None) is allowed).
    goal: Sequence[float] = None  # type: ignore[assignment]
    goal_precision: float = DEFAULT_GOAL_PRECISION
    box_mass: float = DEFAULT_BOX_MASS
    estimator: str = "contact"
    objective: str = "free-energy"
    scene_samples: int = 1
    bounds: Sequence[Sequence[float]] | np.ndarray | None = None
    scene: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()
    robustness_masses: Sequence[float] = ROBUSTNESS_MASSES
    section_shape: str = "round"

    def __post_init__(self) -> None:
        self._check_task()

    def _check_task(self) -> None:
        """Check the task fields and store them in their canonical form (tuples, floats)."""
        object.__setattr__(
            self, "scene_samples", _int("scene_samples", self.scene_samples, 1, SCENE_SAMPLES_MAX)
        )
        goal = self.goal
        if goal is None:
            # The task's own default goal: a hook run without a goal must not be refused for
            # push's (0, 1.5, 0.1), a goal the user never gave. Push's is DEFAULT_GOAL to the
            # bit, so a push config stores what it always did. A plain TaskConfig is push's.
            from tooldesign_env.tasks import get_task

            goal = get_task(getattr(self, "task_name", "push")).goal
        # TaskSettings checks goal, precision, mass and estimator and says what is wrong.
        task = TaskSettings(
            goal=goal,
            goal_precision=self.goal_precision,
            box_mass=self.box_mass,
            estimator=self.estimator,
            objective=self.objective,
        )
        object.__setattr__(self, "goal", task.goal)
        object.__setattr__(self, "goal_precision", task.goal_precision)
        object.__setattr__(self, "box_mass", task.box_mass)
        object.__setattr__(self, "bounds", _bounds(self.bounds))
        object.__setattr__(self, "scene", recorded_scene(self.scene))
        object.__setattr__(self, "robustness_masses", self._checked_masses(self.robustness_masses))
        object.__setattr__(self, "section_shape", check_section_shape(self.section_shape))

    def _checked_masses(self, value: Any) -> Sequence[float]:
        try:
            return RobustnessRequest(coeffs=(0.0,), masses=value).masses
        except (TypeError, ValueError) as error:
            raise type(error)(f"robustness_masses: {error}") from None

    @property
    def degree(self) -> int:
        """Polynomial degree n: the number of coefficients."""
        return len(self.bounds or ())

    def tool_spec(self) -> Any:
        """The ``tooldesign_env.ToolSpec`` of the run: the paper's tool, degree n, its section."""
        from tooldesign_env import ToolSpec

        return ToolSpec(degree=self.degree, section_shape=self.section_shape)

    def task_fields(self) -> dict[str, Any]:
        """The task fields by name, as stored (to make another config of the same task)."""
        return {name: getattr(self, name) for name in TASK_FIELDS}


#: The fields of :class:`TaskConfig`, in their order.
TASK_FIELDS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(TaskConfig))


@dataclasses.dataclass(frozen=True, kw_only=True)
class DesignConfig(TaskConfig):
    """What a design run does: the designer, its budget, where it runs, and the task.

    The task fields are those of :class:`TaskConfig`, which a suite shares.

    Attributes:
        optimizer: Name in the :mod:`optimizers` registry (``cmaes``, ``bo``, ``pso``,
            ``random``) or a ``"module:Class"`` string.
        optimizer_settings: Keyword arguments of the optimizer (a mapping; stored as sorted
            pairs), JSON values only; not ``seed``, ``batch_size``, ``bounds``, ``low`` or
            ``high``, which the run gives it from its own fields (:data:`HARNESS_SETTINGS`).
        seed: Seed of the optimizer, >= 0; the simulation has no randomness.
        iterations: K, iterations of ask/evaluate/tell, >= 1.
        batch_size: Designs asked per iteration (the population size), 1 to 10,000.
        workers: Worker processes, 1 to 1024; ``None`` is the CPUs this process may use
            (:func:`benchmarks.execution.usable_cpus`, its affinity).
        executor: ``"serial"``, ``"process"`` or ``"dask"``.
        scheduler: Address of a Dask scheduler (with ``executor="dask"``); a LocalCluster if
            ``None``.
        max_retries: With ``executor="process"``: how many more times a design whose worker
            process died while it was evaluated alone is evaluated again, alone in a fresh pool,
            before it is logged as ``"failed"``; an int from 0 to 100 (default 0: the simulation
            is deterministic). A design whose worker died in a shared pool is always evaluated
            once more alone first, so the others' designs are not failed with it.
        goal, goal_precision, box_mass, estimator, objective, scene_samples, bounds, scene,
            robustness_masses, section_shape: The task (see :class:`TaskConfig`).
        task_name: The task (``tooldesign_env.tasks.get_task``, docs/tasks.md): ``"push"`` (the
            paper's, the default), another registered name, e.g. ``"hook"``, a
            ``"module:ATTR"`` naming a ``TaskDefinition``, or an installed package's task (entry
            point group ``tooldesign.tasks``). It supplies the scene (which ``scene`` overrides
            field by field), the plan, the obstacles, the goal range, which ``goal`` must lie
            in, and the default goal. The workers are sent the definition itself, so a task
            registered in a function or a notebook runs in the process pool too.
    """

    optimizer: str = "cmaes"
    optimizer_settings: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()
    seed: int = 0
    iterations: int = 15
    batch_size: int = 8
    workers: int | None = None
    executor: str = "process"
    scheduler: str | None = None
    max_retries: int = 0
    task_name: str = "push"

    def __post_init__(self) -> None:
        from tooldesign_env.tasks import get_task

        definition = get_task(self.task_name)  # an unknown name: the error lists the known ones
        if not isinstance(self.optimizer, str) or not self.optimizer.strip():
            raise ValueError(f"optimizer must be a non-empty name, got {self.optimizer!r}")
        object.__setattr__(self, "optimizer_settings", _settings(self.optimizer_settings))
        object.__setattr__(self, "seed", _int("seed", self.seed, 0))
        object.__setattr__(self, "iterations", _int("iterations", self.iterations, 1))
        from optimizers import BATCH_SIZE_MAX

        # The optimizers refuse a larger batch too, but only once the run has started.
        batch_size = _int("batch_size", self.batch_size, 1, BATCH_SIZE_MAX)
        object.__setattr__(self, "batch_size", batch_size)
        if self.workers is not None:
            object.__setattr__(self, "workers", _int("workers", self.workers, 1, WORKERS_MAX))
        if self.executor not in EXECUTORS:
            raise ValueError(f"executor must be one of {EXECUTORS}, got {self.executor!r}")
        if self.scheduler is not None:
            if not isinstance(self.scheduler, str) or not self.scheduler:
                raise ValueError(f"scheduler must be an address, got {self.scheduler!r}")
            if self.executor != "dask":
                raise ValueError(
                    f"scheduler is a Dask scheduler address; it needs executor='dask', "
                    f"got executor={self.executor!r}"
                )
        object.__setattr__(self, "max_retries", check_max_retries(self.max_retries))
        self._check_task()
        definition.check_goal(self.goal, "goal")
        definition.check_scene(self.task_scene())

    def task_scene(self) -> SceneSpec:
        """The scene of the run: the task's, with the ``scene`` overrides applied."""
        from tooldesign_env.tasks import get_task

        return dataclasses.replace(get_task(self.task_name).scene, **dict(self.scene))

    def task(self) -> TaskSettings:
        """The task and env settings every design of the run is scored with."""
        from tooldesign_env import ToolSpec, default_bounds

        extra: dict[str, Any] = {}
        if self.tool_spec() != ToolSpec():
            extra["tool"] = self.tool_spec()
        if self.bounds != _bounds(default_bounds(self.degree)):
            extra["bounds"] = self.bounds
        if self.scene_samples != 1:
            extra["scene_samples"] = self.scene_samples
        if self.task_name == "push":
            scene = scene_spec(self.scene)
        else:
            from tooldesign_env.tasks import get_task

            definition = get_task(self.task_name)
            # The definition itself, not its name: the workers (forkserver processes, Dask)
            # do not have this process's registry, so a task registered in a function, a
            # notebook or under the main guard would be unknown there. It is frozen and pickles;
            # the config keeps the name (its JSON and the run folder's manifest do not change).
            extra["task"] = definition
            scene = self.task_scene()
            # The task's own scene is not stored (the env builds it): read the scene of a run
            # with TaskSettings.task_scene(), never env_kwargs' "scene" or SceneSpec().
            scene = None if scene == definition.scene else scene
        if scene is not None:
            extra["scene"] = scene
        return TaskSettings(
            goal=self.goal,
            goal_precision=self.goal_precision,
            box_mass=self.box_mass,
            estimator=self.estimator,
            objective=self.objective,
            env_kwargs=extra,
        )

    def to_json(self) -> dict[str, Any]:
        """The configuration as JSON values (settings as an object, tuples as lists).

        The designer's fields come first, then the task's, as before the task fields were
        shared.
        """
        data = dataclasses.asdict(self)
        task = {name: data.pop(name) for name in TASK_FIELDS}
        data.update(task)
        data["optimizer_settings"] = dict(self.optimizer_settings)
        data["scene"] = dict(self.scene)
        if data["task_name"] == "push":
            # A push run's config stays what it was before tasks existed: older run folders
            # resume and compare as they did, and a config without the field is the push task.
            del data["task_name"]
        return cast("dict[str, Any]", json.loads(json.dumps(data, allow_nan=False)))
