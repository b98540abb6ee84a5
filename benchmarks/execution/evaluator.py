"""The evaluator: what a worker does with one design, and the batches of Algorithm 1.

:func:`evaluate_design` is the picklable worker function. Each worker keeps one
``ToolDesign-v0`` env per set of env settings (module-level cache), so the plan's inverse
kinematics and the PyBullet client are made once per process, not once per design. Rollouts are
deterministic and do not depend on what the env simulated before, so every executor gives the
same rows apart from ``eval_time``.

Failures never end a run: an exception inside the worker becomes a row with status
``"failed"``; a design whose worker process dies (``BrokenProcessPool``) is run again alone in
a fresh pool, retried up to the pool's ``max_retries`` times if its worker dies again, and then
is ``"failed"`` too (message "worker process died: WorkerDied: ...").

Example:
    >>> task = TaskSettings(goal=(0.0, 1.5, 0.1), goal_precision=20.0)  # doctest: +SKIP
    >>> with make_executor("process", workers=2) as executor:  # doctest: +SKIP
    ...     rows = evaluate_batch(executor, [(0.0, 0.0, 0.0), (1.0, -1.0, 0.3)], task)
"""

from __future__ import annotations

import math
import threading
import time
import traceback
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from benchmarks.execution.executors import map_robust
from tooldesign_env.schema import (
    DEFAULT_BOX_MASS,
    DEFAULT_GOAL,
    DEFAULT_GOAL_PRECISION,
    METRICS,
    ROBUSTNESS_MASSES,
    ROBUSTNESS_METRICS,
    STANDING_COLUMNS,
    rounded_path,
)

if TYPE_CHECKING:
    from tooldesign_env.specs import SceneSpec

#: The built-in estimators and objectives, as the command line offers them (it reads these names
#: without importing the env); TaskSettings takes any registered name.
_ESTIMATORS: tuple[str, ...] = ("contact", "trajectory", "resimulation")


OBJECTIVES: tuple[str, ...] = ("free-energy", "expected-goal-error")


