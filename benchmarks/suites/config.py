"""Benchmark suites, declared: frozen configs written in Python, TOML or JSON.

A suite is a set of design runs (Algorithm 1) that share one task family and one budget: every
combination of a *variant* (a goal precision p^X, optionally named), an *optimizer* (a registry
name with its settings) and a *task* (a seed, and a goal when goals are drawn at random). The
runner (:mod:`benchmarks.suites.runner`) executes the runs into one run folder; the report
(:mod:`benchmarks.reports.suite`) turns the stored results into the suite's figures and tables.

Randomness is explicit and comes from ONE root seed: task ``i`` is child ``i`` of
``numpy.random.SeedSequence(root_seed).spawn(n_seeds)``. Its optimizer seed is the child's first
32-bit state word, and its random goal (if ``goal_box`` is set) is drawn from a generator on the
child's own first spawned child. Every variant and every optimizer sees the same tasks.

The built-in suites reproduce Section IV of the paper, each at two sizes (``smoke`` for CI,
``full`` for the paper's scale); :func:`builtin_suite` makes them. ``docs/benchmarks.md`` shows
how to write a suite file.

Example:
    >>> from benchmarks.suites import builtin_suite
    >>> suite = builtin_suite("optimizers", "smoke")
    >>> [o.name for o in suite.optimizers]
    ['cmaes', 'bo', 'pso', 'random']
    >>> len(suite.runs())
    8
"""

from __future__ import annotations

import dataclasses
import json
import math
import urllib.parse
from collections.abc import Mapping, Sequence
from typing import Any, cast

import numpy as np

from benchmarks.design import DesignConfig
from benchmarks.design.config import ADDED_FIELDS as DESIGN_ADDED_FIELDS
from benchmarks.design.config import HARNESS_SETTINGS, TaskConfig
from benchmarks.storage import with_added_fields
from optimizers import BATCH_SIZE_MAX
from tooldesign_env.env import WORKSPACE_HIGH, WORKSPACE_LOW
from tooldesign_env.specs import BOX_MASS_MAX, GOAL_PRECISION_MAX

ENV_IDS: tuple[str, ...] = ("ToolDesign-v0",)

"""Environment ids the evaluation workers can build (``benchmarks.execution`` makes this one)."""


FIGURES: dict[str, str] = {
    "tool-shapes": "tool shapes side by side with their box paths (needs keep_paths)",
    "robustness-table": "the paper's Table I per labelled variant (needs test_robustness)",
    "robustness-scatter": "robustness against squared goal error (needs test_robustness)",
    "mass-paths": "box paths under every box mass, per variant (needs test_robustness and "
    "keep_paths)",
}

"""Suite-specific reports a suite may ask for, and what each shows."""


RUNTIME_FIELDS: frozenset[str] = frozenset({"executor", "workers", "scheduler", "max_retries"})

"""Fields that do not change the results: a resumed suite may set them differently."""

#: Config fields a resumed suite may raise: the runs of the first seeds do not depend on how
#: many seeds there are, so a suite grows by the runs of the new seeds alone.
GROWABLE_FIELDS: frozenset[str] = frozenset({"n_seeds"})

#: Config fields added after suites were first stored, with the value older suites had: those of
#: a design run's config, added at the same times (``benchmarks.design.config.ADDED_FIELDS``).
ADDED_FIELDS: dict[str, Any] = dict(DESIGN_ADDED_FIELDS)


SUITE_KIND = "suite"

"""``manifest.json`` ``extra.kind`` of a suite run folder."""


N_SEEDS_MAX = 10_000

"""Most tasks a suite may have: ``SeedSequence.spawn`` and the run list grow with it."""


INT64_MAX = 2**63 - 1

"""Largest ``root_seed`` and ``iterations``: stored as int64, as ``DesignConfig``'s are."""


NAME_MAX = 200

"""Longest name (suite, variant, optimizer, label) once percent-encoded: it is a folder name."""


def _show(value: Any) -> str:
    """``repr(value)`` cut to one short line (a suite file may hold huge values)."""
    try:
        text = repr(value)
    except ValueError:  # an int of more digits than Python converts to text
        return f"an int of {value.bit_length()} bits"
    return text if len(text) <= 80 else text[:77] + "..."


def _kind(value: Any) -> str:
    return f"{type(value).__name__} {_show(value)}"


