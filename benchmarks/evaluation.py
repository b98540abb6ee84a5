"""Evaluating batches of tool designs, serially, on a local process pool or on Dask.

The designer of Algorithm 1 asks for a batch of tools; each tool is simulated and scored
independently, so a batch is spread over workers through a :class:`concurrent.futures.Executor`:

- ``"serial"``: :class:`SerialExecutor`, in the calling process (debugging, tiny runs, tests);
- ``"process"`` (default): a local :class:`~concurrent.futures.ProcessPoolExecutor` whose workers
  are started with ``forkserver`` (or ``spawn`` where there is none), never ``fork``: a forked
  PyBullet client shares its parent's physics server and breaks;
- ``"dask"``: a ``dask.distributed`` cluster, a :class:`~distributed.LocalCluster` or the
  scheduler at ``--scheduler ADDRESS`` (``pip install 'tooldesign[dask]'``).

:func:`evaluate_design` is the picklable worker function. Each worker keeps one
``ToolDesign-v0`` env per set of env settings (module-level cache), so the plan's inverse
kinematics and the PyBullet client are made once per process, not once per design. Rollouts are
deterministic and do not depend on what the env simulated before, so every executor gives the
same rows apart from ``eval_time``.

Failures never end a run: an exception inside the worker becomes a row with status
``"failed"``; a worker process that dies (``BrokenProcessPool``) is retried alone in a fresh
pool and, if it dies again, its design is ``"failed"`` too.

Example:
    >>> task = TaskSettings(goal=(0.0, 1.5, 0.1), goal_precision=20.0)  # doctest: +SKIP
    >>> with make_executor("process", workers=2) as executor:  # doctest: +SKIP
    ...     rows = evaluate_batch(executor, [(0.0, 0.0, 0.0), (1.0, -1.0, 0.3)], task)
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import math
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from benchmarks._parent_death import die_with_parent

__all__ = [
    "check_main_guard",
    "EXECUTORS",
    "Designs",
    "METRIC_FIELDS",
    "EvaluationRequest",
    "RobustnessRequest",
    "SerialExecutor",
    "TaskSettings",
    "clear_env_cache",
    "evaluate_batch",
    "evaluate_design",
    "evaluate_robustness_of_design",
    "make_executor",
    "map_robust",
    "outcome_row",
]

ExecutorKind = Literal["serial", "process", "dask"]
Designs = Sequence[Sequence[float]] | Sequence[np.ndarray] | np.ndarray
"""(batch_size, n) coefficients: an array or a sequence of designs."""
EXECUTORS: tuple[str, ...] = ("serial", "process", "dask")
"""Executor kinds accepted by :func:`make_executor`."""

METRIC_FIELDS: tuple[str, ...] = ("free_energy", "goal_error", "confidence", "final_distance")
"""Metric fields of an evaluation row (the evaluation log's metric columns)."""

_ESTIMATORS: tuple[str, ...] = ("contact", "trajectory", "resimulation")
OBJECTIVES: tuple[str, ...] = ("free-energy", "expected-goal-error")
_DASK_EXTRA = "pip install 'tooldesign[dask]'"


# --- requests ----------------------------------------------------------------------------------


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


@dataclass(frozen=True, kw_only=True)
class TaskSettings:
    """The task a design is scored on, and the env settings it is scored with.

    Attributes:
        goal: Goal position X^g, (x, y, z) in m; stored as a tuple of floats.
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

    goal: Sequence[float] = (0.0, 1.5, 0.1)
    goal_precision: float = 20.0
    box_mass: float = 0.1
    estimator: str = "contact"
    objective: str = "free-energy"
    env_kwargs: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()

    def __post_init__(self) -> None:
        goal = self.goal
        if isinstance(goal, (str, bytes)) or not isinstance(goal, (Sequence, np.ndarray)):
            raise TypeError(f"goal must be 3 numbers (x, y, z) in m, got {goal!r}")
        if len(goal) != 3:
            raise ValueError(f"goal must be 3 numbers (x, y, z) in m, got {len(goal)}")
        object.__setattr__(self, "goal", tuple(_finite("goal", v) for v in goal))
        from tooldesign_env.specs import BOX_MASS_MAX, GOAL_PRECISION_MAX

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
        if self.estimator not in _ESTIMATORS:
            raise ValueError(f"estimator must be one of {_ESTIMATORS}, got {self.estimator!r}")
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}, got {self.objective!r}")
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

    def env_key(self) -> tuple[Any, ...]:
        """The settings that need a separate env; goal and box mass are set per episode."""
        return (self.goal_precision, self.estimator, self.objective, self.env_kwargs)


def add_task_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the task options (goal, p^X, box mass, estimator, objective) to a parser.

    Their defaults are :class:`TaskSettings`'; every command that evaluates designs takes the
    same options with the same meaning.
    """
    defaults = TaskSettings()
    parser.add_argument(
        "--goal",
        type=float,
        nargs=3,
        default=list(defaults.goal),
        metavar=("X", "Y", "Z"),
        help=f"goal X^g in m (default: {' '.join(f'{v:g}' for v in defaults.goal)})",
    )
    parser.add_argument(
        "--goal-precision",
        type=float,
        default=defaults.goal_precision,
        metavar="P",
        help="goal precision p^X (default: %(default)s)",
    )
    parser.add_argument(
        "--box-mass",
        type=float,
        default=defaults.box_mass,
        metavar="M",
        help="box mass in kg (default: %(default)s)",
    )
    parser.add_argument(
        "--estimator",
        choices=_ESTIMATORS,
        default=defaults.estimator,
        help="estimator of dX/dU (default: %(default)s)",
    )
    parser.add_argument(
        "--objective",
        choices=OBJECTIVES,
        default=defaults.objective,
        help="what is minimized: F, or the goal error averaged over box masses (the "
        "robust-design baseline) (default: %(default)s)",
    )


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
        masses: Altered masses m_i in kg; stored as a tuple.
    """

    coeffs: Sequence[float] | np.ndarray
    task: TaskSettings = field(default_factory=TaskSettings)
    masses: Sequence[float] = (0.3, 0.5, 0.7, 0.9)

    def __post_init__(self) -> None:
        object.__setattr__(self, "coeffs", _as_coeffs(self.coeffs))
        if not isinstance(self.task, TaskSettings):
            raise TypeError(f"task must be a TaskSettings, got {type(self.task).__name__}")
        masses = tuple(_finite("masses", m) for m in self.masses)
        if not masses or min(masses) <= 0:
            raise ValueError(f"masses must be one or more masses > 0 kg, got {masses}")
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


# --- the worker --------------------------------------------------------------------------------

# One env per env settings per thread: a process-pool or Dask worker with one thread keeps one
# env (one PyBullet client) for the whole run; threads never share a client.
_LOCAL = threading.local()


def _env(task: TaskSettings) -> Any:
    cache: dict[tuple[Any, ...], Any] | None = getattr(_LOCAL, "envs", None)
    if cache is None:
        cache = _LOCAL.envs = {}
    key = task.env_key()
    env = cache.get(key)
    if env is None:
        import gymnasium as gym

        import tooldesign_env  # noqa: F401  (registers ToolDesign-v0)

        env = gym.make(
            "ToolDesign-v0",
            goal_precision=task.goal_precision,
            estimator=task.estimator,
            objective_kind=task.objective,
            **dict(task.env_kwargs),
        )
        cache[key] = env
    env.reset(options={"goal": task.goal, "box_mass": task.box_mass})
    return env


def clear_env_cache() -> None:
    """Close and forget this thread's cached envs (tests; long-lived interactive sessions)."""
    cache = getattr(_LOCAL, "envs", None) or {}
    for env in cache.values():
        env.close()
    _LOCAL.envs = {}


def _failed_row(message: str, elapsed: float) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(METRIC_FIELDS, math.nan)
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
        ``final_distance`` (m) as floats; ``status``: ``"ok"``, ``"invalid"`` (not simulated;
        the metrics are the env's finite penalty values) or ``"failed"`` (the metrics are NaN);
        ``eval_time`` (s, wall time); ``message`` (why it is invalid or failed, "" if ok); and
        ``box_trajectory`` ((T, 3) in m, T = 0 if not simulated) if ``keep_trajectory``.
    """
    start = time.perf_counter()
    try:
        env = _env(request.task)
        _, _, _, _, info = env.step(np.asarray(request.coeffs, dtype=np.float64))
    except Exception as exc:  # a failed design must not end the run
        return _failed_row(_describe(exc), time.perf_counter() - start)
    row: dict[str, Any] = {name: float(info[name]) for name in METRIC_FIELDS}
    if not all(math.isfinite(v) for v in row.values()):
        bad = [k for k, v in row.items() if not math.isfinite(v)]
        return _failed_row(f"non-finite {', '.join(bad)}", time.perf_counter() - start)
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
    env = _env(request.task)
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


# --- executors ---------------------------------------------------------------------------------


class SerialExecutor(Executor):
    """An executor that runs each call at once in the calling thread.

    Exceptions are stored in the returned future, as a pool would, so callers handle every
    executor the same way.
    """

    def __init__(self) -> None:
        self._shutdown = False

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Run ``fn(*args, **kwargs)`` now and return its finished future."""
        if self._shutdown:
            raise RuntimeError("cannot schedule new futures after shutdown")
        future: Future[Any] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # KeyboardInterrupt is not stored: it stops the run
            future.set_exception(exc)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Refuse further calls."""
        self._shutdown = True


class _RestartingProcessPool(Executor):
    """A process pool that replaces itself after a worker died, so the run can go on."""

    def __init__(self, workers: int, context: Any) -> None:
        self._workers = workers
        self._context = context
        self._pool = self._new_pool()

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self._workers, mp_context=self._context, initializer=_init_worker
        )

    @property
    def max_workers(self) -> int:
        """Number of worker processes."""
        return self._workers

    def restart(self) -> None:
        """Drop the current pool (broken or not) and start a fresh one."""
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._new_pool()

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Submit to the pool, restarting it first if a worker died since the last call."""
        try:
            return self._pool.submit(fn, *args, **kwargs)
        except BrokenProcessPool:
            self.restart()
            return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Shut the pool down."""
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)


def _ignore_sigint() -> None:
    # Ctrl-C reaches the whole process group. Workers ignore it and finish their evaluation;
    # the main process stops the run and shuts the pool down, so no half-told batch is logged.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _init_worker() -> None:
    _ignore_sigint()
    die_with_parent()


def _process_context() -> Any:
    # forkserver forks workers from a clean server process that never made a PyBullet client
    # (and is faster to start than spawn); plain fork would copy the parent's client.
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    if hasattr(context, "set_forkserver_preload"):
        # The forkserver imports this module first, which makes it die with the main process:
        # a SIGKILLed run would otherwise leave the server and its workers running.
        context.set_forkserver_preload(["__main__", "benchmarks._forkserver_preload"])
    return context


def check_main_guard() -> None:
    """Refuse to start worker processes from a script without a ``__main__`` guard.

    Worker processes (``forkserver`` or ``spawn``) import the main script again. Without the
    guard, each worker re-runs the script and would start a pool of its own: the run fails
    after minutes with a RuntimeError from deep inside multiprocessing. This check fails at once.
    It looks only at a main module that is a Python file (not ``python -c``, a notebook or an
    interactive session).

    Raises:
        RuntimeError: the main script has module-level code but no ``__main__`` guard; the
            message says what to do.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or getattr(main, "__spec__", None) is not None:
        return  # -c, interactive, notebook, or python -m (a module, imported under its name)
    if not str(path).endswith(".py") or not os.path.isfile(path):
        return
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read(), filename=str(path))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return
    if not any(_is_main_guard(node) for node in tree.body):
        raise RuntimeError(
            f"{path} starts worker processes but has no 'if __name__ == \"__main__\":' guard; "
            "each worker would re-run the script. Put the call under that guard, e.g.\n\n"
            '    if __name__ == "__main__":\n        run_design(...)\n\n'
            "or evaluate in this process with executor='serial'."
        )


def _is_main_guard(node: ast.stmt) -> bool:
    if not isinstance(node, ast.If) or not isinstance(node.test, ast.Compare):
        return False
    if not all(isinstance(op, ast.Eq) for op in node.test.ops):
        return False
    names = [node.test.left, *node.test.comparators]
    has_name = any(isinstance(n, ast.Name) and n.id == "__name__" for n in names)
    has_main = any(isinstance(n, ast.Constant) and n.value == "__main__" for n in names)
    return has_name and has_main


def _check_workers(workers: int | None) -> int:
    if workers is None:
        return os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)):
        raise TypeError(f"workers must be an int >= 1 or None, got {type(workers).__name__}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    return int(workers)


@contextlib.contextmanager
def make_executor(
    kind: str = "process", workers: int | None = None, scheduler: str | None = None
) -> Iterator[Executor]:
    """An executor for :func:`evaluate_batch`, shut down (and its cluster closed) on exit.

    Args:
        kind: ``"serial"``, ``"process"`` or ``"dask"``.
        workers: Worker processes (process pool, Dask ``LocalCluster``); default
            ``os.cpu_count()``. Ignored by ``"serial"`` and with a ``scheduler``.
        scheduler: Address of a running Dask scheduler (``"tcp://host:8786"``); only with
            ``kind="dask"``. Without it a ``LocalCluster`` of ``workers`` single-threaded worker
            processes is started.

    Yields:
        A :class:`concurrent.futures.Executor`.

    Raises:
        ValueError: If ``kind`` is unknown, ``workers`` < 1, or ``scheduler`` is given for a
            kind other than ``"dask"``.
        ImportError: If ``kind="dask"`` and dask.distributed is not installed; the message names
            the extra ``pip install 'tooldesign[dask]'``.
    """
    if kind not in EXECUTORS:
        raise ValueError(f"executor kind must be one of {EXECUTORS}, got {kind!r}")
    count = _check_workers(workers)
    if scheduler is not None and kind != "dask":
        raise ValueError(
            f"scheduler is an address of a Dask scheduler; it needs kind='dask', got {kind!r}"
        )
    if kind == "serial":
        serial = SerialExecutor()
        try:
            yield serial
        finally:
            serial.shutdown()
    elif kind == "process":
        check_main_guard()
        pool = _RestartingProcessPool(count, _process_context())
        try:
            yield pool
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    else:
        if scheduler is None:  # a LocalCluster starts worker processes here
            check_main_guard()
        with _dask_executor(count, scheduler) as executor:
            yield executor


@contextlib.contextmanager
def _dask_executor(workers: int, scheduler: str | None) -> Iterator[Executor]:
    try:
        from distributed import Client, LocalCluster
    except ImportError as err:
        raise ImportError(
            f"the dask executor needs dask.distributed, which is not installed; "
            f"install it with `{_DASK_EXTRA}` or use --executor process"
        ) from err
    if scheduler is not None:
        if not isinstance(scheduler, str) or not scheduler:
            raise ValueError(
                f"scheduler must be an address like tcp://host:8786, got {scheduler!r}"
            )
        cluster = None
        client = Client(scheduler)
    else:
        # One thread per worker: the env cache is per thread, and PyBullet is CPU bound.
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=40,  # logging.ERROR: no worker start-up chatter in the progress bar
        )
        client = Client(cluster)
    try:
        # pure=False: two equal designs are two evaluations (each timed), not one cached task.
        yield client.get_executor(pure=False)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def map_robust(
    executor: Executor, fn: Callable[[Any], Any], items: Sequence[Any]
) -> list[tuple[Any, BaseException | None, float]]:
    """Call ``fn`` on every item through ``executor``; collect results and exceptions in order.

    Items whose worker process died (``BrokenProcessPool`` takes every pending call of the pool
    with it) are retried one at a time in a fresh pool, so one crashing design does not fail its
    neighbours and the outcome does not depend on how the batch was spread over workers.

    Args:
        executor: From :func:`make_executor` (or any executor).
        fn: A picklable function of one argument.
        items: The arguments.

    Returns:
        ``(result, None, seconds)`` or ``(None, exception, seconds)`` per item, in the order of
        ``items``; ``seconds`` is the wall time from submitting the item to its outcome.
    """
    start = time.perf_counter()
    futures = [executor.submit(fn, item) for item in items]
    outcomes = [_outcome(f, start) for f in futures]
    broken = [i for i, (_, exc, _) in enumerate(outcomes) if isinstance(exc, BrokenProcessPool)]
    if broken and isinstance(executor, _RestartingProcessPool):
        for index in broken:
            executor.restart()
            start = time.perf_counter()
            outcomes[index] = _outcome(executor.submit(fn, items[index]), start)
        executor.restart()  # leave a working pool for the next batch
    return outcomes


def _outcome(future: Future[Any], start: float) -> tuple[Any, BaseException | None, float]:
    try:
        return future.result(), None, time.perf_counter() - start
    except Exception as exc:  # every failure becomes a "failed" row
        return None, exc, time.perf_counter() - start


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
        return result
    what = "worker process died" if isinstance(exc, BrokenProcessPool) else "worker error"
    return _failed_row(f"{what}: {_describe(exc)}", seconds)