def _finite(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    try:
        number = float(value)
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return number


def _default_goal(env_kwargs: Any) -> tuple[float, float, float]:
    """The default goal of ``env_kwargs``' ``task``: push's (DEFAULT_GOAL) without one.

    Malformed ``env_kwargs`` give push's; TaskSettings then refuses them in their own words.
    """
    try:
        task = dict(env_kwargs).get("task")
    except (TypeError, ValueError):
        task = None
    if task is None:
        return DEFAULT_GOAL
    from tooldesign_env.tasks import get_task

    return get_task(task).goal


@dataclass(frozen=True, kw_only=True)
class TaskSettings:
    """The task a design is scored on, and the env settings it is scored with.

    Attributes:
        goal: Goal position X^g, (x, y, z) in m, in the env's workspace (x, y in [-2.5, 2.5],
            z in [0, 1]); stored as a tuple of floats. ``None`` (the default) is the default
            goal of ``env_kwargs``' ``task`` (push's (0, 1.5, 0.1) without one).
        goal_precision: p^X, weight of the squared goal error in F, 1/m^2, >= 0.
        box_mass: Mass of the box in kg, > 0.
        estimator: How dX/dU is estimated: ``"contact"``, ``"trajectory"`` or
            ``"resimulation"`` (see ``ObjectiveSpec.estimator``).
        objective: What is minimized: ``"free-energy"`` (F) or ``"expected-goal-error"`` (the
            robust-design baseline; see ``ObjectiveSpec.kind``).
        env_kwargs: Further keyword arguments of ``gym.make("ToolDesign-v0", ...)`` (e.g.
            ``plan=PlanSpec(...)``) as sorted ``(name, value)`` pairs; values must be hashable
            and picklable (the frozen specs are). A mapping is accepted and sorted.
    """

    # None, the default, becomes the task's default goal on construction: the settings always
    # hold three floats, so the field is typed as what it holds.
    goal: Sequence[float] = None  # type: ignore[assignment]
    goal_precision: float = DEFAULT_GOAL_PRECISION
    box_mass: float = DEFAULT_BOX_MASS
    estimator: str = "contact"
    objective: str = "free-energy"
    env_kwargs: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()

    def __post_init__(self) -> None:
        goal = self.goal
        if goal is None:
            goal = _default_goal(self.env_kwargs)
        if isinstance(goal, (str, bytes)) or not isinstance(goal, (Sequence, np.ndarray)):
            raise TypeError(f"goal must be 3 numbers (x, y, z) in m, got {goal!r}")
        if len(goal) != 3:
            raise ValueError(f"goal must be 3 numbers (x, y, z) in m, got {len(goal)}")
        object.__setattr__(self, "goal", tuple(_finite("goal", v) for v in goal))
        from tooldesign_env.env import WORKSPACE_HIGH, WORKSPACE_LOW
        from tooldesign_env.specs import BOX_MASS_MAX, GOAL_PRECISION_MAX

        # The env refuses a goal outside its workspace at every reset: refuse it here, once.
        inside = zip(self.goal, WORKSPACE_LOW, WORKSPACE_HIGH, strict=True)
        if not all(lo <= v <= hi for v, lo, hi in inside):
            raise ValueError(
                f"goal {list(self.goal)} is outside the workspace: x, y in "
                f"[{WORKSPACE_LOW[0]:g}, {WORKSPACE_HIGH[0]:g}] m, z in "
                f"[{WORKSPACE_LOW[2]:g}, {WORKSPACE_HIGH[2]:g}] m"
            )

        precision = _finite("goal_precision", self.goal_precision)
        if not 0 <= precision <= GOAL_PRECISION_MAX:
            raise ValueError(
                f"goal_precision (p^X) must be in [0, {GOAL_PRECISION_MAX:g}] 1/m^2, "
                f"got {precision}"
            )
        object.__setattr__(self, "goal_precision", precision)
        mass = _finite("box_mass", self.box_mass)
        if not 0 < mass <= BOX_MASS_MAX:
            raise ValueError(f"box_mass must be > 0 and <= {BOX_MASS_MAX:g} kg, got {mass}")
        object.__setattr__(self, "box_mass", mass)
        # The registries (tooldesign_env/objective/registry.py), so that an estimator or
        # objective registered in this process is taken as the env takes it.
        from tooldesign_env.objective.registry import estimator_names, objective_names

        if self.estimator not in estimator_names():
            raise ValueError(
                f"estimator must be one of {estimator_names()}, got {self.estimator!r}"
            )
        if self.objective not in objective_names():
            raise ValueError(
                f"objective must be one of {objective_names()}, got {self.objective!r}"
            )
        extra = self.env_kwargs
        if isinstance(extra, Mapping):
            extra = tuple(extra.items())
        try:
            pairs = tuple(sorted((str(k), v) for k, v in extra))
        except (TypeError, ValueError):
            raise TypeError(
                f"env_kwargs must be a mapping or (name, value) pairs, got {extra!r}"
            ) from None
        clash = {k for k, _ in pairs} & {
            "goal",
            "goal_precision",
            "box_mass",
            "estimator",
            "objective_kind",
        }
        if clash:
            raise ValueError(f"env_kwargs must not repeat the task fields {sorted(clash)}")
        try:
            hash(pairs)
        except TypeError:
            raise TypeError("env_kwargs values must be hashable (e.g. frozen specs)") from None
        object.__setattr__(self, "env_kwargs", pairs)

    def task_scene(self) -> SceneSpec:
        """The ``SceneSpec`` the env builds for these settings.

        ``env_kwargs``' ``scene`` if given, else the scene of ``env_kwargs``' ``task`` (a name or
        a ``TaskDefinition``; ``push``, the default scene, without one). Code that derives
        scenes from the run's (the retest's nudges) must start here: a plain ``SceneSpec()``
        is push's box start, not a hook's.
        """
        kwargs = dict(self.env_kwargs)
        if kwargs.get("scene") is not None:
            return cast("SceneSpec", kwargs["scene"])
        from tooldesign_env.tasks import DEFAULT_TASK, get_task

        return get_task(kwargs.get("task", DEFAULT_TASK)).scene

    def env_key(self) -> tuple[Any, ...]:
        """The settings that need a separate env; goal and box mass are set per episode."""
        return (self.goal_precision, self.estimator, self.objective, self.env_kwargs)


@dataclass(frozen=True, kw_only=True)
class EvaluationRequest:
    """One design to simulate and score: what a worker receives.

    Attributes:
        coeffs: Design ``(c1, ..., cn)``, highest power first; stored as a tuple of floats.
        task: Goal, precision, box mass, estimator and env settings.
        keep_trajectory: Also return the (T, 3) box trajectory in m (for plots).
    """

    coeffs: Sequence[float] | np.ndarray
    task: TaskSettings = field(default_factory=TaskSettings)
    keep_trajectory: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "coeffs", _as_coeffs(self.coeffs))
        if not isinstance(self.task, TaskSettings):
            raise TypeError(f"task must be a TaskSettings, got {type(self.task).__name__}")