def _int(name: str, value: Any, minimum: int, maximum: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int from {minimum} to {maximum}, got {_kind(value)}")
    if not minimum <= value <= maximum:
        raise ValueError(f"{name} must be from {minimum} to {maximum}, got {_show(value)}")
    return int(value)


def _number(name: str, value: Any, low: float = -math.inf, high: float = math.inf) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"{name} must be a number, got {_kind(value)}")
    try:
        number = float(value)
    except OverflowError:  # an int beyond float64
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, got {_show(value)}")
    if not low <= number <= high:
        raise ValueError(f"{name} must be from {low:g} to {high:g}, got {_show(value)}")
    return number


def _name(name: str, value: Any, *, allow_empty: bool = False) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, got {_kind(value)}")
    if value != value.strip() or (not value and not allow_empty):
        raise ValueError(
            f"{name} must be a non-empty name without surrounding spaces: {_show(value)}"
        )
    encoded = len(urllib.parse.quote(value, safe=""))
    if encoded > NAME_MAX:
        raise ValueError(
            f"{name} names a folder of the run: it must be at most {NAME_MAX} characters once "
            f"percent-encoded, got {encoded}: {_show(value)}"
        )
    return value


def _sequence(name: str, value: Any) -> tuple[Any, ...]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TypeError(f"{name} must be a list, got {_kind(value)}")
    return tuple(value)


def _json_settings(name: str, value: Any) -> tuple[tuple[str, Any], ...]:
    if isinstance(value, Mapping):
        value = tuple(value.items())
    if isinstance(value, (str, bytes)):  # iterating "" gives no pairs: it would pass as empty
        raise TypeError(f"{name} must be a table of names to values, got {_kind(value)}")
    try:
        pairs = tuple(sorted((k, v) for k, v in value))
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a table of names to values, got {_kind(value)}") from None
    for key, item in pairs:
        if not isinstance(key, str) or not key.isidentifier():
            raise ValueError(f"{name} keys must be identifiers, got {_show(key)}")
        if not _json_value(item):
            raise TypeError(
                f"{name}[{key!r}] must be a JSON value (a finite number within float64, string, "
                f"bool, null, list or table of them), got {_kind(item)}"
            )
    return pairs


def _json_value(item: Any, depth: int = 0) -> bool:
    """Whether ``item`` is JSON that an optimizer can take: no NaN, no int beyond float64."""
    if depth > 20:  # settings are flat; a deeper nest is a mistake (and recursion is bounded)
        return False
    if item is None or isinstance(item, (bool, str)):
        return True
    if isinstance(item, (int, float)):
        try:
            return math.isfinite(item)  # an int beyond float64 raises OverflowError here
        except OverflowError:
            return False
    if isinstance(item, (list, tuple)):
        return all(_json_value(v, depth + 1) for v in item)
    if isinstance(item, dict):
        return all(isinstance(k, str) and _json_value(v, depth + 1) for k, v in item.items())
    return False