@dataclass(frozen=True, kw_only=True)
class RobustnessRequest:
    """One design to test under the paper's box-mass changes.

    Attributes:
        coeffs: Design ``(c1, ..., cn)``; stored as a tuple of floats.
        task: The task; ``task.box_mass`` is the nominal mass m.
        masses: Altered masses m_i in kg, each > 0 and <= 1000; stored as a tuple.
    """

    coeffs: Sequence[float] | np.ndarray
    task: TaskSettings = field(default_factory=TaskSettings)
    masses: Sequence[float] = ROBUSTNESS_MASSES

    def __post_init__(self) -> None:
        object.__setattr__(self, "coeffs", _as_coeffs(self.coeffs))
        if not isinstance(self.task, TaskSettings):
            raise TypeError(f"task must be a TaskSettings, got {type(self.task).__name__}")
        from tooldesign_env.specs import BOX_MASS_MAX, is_unordered

        if is_unordered(self.masses):
            # A set would be tested, and reported, in hash order.
            raise TypeError(
                f"masses must be masses in kg in order (a list or tuple), got a "
                f"{type(self.masses).__name__}: {self.masses!r}"
            )
        masses = tuple(_finite("masses", m) for m in self.masses)
        if not masses or min(masses) <= 0 or max(masses) > BOX_MASS_MAX:
            raise ValueError(
                f"masses must be one or more masses > 0 and <= {BOX_MASS_MAX:g} kg (the limit of "
                f"box_mass), got {masses}"
            )
        object.__setattr__(self, "masses", masses)


def _as_coeffs(coeffs: Any) -> tuple[float, ...]:
    if isinstance(coeffs, (str, bytes)):
        raise TypeError(f"coeffs must be numbers, got {coeffs!r}")
    try:
        array = np.asarray(coeffs, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"coeffs must be a sequence of numbers, got {coeffs!r}") from None
    if array.ndim != 1 or array.size == 0:
        raise ValueError(f"coeffs must be a flat sequence of n >= 1 numbers, got {coeffs!r}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"coeffs must be finite, got {array.tolist()}")
    # tolist() gives Python floats with the same bits, so pickling and logging are exact.
    return tuple(array.tolist())


# One env per env settings per thread: a process-pool or Dask worker with one thread keeps one
# env (one PyBullet client) for the whole run; threads never share a client.
_LOCAL = threading.local()

#: Envs a thread keeps at most, the least recently used closed first. Each is a PyBullet client
#: with its meshes (about 150 MB), and a worker of the benchmark protocol meets a new set of env
#: settings in every cell (each instance has its own box friction, each nudged scene its own box
#: start): kept without a bound, a worker of the full references grew by 2.4 GB in 11 of its 72
#: cells. A suite's runs use one or two settings, so 4 never closes an env a run still needs.
ENV_CACHE_SIZE = 4


def worker_env(task: TaskSettings, *, series: bool = False) -> Any:
    """This thread's ``ToolDesign-v0`` env for ``task``'s settings, reset to its goal and mass.

    Made on first use and kept (one per set of env settings per thread, at most
    :data:`ENV_CACHE_SIZE`, the least recently used closed first), so the plan's inverse
    kinematics and the PyBullet client are made once per worker, not once per design.

    Args:
        task: The task and env settings.
        series: Whether the next steps' ``info`` holds the per-step series and trajectories.

    Returns:
        The env (a Gymnasium wrapper of :class:`~tooldesign_env.ToolDesignEnv`).
    """
    cache: OrderedDict[tuple[Any, ...], Any] | None = getattr(_LOCAL, "envs", None)
    if cache is None:
        cache = _LOCAL.envs = OrderedDict()
    key = task.env_key()
    env = cache.get(key)
    if env is None:
        import gymnasium as gym

        import tooldesign_env  # noqa: F401  (registers ToolDesign-v0)

        while len(cache) >= ENV_CACHE_SIZE:
            cache.popitem(last=False)[1].close()
        env = gym.make(
            "ToolDesign-v0",
            goal_precision=task.goal_precision,
            estimator=task.estimator,
            objective_kind=task.objective,
            **dict(task.env_kwargs),
        )
        cache[key] = env
    else:
        cache.move_to_end(key)
    env.reset(options={"goal": task.goal, "box_mass": task.box_mass})
    env.unwrapped.info_series = bool(series)  # type: ignore[union-attr]
    return env


def clear_env_cache() -> None:
    """Close and forget this thread's cached envs (tests; long-lived interactive sessions)."""
    cache = getattr(_LOCAL, "envs", None) or {}
    for env in cache.values():
        env.close()
    _LOCAL.envs = OrderedDict()


def _failed_row(message: str, elapsed: float) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys((*METRICS, *STANDING_COLUMNS), math.nan)
    row.update(status="failed", eval_time=elapsed, message=message)
    return row


def evaluate_design(request: EvaluationRequest) -> dict[str, Any]:
    """Simulate and score one design; never raises for a bad design or a simulation error.

    Runs in a worker (any executor); the env of the request's settings is made on first use in
    the process and reused.

    Args:
        request: The design and its task.

    Returns:
        A plain dict: ``free_energy``, ``goal_error``, ``confidence`` (control-confidence term),
        ``final_distance`` (m), ``final_height`` (the box centre's final height, m) and
        ``final_tilt`` (its up axis's final angle from the vertical, rad; NaN where the env
        did not read it) as floats; ``status``: ``"ok"``, ``"invalid"`` (not simulated;
        the metrics are the env's finite penalty values, height and tilt the box's start) or
        ``"failed"`` (the metrics, height and tilt are NaN);
        ``eval_time`` (s, wall time); ``message`` (why it is invalid or failed, "" if ok); and
        ``box_trajectory`` ((T, 3) in m, T = 0 if not simulated) if ``keep_trajectory``.
    """
    start = time.perf_counter()
    try:
        env = worker_env(request.task, series=request.keep_trajectory)
        _, _, _, _, info = env.step(np.asarray(request.coeffs, dtype=np.float64))
    except Exception as exc:  # a failed design must not end the run
        return _failed_row(_describe(exc), time.perf_counter() - start)
    row: dict[str, Any] = {name: float(info[name]) for name in METRICS}
    if not all(math.isfinite(v) for v in row.values()):
        bad = [k for k, v in row.items() if not math.isfinite(v)]
        return _failed_row(f"non-finite {', '.join(bad)}", time.perf_counter() - start)
    # The box's final height and tilt, for the task's whole success test in reports. They do
    # not enter F: stored as the env gives them, NaN where it has none (a tilt it did not read).
    for name in STANDING_COLUMNS:
        value = info.get(name)
        row[name] = math.nan if value is None else float(value)
    row["status"] = "ok" if info["valid"] else "invalid"
    row["message"] = "" if info["valid"] else str(info["invalid_reason"])
    if request.keep_trajectory:
        row["box_trajectory"] = np.asarray(info["box_trajectory"], dtype=np.float64)
    row["eval_time"] = time.perf_counter() - start
    return row


def evaluate_robustness_of_design(request: RobustnessRequest) -> dict[str, Any]:
    """The paper's robustness test of one design, in a worker (see ``evaluate_robustness``).

    Args:
        request: The design, its task (nominal box mass) and the altered masses.

    Returns:
        ``robustness`` (m), ``accuracy`` (m), ``control_deviation`` (N m), ``nominal_mass`` and
        ``masses`` (kg), ``nominal_box_trajectory`` ((T, 3) in m) and ``box_trajectories``
        (one (T, 3) array in m per altered mass).

    Raises:
        ValueError: If the design is not valid (it cannot be built or overlaps the box).
    """
    env = worker_env(request.task)
    result = env.unwrapped.evaluate_robustness(
        np.asarray(request.coeffs, dtype=np.float64), masses=request.masses
    )
    return {
        "robustness": float(result.robustness),
        "accuracy": float(result.accuracy),
        "control_deviation": float(result.control_deviation),
        "nominal_mass": float(result.nominal_mass),
        "masses": [float(m) for m in result.masses],
        "nominal_box_trajectory": np.asarray(result.nominal.box_position, dtype=np.float64),
        "box_trajectories": [
            np.asarray(t.box_position, dtype=np.float64) for t in result.perturbed
        ],
    }


def _describe(exc: BaseException) -> str:
    # The last frame says where; the whole traceback would not fit a log line.
    frames = traceback.extract_tb(exc.__traceback__)
    where = f" at {frames[-1].filename}:{frames[-1].lineno}" if frames else ""
    return f"{type(exc).__name__}: {exc}{where}"


Designs = Sequence[Sequence[float]] | Sequence[np.ndarray] | np.ndarray

"""(batch_size, n) coefficients: an array or a sequence of designs."""


def evaluate_batch(
    executor: Executor,
    designs: Designs,
    task: TaskSettings,
    *,
    keep_trajectory: bool = False,
) -> list[dict[str, Any]]:
    """Evaluate a batch of designs through ``executor``; one row per design, in order.

    Args:
        executor: From :func:`make_executor`.
        designs: (batch_size, n) coefficients.
        task: The task every design is scored on.
        keep_trajectory: Also return each (T, 3) box trajectory (see :func:`evaluate_design`).

    Returns:
        Rows of :func:`evaluate_design`; a design whose worker raised or died has status
        ``"failed"`` with NaN metrics, the error in ``message`` and, as ``eval_time``, the
        wall time until the failure was known.
    """
    requests = [
        EvaluationRequest(coeffs=d, task=task, keep_trajectory=keep_trajectory) for d in designs
    ]
    return [outcome_row(*outcome) for outcome in map_robust(executor, evaluate_design, requests)]


def outcome_row(result: Any, exc: BaseException | None, seconds: float) -> dict[str, Any]:
    """The evaluation row of one outcome of :func:`map_robust` over :func:`evaluate_design`.

    Args:
        result: The row the worker returned (ignored if ``exc`` is given).
        exc: The exception of a worker that raised or died, or ``None``.
        seconds: Wall time until the outcome was known.

    Returns:
        ``result``, or a ``"failed"`` row with NaN metrics, the error in ``message`` and
        ``seconds`` as ``eval_time``.
    """
    if exc is None:
        return cast("dict[str, Any]", result)
    what = "worker process died" if isinstance(exc, BrokenProcessPool) else "worker error"
    return _failed_row(f"{what}: {_describe(exc)}", seconds)


@dataclass(frozen=True, kw_only=True)
class FinalTest:
    """The test of a finished run's design, done in a worker.

    Attributes:
        coeffs: The design ``(c1, ..., cn)``.
        task: Its task; ``task.box_mass`` is the nominal mass.
        masses: Altered box masses m_i in kg for the robustness test, or ``None`` for a single
            rollout at the nominal mass (to get the box path).
        keep_paths: Return the box paths (rounded to 1 um).
    """

    coeffs: tuple[float, ...]
    task: TaskSettings
    masses: tuple[float, ...] | None
    keep_paths: bool


def run_final_test(test: FinalTest) -> dict[str, Any]:
    """Roll the design out at the nominal mass (and at each altered mass) and measure it.

    Args:
        test: The design and what to measure.

    Returns:
        ``squared_goal_error`` (sum over control steps of |X(m, t) - X^g|^2, m^2),
        ``nominal_final_distance`` (|X(m, T) - X^g|, m), with ``masses``: ``robustness`` (m),
        ``accuracy`` (m), ``control_deviation`` (N m), ``nominal_mass`` and ``masses`` (kg);
        with ``keep_paths``: ``paths`` ({``nominal``: (T, 3) list, ``perturbed``: one per
        mass}); and ``test_time`` (s, in the worker).

    Raises:
        ValueError: If the design is not valid (the env cannot simulate it).
    """
    start = time.perf_counter()
    out: dict[str, Any] = {}
    perturbed: list[np.ndarray] = []
    if test.masses is not None:
        request = RobustnessRequest(coeffs=test.coeffs, task=test.task, masses=test.masses)
        result = evaluate_robustness_of_design(request)
        nominal = np.asarray(result["nominal_box_trajectory"], dtype=np.float64)
        perturbed = [np.asarray(p, dtype=np.float64) for p in result["box_trajectories"]]
        out.update({k: result[k] for k in (*ROBUSTNESS_METRICS, "nominal_mass", "masses")})
    else:
        row = evaluate_design(
            EvaluationRequest(coeffs=test.coeffs, task=test.task, keep_trajectory=True)
        )
        if row["status"] != "ok":
            raise ValueError(f"the design cannot be simulated: {row['message']}")
        nominal = np.asarray(row["box_trajectory"], dtype=np.float64)
    error = nominal - np.asarray(test.task.goal, dtype=np.float64)
    out["squared_goal_error"] = float(np.sum(error * error))
    out["nominal_final_distance"] = float(np.linalg.norm(error[-1])) if len(error) else math.nan
    if test.keep_paths:
        out["paths"] = {
            "nominal": rounded_path(nominal),
            "perturbed": [rounded_path(p) for p in perturbed],
        }
    out["test_time"] = time.perf_counter() - start
    return out


def evaluate_item(item: EvaluationRequest | FinalTest) -> dict[str, Any]:
    """The worker function of a suite: a design to score, or a finished run's test."""
    if isinstance(item, FinalTest):
        return run_final_test(item)
    return evaluate_design(item)