def _from_mapping(cls: type, data: Any, where: str) -> Any:
    """``cls(**data)`` with an error that names unknown keys instead of a bare TypeError."""
    if isinstance(data, cls):
        return data
    if not isinstance(data, Mapping):
        raise TypeError(f"{where} must be a table (mapping), got {_kind(data)}")
    fields = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(_show(key) for key in set(data) - fields)
    if unknown:
        raise ValueError(f"{where}: unknown keys [{', '.join(unknown)}]; allowed: {sorted(fields)}")
    required = [
        f.name
        for f in dataclasses.fields(cls)
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    missing = [name for name in required if name not in data]
    if missing:
        raise ValueError(f"{where}: missing keys {missing}; each {cls.__name__} needs them")
    return cls(**data)


# Where a suite sets each keyword of HARNESS_SETTINGS, which its runs give every optimizer.
_SUITE_FIELDS = {
    "seed": "each run's seed is one of the suite's n_seeds seeds",
    "batch_size": "the suite's batch_size is every optimizer's",
    "bounds": "every optimizer searches the suite's bounds",
}


@dataclasses.dataclass(frozen=True, kw_only=True)
class OptimizerSpec:
    """One optimizer of a suite.

    Attributes:
        name: Name in the :mod:`optimizers` registry (``cmaes``, ``bo``, ``pso``, ``random``,
            ``optuna-tpe``, ...) or a ``"module:Class"`` string.
        settings: Keyword arguments of the optimizer, JSON values (stored as sorted pairs); not
            ``seed``, ``batch_size``, ``bounds``, ``low`` or ``high``, which the suite sets.
        label: Name in the evaluation log's ``optimizer`` column; ``name`` if empty. Two specs
            of one optimizer with different settings need different labels.
    """

    name: str
    settings: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()
    label: str = ""

    def __post_init__(self) -> None:
        _name("optimizer name", self.name)
        settings = _json_settings(f"settings of {self.name}", self.settings)
        object.__setattr__(self, "settings", settings)
        for key, _ in settings:
            if key in HARNESS_SETTINGS:
                raise ValueError(
                    f"settings of {self.name} must not set {key!r}: "
                    f"{_SUITE_FIELDS[HARNESS_SETTINGS[key]]}"
                )
        _name("optimizer label", self.label, allow_empty=True)

    @property
    def column(self) -> str:
        """The ``optimizer`` column of its runs: ``label`` or ``name``."""
        return self.label or self.name


@dataclasses.dataclass(frozen=True, kw_only=True)
class Variant:
    """One setting of the objective under which every optimizer and task is run.

    Attributes:
        name: ``variant`` column of its runs ("" for a suite with one variant); short and
            path-friendly, e.g. ``"p20"``.
        goal_precision: p^X of this variant in 1/m^2, >= 0; the suite's if ``None``.
        label: What the paper calls it, e.g. ``"free energy"``; tables show it.
    """

    name: str = ""
    goal_precision: float | None = None
    label: str = ""

    def __post_init__(self) -> None:
        _name("variant name", self.name, allow_empty=True)
        if self.goal_precision is not None:
            value = _number(
                f"goal_precision (p^X, 1/m^2) of variant {self.name!r}",
                self.goal_precision,
                0.0,
                GOAL_PRECISION_MAX,
            )
            object.__setattr__(self, "goal_precision", value)
        if not isinstance(self.label, str):
            raise TypeError(
                f"label of variant {self.name!r} must be a string, got {_kind(self.label)}"
            )


@dataclasses.dataclass(frozen=True, kw_only=True)
class Task:
    """One task of a suite: what every variant and optimizer is run on.

    Attributes:
        index: Position i in ``SeedSequence(root_seed).spawn(n_seeds)``.
        seed: The optimizer seed, a 32-bit state word of child i.
        goal: X^g, (x, y, z) in m.
    """

    index: int
    seed: int
    goal: tuple[float, float, float]


@dataclasses.dataclass(frozen=True, kw_only=True)
class RunSpec:
    """One design run of a suite: a variant, an optimizer and a task.

    Attributes:
        suite: The suite name (``suite`` column).
        variant: The variant.
        optimizer: The optimizer.
        task: The task.
        design: The run as a :class:`~benchmarks.design.DesignConfig` (designer, budget, goal,
            p^X, executor).
    """

    suite: str
    variant: Variant
    optimizer: OptimizerSpec
    task: Task
    design: DesignConfig

    @property
    def key(self) -> tuple[str, str, str, int]:
        """``(suite, variant, optimizer column, seed)``: the run's key in the evaluation log."""
        return (self.suite, self.variant.name, self.optimizer.column, self.task.seed)


#: The order of a suite's fields in its JSON form and its suite files (the task fields, shared
#: with a design run through :class:`~benchmarks.design.config.TaskConfig`, sit among them).
_FILE_ORDER: tuple[str, ...] = (
    "name",
    "description",
    "env_id",
    "goal",
    "goal_box",
    "goal_precision",
    "box_mass",
    "estimator",
    "objective",
    "scene_samples",
    "bounds",
    "scene",
    "section_shape",
    "variants",
    "optimizers",
    "batch_size",
    "iterations",
    "root_seed",
    "n_seeds",
    "test_robustness",
    "robustness_masses",
    "keep_paths",
    "figures",
    "executor",
    "workers",
    "scheduler",
    "max_retries",
)


@dataclasses.dataclass(frozen=True, kw_only=True)
class SuiteConfig(TaskConfig):
    """A benchmark suite: the task family, the optimizers, the budget, the seeds, the executor.

    Runs: every (task, variant, optimizer), in that order, so that an interrupted suite has
    whole tasks for every optimizer first. The task fields (``goal``, ``goal_precision``,
    ``box_mass``, ``estimator``, ``objective``, ``scene_samples``, ``bounds``, ``scene``,
    ``section_shape``, ``robustness_masses``) are those of
    :class:`~benchmarks.design.config.TaskConfig`, shared with every run's
    :class:`~benchmarks.design.DesignConfig`; a variant may set its own ``goal_precision`` and
    ``goal_box`` draws each task's goal.

    Attributes:
        name: Suite name (the log's ``suite`` column), e.g. ``"optimizers"``.
        description: One line saying what the suite shows.
        env_id: The Gymnasium env the designs are scored with (see :data:`ENV_IDS`).
        goal: X^g, (x, y, z) in m, used when ``goal_box`` is ``None``; ``None`` (the default)
            is the task's default goal (push's (0, 1.5, 0.1)).
        goal_box: ``((x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi))`` in m: draw each task's goal
            uniformly in this box from the task's seed; ``None`` uses ``goal`` for every task.
        goal_precision: p^X in 1/m^2 of variants that do not set their own.
        box_mass: Nominal box mass in kg.
        estimator: ``"contact"``, ``"trajectory"`` or ``"resimulation"`` estimate of dX/dU.
        objective: ``"free-energy"`` (F) or ``"expected-goal-error"`` (the robust-design
            baseline: the goal error averaged over box masses, see ``ObjectiveSpec.kind``).
        scene_samples: K, the scenes each design's F is averaged over (1 to 64, see
            ``ObjectiveSpec.scene_samples``); K times the simulation.
        bounds: (n, 2) coefficient bounds; ``None`` is ``default_bounds(3)``.
        scene: Overrides of ``SceneSpec`` fields for every run (a mapping, a ``[scene]`` table
            in a suite file; stored as sorted pairs), e.g. ``{"box_position": [-0.4, 1.1]}``.
            Not ``box_mass`` (its own field). Empty (the default) is the default scene. The
            fields of ``RECORDED_SCENE_FIELDS`` are always stored (today's default where not
            set), so a folder keeps its scene when a default changes.
        section_shape: The tool's section, ``"round"`` (the default) or ``"square"`` (the
            paper's) (``ToolSpec.section_shape``). A suite file without the field, written
            before the field existed, reads as ``"square"``.
        variants: The variants, names unique.
        optimizers: The optimizers, log names (labels) unique.
        batch_size: Designs per iteration (the population size), the same for every optimizer.
        iterations: Iterations K of every run.
        root_seed: The one root seed of the tasks.
        n_seeds: Number of tasks (seeds; goals when ``goal_box`` is set).
        test_robustness: Test each run's design under ``robustness_masses``.
        robustness_masses: Altered box masses m_i in kg.
        keep_paths: Keep the box paths of each run's design (nominal mass, and every altered
            mass with ``test_robustness``) for the figures.
        figures: Suite-specific reports (keys of :data:`FIGURES`).
        executor: ``"serial"``, ``"process"`` or ``"dask"``.
        workers: Worker processes; ``None`` is the CPUs this process may use
            (:func:`benchmarks.execution.usable_cpus`, its affinity).
        scheduler: Address of a running Dask scheduler (with ``executor="dask"``).
        max_retries: With ``executor="process"``: further evaluations, each alone in a fresh
            pool, of a design whose worker process died while it was evaluated alone, before it
            is logged as ``"failed"``; an int from 0 to 100 (see ``DesignConfig.max_retries``).
        task_name: The registered task every run is scored on (``DesignConfig.task_name``):
            ``"push"`` (the default; then not written to the suite's JSON, so a push suite's
            manifest is as before the field existed) or another, e.g. ``"hook"``, whose goal
            range ``goal`` must lie in (the benchmark protocol's task axis uses it).
    """

    name: str
    description: str = ""
    env_id: str = "ToolDesign-v0"
    goal_box: Sequence[Sequence[float]] | None = None
    variants: Sequence[Variant] = (Variant(),)
    optimizers: Sequence[OptimizerSpec] = (OptimizerSpec(name="cmaes"),)
    batch_size: int = 8
    iterations: int = 15
    root_seed: int = 0
    n_seeds: int = 10
    test_robustness: bool = False
    keep_paths: bool = False
    figures: Sequence[str] = ()
    executor: str = "process"
    workers: int | None = None
    scheduler: str | None = None
    max_retries: int = 0
    task_name: str = "push"

    def __post_init__(self) -> None:
        _name("name", self.name)
        if not isinstance(self.description, str):
            raise TypeError("description must be a string")
        if self.env_id not in ENV_IDS:
            raise ValueError(
                f"env_id must be one of {list(ENV_IDS)} (the env the evaluation workers build), "
                f"got {self.env_id!r}"
            )
        self._check_task()
        object.__setattr__(self, "goal_box", self._checked_goal_box())
        variants = tuple(
            _from_mapping(Variant, v, f"variants[{i}]")
            for i, v in enumerate(_sequence("variants", self.variants))
        )
        optimizers = tuple(
            _from_mapping(OptimizerSpec, o, f"optimizers[{i}]")
            for i, o in enumerate(_sequence("optimizers", self.optimizers))
        )
        listed: tuple[tuple[str, tuple[Any, ...], list[str]], ...] = (
            ("variants", variants, [v.name for v in variants]),
            ("optimizers", optimizers, [o.column for o in optimizers]),
        )
        for what, items, names in listed:
            if not items:
                raise ValueError(f"{what} must hold at least one entry")
            if len(set(names)) != len(names):
                raise ValueError(f"{what} must have unique names (labels), got {names}")
        object.__setattr__(self, "variants", variants)
        object.__setattr__(self, "optimizers", optimizers)
        counts = (
            ("batch_size", 1, BATCH_SIZE_MAX),
            ("iterations", 1, INT64_MAX),
            ("root_seed", 0, INT64_MAX),
            ("n_seeds", 1, N_SEEDS_MAX),
        )
        for field, low, high in counts:
            object.__setattr__(self, field, _int(field, getattr(self, field), low, high))
        for flag in ("test_robustness", "keep_paths"):
            if not isinstance(getattr(self, flag), bool):
                raise TypeError(f"{flag} must be true or false, got {_kind(getattr(self, flag))}")
        figures = tuple(_sequence("figures", self.figures))
        for figure in figures:
            if not isinstance(figure, str) or figure not in FIGURES:
                raise ValueError(
                    f"figures: unknown figure {_show(figure)}; allowed: {sorted(FIGURES)}"
                )
        needs = {
            "tool-shapes": ("keep_paths",),
            "robustness-table": ("test_robustness",),
            "robustness-scatter": ("test_robustness",),
            "mass-paths": ("test_robustness", "keep_paths"),
        }
        for figure in figures:
            missing = [flag for flag in needs[figure] if not getattr(self, flag)]
            if missing:
                raise ValueError(f"figure {figure!r} needs {' and '.join(missing)} = true")
        object.__setattr__(self, "figures", figures)
        # One DesignConfig per variant checks the rest (bounds, executor, workers, scheduler,
        # estimator) with the messages the design command gives; the bounds come back as tuples.
        for variant in variants:
            design = self._design(variant, OptimizerSpec(name="random"), 0, self.goal)
        object.__setattr__(self, "workers", design.workers)
        object.__setattr__(self, "max_retries", design.max_retries)

    def _checked_masses(self, value: Any) -> tuple[float, ...]:
        # A suite file's own wording (kg, the limit), then the design run's check.
        masses = tuple(
            _number("robustness_masses (kg)", m, 0.0, BOX_MASS_MAX)
            for m in _sequence("robustness_masses", value)
        )
        if not masses or min(masses) <= 0:
            raise ValueError(f"robustness_masses must be one or more masses > 0 kg, got {masses}")
        return tuple(super()._checked_masses(masses))

    def _checked_goal_box(self) -> tuple[tuple[float, float], ...] | None:
        if self.goal_box is None:
            return None
        rows = _sequence("goal_box", self.goal_box)
        if len(rows) != 3:
            raise ValueError(f"goal_box must be 3 [low, high] pairs (x, y, z) in m, got {rows}")
        box = []
        for axis, row, low, high in zip("xyz", rows, WORKSPACE_LOW, WORKSPACE_HIGH, strict=True):
            # Every goal drawn must be one the env accepts: inside its workspace.
            pair = tuple(
                _number(f"goal_box {axis} (m, in the workspace)", v, low, high)
                for v in _sequence(f"goal_box {axis}", row)
            )
            if len(pair) != 2 or pair[0] > pair[1]:
                raise ValueError(f"goal_box {axis} must be [low, high] with low <= high: {pair}")
            box.append(pair)
        return tuple(box)

    def _design(
        self, variant: Variant, optimizer: OptimizerSpec, seed: int, goal: Sequence[float]
    ) -> DesignConfig:
        precision = (
            self.goal_precision if variant.goal_precision is None else variant.goal_precision
        )
        task = {**self.task_fields(), "goal": tuple(goal), "goal_precision": precision}
        return DesignConfig(
            optimizer=optimizer.name,
            optimizer_settings=optimizer.settings,
            seed=seed,
            iterations=self.iterations,
            batch_size=self.batch_size,
            workers=self.workers,
            executor=self.executor,
            scheduler=self.scheduler,
            max_retries=self.max_retries,
            task_name=self.task_name,
            **task,
        )

    # derived plans

    def seeds(self) -> tuple[int, ...]:
        """The optimizer seed of each task, from ``SeedSequence(root_seed).spawn(n_seeds)``."""
        children = np.random.SeedSequence(self.root_seed).spawn(self.n_seeds)
        return tuple(int(child.generate_state(1, dtype=np.uint32)[0]) for child in children)

    def tasks(self) -> tuple[Task, ...]:
        """The tasks every variant and optimizer runs: seed and goal of each."""
        children = np.random.SeedSequence(self.root_seed).spawn(self.n_seeds)
        tasks = []
        for index, (child, seed) in enumerate(zip(children, self.seeds(), strict=True)):
            goal = self.goal
            if self.goal_box is not None:
                # A stream of its own (the child's first child), apart from the optimizer seed.
                rng = np.random.default_rng(child.spawn(1)[0])
                low, high = np.asarray(self.goal_box, dtype=np.float64).T
                goal = tuple(float(v) for v in rng.uniform(low, high))
            tasks.append(Task(index=index, seed=seed, goal=tuple(goal)))  # type: ignore[arg-type]
        return tuple(tasks)

    def runs(self) -> tuple[RunSpec, ...]:
        """Every design run, task by task, then variant, then optimizer."""
        runs = []
        for task in self.tasks():
            for variant in self.variants:
                for optimizer in self.optimizers:
                    runs.append(
                        RunSpec(
                            suite=self.name,
                            variant=variant,
                            optimizer=optimizer,
                            task=task,
                            design=self._design(variant, optimizer, task.seed, task.goal),
                        )
                    )
        return tuple(runs)

    def evaluations(self) -> int:
        """Planned evaluations of the design runs (final tests not counted)."""
        runs = self.n_seeds * len(self.variants) * len(self.optimizers)
        return runs * self.iterations * self.batch_size

    # conversions

    def to_json(self) -> dict[str, Any]:
        """The suite as JSON values: what :func:`suite_from_json` and suite files accept."""
        data = dataclasses.asdict(self)
        data = {name: data[name] for name in _FILE_ORDER}
        data["optimizers"] = [
            {**dataclasses.asdict(o), "settings": dict(o.settings)} for o in self.optimizers
        ]
        data["scene"] = dict(self.scene)
        if self.task_name != "push":
            data["task_name"] = self.task_name
        return cast("dict[str, Any]", json.loads(json.dumps(data, allow_nan=False)))

    def replace(self, **changes: Any) -> SuiteConfig:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)


def suite_from_json(data: Mapping[str, Any], *, where: str = "suite") -> SuiteConfig:
    """Make a :class:`SuiteConfig` from JSON values (``SuiteConfig.to_json`` or a suite file).

    Args:
        data: The fields; ``variants`` and ``optimizers`` as lists of tables.
        where: What ``data`` is, for error messages (e.g. the file path).

    Returns:
        The validated suite.

    Raises:
        TypeError, ValueError: If a key is unknown or a value is invalid; the message names it.
    """
    try:
        if not isinstance(data, Mapping):
            raise TypeError(f"must be a table (mapping), got {type(data).__name__}")
        fields = dict(data)
        for key, cls in (("variants", Variant), ("optimizers", OptimizerSpec)):
            if key in fields:
                items = _sequence(key, fields[key])
                fields[key] = tuple(
                    _from_mapping(cls, item, f"{key}[{i}]") for i, item in enumerate(items)
                )
        return _from_mapping(SuiteConfig, fields, where)  # type: ignore[no-any-return]
    except (TypeError, ValueError) as err:
        message = str(err)
        raise type(err)(message if message.startswith(where) else f"{where}: {message}") from None


def suite_of_manifest(manifest: Mapping[str, Any]) -> SuiteConfig:
    """The :class:`SuiteConfig` recorded in a suite run folder's manifest.

    A field the run predates takes the value every run made before it had
    (:data:`ADDED_FIELDS`), not today's default: a folder written before ``section_shape``
    existed ran with the square section, whatever the default is now.

    Raises:
        ValueError: If the manifest is not one of a suite run folder.
    """
    if manifest.get("extra", {}).get("kind") != SUITE_KIND or "config" not in manifest:
        raise ValueError("manifest.json is not the manifest of a suite run folder")
    config = manifest["config"]
    if isinstance(config, Mapping):
        config = with_added_fields(config, ADDED_FIELDS)
    return suite_from_json(config, where="manifest.json config")
