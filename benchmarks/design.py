"""Algorithm 1 of the paper, resumable: ask a batch of tools, evaluate them, tell, repeat.

``tooldesign design`` (and :func:`run_design`) runs the designer (an ask/tell optimizer from
:mod:`optimizers`, CMA-ES by default), the user and the evaluator (``ToolDesign-v0`` through an
executor of :mod:`benchmarks.evaluation`) for K iterations, and writes a run folder: the
evaluation log, the best design's card and meshes, the panels of the paper's Figure 3 and the
robustness test of the final tool. ``docs/design-runs.md`` documents the folder.

Resume: every finished iteration is one atomic part file of the evaluation log (see
:mod:`benchmarks.storage`), written after the optimizer was told its scores. A resumed run makes
the optimizer again from the seed and replays the logged iterations: each replayed ask must equal
the logged coefficients and ids bit for bit (else :class:`ResumeError`), and is told the logged
scores. The run then goes on as if it had never stopped, so an interrupted and resumed run gives
the same evaluation log and the same design as an uninterrupted one.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import json
import math
import os
import sys
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks import plots
from benchmarks.evaluation import (
    EXECUTORS,
    METRIC_FIELDS,
    RobustnessRequest,
    TaskSettings,
    add_task_arguments,
    evaluate_batch,
    evaluate_robustness_of_design,
    make_executor,
    map_robust,
)
from benchmarks.storage import (
    MANIFEST_VERSION,
    ResultStore,
    Unit,
    atomic_write_text,
    build_manifest,
    json_text,
    part_checksums,
    read_manifest,
    timing_totals,
    verify_checksums,
)

__all__ = [
    "DESIGN_SUITE",
    "FILES",
    "DesignConfig",
    "DesignResult",
    "DesignStepper",
    "ResumeError",
    "add_parser",
    "best_evaluation",
    "config_from_args",
    "run_design",
]

DESIGN_SUITE = "design"
"""Suite name of a design run in its evaluation log."""

CARD_VERSION = 1
"""``format_version`` of ``design.json``."""

FILES: dict[str, str] = {
    "card": "design.json",
    "stl": "tool.stl",
    "obj": "tool.obj",
    "urdf": "tool.urdf",
    "evaluations": "evaluations.csv",
    "robustness": "robustness.json",
    "robustness_png": "robustness.png",
    "fig3a": "fig3a_tool_curves.png",
    "fig3b": "fig3b_free_energy.png",
    "fig3c": "fig3c_box_paths.png",
    "fig3d": "fig3d_final_tool.png",
    "fig3": "figure3.png",
}
"""Files of a finished run folder, besides ``manifest.json`` and ``parts/``."""

VIDEO_FILE = "rollout.gif"
"""The best design's rollout (``run_design(video=True)``, ``tooldesign design`` by default)."""

_DEFAULT_GOAL = (0.0, 1.5, 0.1)
# Fields that do not change the results, so a resumed run may set them differently.
_RUNTIME_FIELDS = frozenset({"iterations", "workers", "executor", "scheduler"})


#: Key in the manifest's ``extra``: ``{part path relative to the run folder: sha256}``.
PART_CHECKSUMS = "part_sha256"


class ResumeError(ValueError):
    """A run folder cannot be resumed with this configuration or this optimizer."""


# --- configuration -----------------------------------------------------------------------------


def _int(name: str, value: Any, minimum: int, maximum: int = 2**63 - 1) -> int:
    # The maximum is int64's: seeds and counts are stored in Parquet and SQLite columns.
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if value > maximum:
        raise ValueError(f"{name} must be <= {maximum} (int64), got {value}")
    return int(value)


def _settings(value: Any) -> tuple[tuple[str, Any], ...]:
    if isinstance(value, Mapping):
        value = tuple(value.items())
    try:
        pairs = tuple(sorted((k, v) for k, v in value))
    except (TypeError, ValueError):
        raise TypeError(
            f"optimizer_settings must be a mapping of names to values, got {value!r}"
        ) from None
    for key, item in pairs:
        if not isinstance(key, str) or not key.isidentifier():
            raise ValueError(f"optimizer_settings keys must be identifiers, got {key!r}")
        try:
            json.dumps(item, allow_nan=False)
        except (TypeError, ValueError):
            raise TypeError(
                f"optimizer_settings[{key!r}] must be a JSON value (number, string, bool, list, "
                f"null) so the run folder can record it, got {item!r}"
            ) from None
    return pairs


def _bounds(value: Any) -> tuple[tuple[float, float], ...]:
    if value is None:
        from tooldesign_env import default_bounds

        value = default_bounds(3)
    from optimizers._validation import check_bounds
    from tooldesign_env.env import COEFFICIENT_MAX

    # The optimizers' check refuses bools, strings, ragged rows and overflowing ints by name.
    low, high = check_bounds(value)
    array = np.stack([low, high], axis=1)
    if np.any(np.abs(array) > COEFFICIENT_MAX):
        raise ValueError(
            f"bounds must lie within +-{COEFFICIENT_MAX:g} (coefficients of a 1.1 m tool), "
            f"got {array.tolist()}"
        )
    return tuple((float(lo), float(hi)) for lo, hi in array.tolist())


@dataclasses.dataclass(frozen=True, kw_only=True)
class DesignConfig:
    """What a design run does: the designer, its budget, where it runs, and the task.

    Attributes:
        optimizer: Name in the :mod:`optimizers` registry (``cmaes``, ``bo``, ``pso``,
            ``random``) or a ``"module:Class"`` string.
        optimizer_settings: Keyword arguments of the optimizer (a mapping; stored as sorted
            pairs), JSON values only.
        seed: Seed of the optimizer, >= 0; the simulation has no randomness.
        iterations: K, iterations of ask/evaluate/tell, >= 1.
        batch_size: Designs asked per iteration (the population size), >= 1.
        workers: Worker processes; ``None`` is ``os.cpu_count()``.
        executor: ``"serial"``, ``"process"`` or ``"dask"``.
        scheduler: Address of a Dask scheduler (with ``executor="dask"``); a LocalCluster if
            ``None``.
        goal: X^g, (x, y, z) in m.
        goal_precision: p^X in 1/m^2, >= 0 (the paper's Figure 3 uses 40, its comparisons 20).
        box_mass: Box mass in kg (the paper's 0.1).
        estimator: ``"contact"``, ``"trajectory"`` or ``"resimulation"`` estimate of dX/dU.
        objective: ``"free-energy"`` (F) or ``"expected-goal-error"`` (the robust-design
            baseline, see ``ObjectiveSpec.kind``).
        bounds: (n, 2) coefficient bounds [low, high]; ``None`` is ``default_bounds(3)``
            (c1, c2 in [-1.5, 1.5], c3 in [-0.5, 0.5]). n is the polynomial degree.
        robustness_masses: Altered box masses m_i in kg of the final tool's robustness test.
    """

    optimizer: str = "cmaes"
    optimizer_settings: tuple[tuple[str, Any], ...] | Mapping[str, Any] = ()
    seed: int = 0
    iterations: int = 15
    batch_size: int = 8
    workers: int | None = None
    executor: str = "process"
    scheduler: str | None = None
    goal: Sequence[float] = _DEFAULT_GOAL
    goal_precision: float = 20.0
    box_mass: float = 0.1
    estimator: str = "contact"
    objective: str = "free-energy"
    bounds: Sequence[Sequence[float]] | np.ndarray | None = None
    robustness_masses: Sequence[float] = (0.3, 0.5, 0.7, 0.9)

    def __post_init__(self) -> None:
        if not isinstance(self.optimizer, str) or not self.optimizer.strip():
            raise ValueError(f"optimizer must be a non-empty name, got {self.optimizer!r}")
        object.__setattr__(self, "optimizer_settings", _settings(self.optimizer_settings))
        object.__setattr__(self, "seed", _int("seed", self.seed, 0))
        object.__setattr__(self, "iterations", _int("iterations", self.iterations, 1))
        object.__setattr__(self, "batch_size", _int("batch_size", self.batch_size, 1))
        if self.workers is not None:
            object.__setattr__(self, "workers", _int("workers", self.workers, 1))
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
        # TaskSettings checks goal, precision, mass and estimator and says what is wrong.
        task = TaskSettings(
            goal=self.goal,
            goal_precision=self.goal_precision,
            box_mass=self.box_mass,
            estimator=self.estimator,
            objective=self.objective,
        )
        object.__setattr__(self, "goal", task.goal)
        object.__setattr__(self, "goal_precision", task.goal_precision)
        object.__setattr__(self, "box_mass", task.box_mass)
        object.__setattr__(self, "bounds", _bounds(self.bounds))
        masses = RobustnessRequest(coeffs=(0.0,), masses=self.robustness_masses).masses
        object.__setattr__(self, "robustness_masses", masses)

    @property
    def degree(self) -> int:
        """Polynomial degree n: the number of coefficients."""
        return len(self.bounds or ())

    def tool_spec(self) -> Any:
        """The ``tooldesign_env.ToolSpec`` of the run: the paper's tool with ``degree`` n."""
        from tooldesign_env import ToolSpec

        spec = ToolSpec()
        return spec if spec.degree == self.degree else dataclasses.replace(spec, degree=self.degree)

    def task(self) -> TaskSettings:
        """The task and env settings every design of the run is scored with."""
        from tooldesign_env import ToolSpec, default_bounds

        extra: dict[str, Any] = {}
        if self.degree != ToolSpec().degree:
            extra["tool"] = self.tool_spec()
        if self.bounds != _bounds(default_bounds(self.degree)):
            extra["bounds"] = self.bounds
        return TaskSettings(
            goal=self.goal,
            goal_precision=self.goal_precision,
            box_mass=self.box_mass,
            estimator=self.estimator,
            objective=self.objective,
            env_kwargs=extra,
        )

    def to_json(self) -> dict[str, Any]:
        """The configuration as JSON values (settings as an object, tuples as lists)."""
        data = dataclasses.asdict(self)
        data["optimizer_settings"] = dict(self.optimizer_settings)
        return json.loads(json.dumps(data, allow_nan=False))


# --- results -----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class DesignResult:
    """The outcome of :func:`run_design`.

    Attributes:
        out_dir: The run folder.
        coefficients: (n,) the best design ``(c1, ..., cn)``.
        free_energy: F of the best design.
        goal_error: Goal-error term of F.
        confidence: Control-confidence term of F.
        final_distance: |X_T - X^g| in m.
        status: ``"ok"`` (or ``"invalid"`` if no design of the run was valid).
        iteration: 0-based iteration the best design was asked in.
        candidate: Its index in the batch.
        eval_id: The id the optimizer gave it.
        evaluations: The evaluation log (one row per evaluation, ``ResultStore.read`` format).
        robustness: ``robustness.json`` as a dict.
        card: ``design.json`` as a dict.
    """

    out_dir: Path
    coefficients: np.ndarray
    free_energy: float
    goal_error: float
    confidence: float
    final_distance: float
    status: str
    iteration: int
    candidate: int
    eval_id: int
    evaluations: pd.DataFrame
    robustness: dict[str, Any]
    card: dict[str, Any]


# --- the optimizer -----------------------------------------------------------------------------


def _make_optimizer(config: DesignConfig) -> Any:
    import optimizers

    # Unknown names raise ValueError naming the available ones; a missing backend raises an
    # ImportError naming the pip extra.
    return optimizers.make(
        config.optimizer,
        bounds=np.asarray(config.bounds, dtype=np.float64),
        batch_size=config.batch_size,
        seed=config.seed,
        **dict(config.optimizer_settings),
    )


def _ask(optimizer: Any, config: DesignConfig) -> tuple[np.ndarray, np.ndarray]:
    batch = optimizer.ask()
    ids = np.asarray(batch.ids)
    x = np.ascontiguousarray(batch.x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != config.degree or len(ids) != len(x) or len(x) == 0:
        raise RuntimeError(
            f"optimizer {config.optimizer!r} asked a batch of shape {x.shape} with {len(ids)} "
            f"ids; expected (batch, {config.degree}) with one id per row"
        )
    return ids.astype(np.int64), x


def _tell(optimizer: Any, ids: np.ndarray, values: np.ndarray, failed: np.ndarray) -> None:
    # Failed evaluations are told as failures (NaN): the optimizer decides what that means.
    told = np.where(failed, np.nan, values)
    optimizer.tell(ids.tolist(), told)


def _values(frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Scores to tell from logged rows: F for ``ok`` and ``invalid`` (the env's penalty F)."""
    failed = (frame["status"] == "failed").to_numpy() | ~np.isfinite(frame["free_energy"])
    return frame["free_energy"].to_numpy(dtype=np.float64), failed


def _coefficient_columns(degree: int) -> list[str]:
    return [f"c{i}" for i in range(1, degree + 1)]


def _replay(optimizer: Any, config: DesignConfig, logged: list[pd.DataFrame]) -> None:
    columns = _coefficient_columns(config.degree)
    for iteration, part in enumerate(logged):
        ids, x = _ask(optimizer, config)
        expected = np.ascontiguousarray(part[columns].to_numpy(dtype=np.float64))
        same_ids = np.array_equal(ids, part["eval_id"].to_numpy(dtype=np.int64))
        if x.shape != expected.shape or x.tobytes() != expected.tobytes() or not same_ids:
            raise ResumeError(
                f"cannot resume: replaying iteration {iteration}, optimizer {config.optimizer!r} "
                "asked other designs than the log holds (another optimizer version, settings or "
                "seed?); start a new run folder instead"
            )
        values, failed = _values(part)
        _tell(optimizer, ids, values, failed)


# --- the run folder ----------------------------------------------------------------------------


def _now() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc)


def _unit(config: DesignConfig, iteration: int) -> Unit:
    return Unit(
        suite=DESIGN_SUITE, optimizer=config.optimizer, seed=config.seed, iteration=iteration
    )


def _check_out_dir(out_dir: Any) -> Path:
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir must be a path, got {type(out_dir).__name__}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    return out


def _previous_session(out: Path, config: DesignConfig, resume: bool) -> dict[str, Any] | None:
    """The manifest of the run to continue, ``None`` for a new run; refuses to mix runs."""
    has_content = out.is_dir() and any(out.iterdir())
    if not has_content:
        return None
    if not resume:
        raise ValueError(
            f"--out {out} exists and is not empty; pass --resume to continue the run in it, or "
            "choose another folder"
        )
    try:
        manifest = read_manifest(out)
    except FileNotFoundError:
        raise ResumeError(
            f"cannot resume: {out} has no manifest.json, so it is not a design run folder"
        ) from None
    if manifest.get("format_version") != MANIFEST_VERSION:
        raise ResumeError(
            f"cannot resume: {out} was written by an incompatible version (manifest "
            f"format_version {manifest.get('format_version')!r}, this version writes "
            f"{MANIFEST_VERSION}); start a new run folder"
        )
    old = manifest.get("config", {})
    extra = manifest.get("extra")
    if (
        not isinstance(old, dict)
        or not isinstance(extra, dict)
        or extra.get("kind") != DESIGN_SUITE
    ):
        raise ResumeError(f"cannot resume: {out} holds a run of another kind")
    _verify_parts(out, extra)
    new = config.to_json()
    changed = sorted(k for k in new.keys() - _RUNTIME_FIELDS if old.get(k) != new[k])
    if changed:
        detail = ", ".join(f"{k}: {old.get(k)!r} -> {new[k]!r}" for k in changed)
        raise ResumeError(
            f"cannot resume: the run in {out} was made with other settings ({detail}); "
            "use the same settings or another folder"
        )
    return manifest


def _verify_parts(out: Path, extra: Mapping[str, Any]) -> None:
    """Refuse a run folder whose part files differ from what the manifest records.

    The manifest is rewritten after every part, so at most one part (the last, written just
    before a kill) may be missing from it; any other unrecorded part is refused too.
    """
    recorded = extra.get(PART_CHECKSUMS)
    if not isinstance(recorded, dict):
        raise ResumeError(
            f"cannot resume: {out / 'manifest.json'} records no part checksums "
            f"({PART_CHECKSUMS!r}): it was written by an incompatible version or edited"
        )
    try:
        verify_checksums(out, recorded)
    except ValueError as error:
        raise ResumeError(f"cannot resume: {error}") from None
    unrecorded = sorted(set(part_checksums(ResultStore(out))) - set(recorded))
    if len(unrecorded) > 1:
        raise ResumeError(
            f"cannot resume: {out} holds part files the manifest does not record: {unrecorded}"
        )


def _logged_iterations(store: ResultStore, config: DesignConfig) -> list[pd.DataFrame]:
    units = store.completed_units()
    mine = sorted(u.iteration for u in units if u == _unit(config, u.iteration))
    if len(mine) != len(units):
        raise ResumeError(f"cannot resume: {store.parts_dir} holds parts of other runs")
    if mine != list(range(len(mine))):
        raise ResumeError(f"cannot resume: iterations {mine} in {store.parts_dir} have gaps")
    if len(mine) > config.iterations:
        raise ResumeError(
            f"cannot resume: the run folder holds {len(mine)} iterations, more than "
            f"--iterations {config.iterations}"
        )
    if not mine:
        return []
    log = store.read()
    return [part for _, part in log.groupby("iteration", sort=True)]


def _batch_frame(
    config: DesignConfig,
    iteration: int,
    ids: np.ndarray,
    x: np.ndarray,
    rows: Sequence[Mapping[str, Any]],
    opt_time: float,
    *,
    suite: str = DESIGN_SUITE,
    variant: str = "",
    optimizer: str | None = None,
) -> pd.DataFrame:
    n = len(rows)
    data: dict[str, Any] = {
        "suite": [suite] * n,
        "optimizer": [config.optimizer if optimizer is None else optimizer] * n,
        "seed": [config.seed] * n,
        "iteration": [iteration] * n,
        "candidate": list(range(n)),
        "eval_id": ids.tolist(),
    }
    for j, name in enumerate(_coefficient_columns(config.degree)):
        data[name] = x[:, j]
    for name in METRIC_FIELDS:
        data[name] = [float(r[name]) for r in rows]
    data["status"] = [str(r["status"]) for r in rows]
    data["eval_time"] = [float(r["eval_time"]) for r in rows]
    data["opt_time"] = [opt_time] * n
    for axis, value in zip(("goal_x", "goal_y", "goal_z"), config.goal, strict=True):
        data[axis] = [value] * n
    data["goal_precision"] = [config.goal_precision] * n
    data["box_mass"] = [config.box_mass] * n
    data["variant"] = [variant] * n
    return pd.DataFrame(data)


def _manifest(
    config: DesignConfig,
    start_time: dt.datetime,
    sessions: list[dict[str, Any]],
    evaluations: pd.DataFrame | None,
    end_time: dt.datetime | None,
    store: ResultStore,
) -> dict[str, Any]:
    totals = timing_totals(evaluations) if evaluations is not None and len(evaluations) else {}
    return build_manifest(
        config=config.to_json(),
        start_time=start_time,
        end_time=end_time,
        wall_time=sum(s["wall_time"] for s in sessions),
        simulation_time=totals.get("simulation_time"),
        optimizer_time=totals.get("optimizer_time"),
        extra={
            "kind": DESIGN_SUITE,
            "sessions": sessions,
            PART_CHECKSUMS: part_checksums(store),
        },
    )


# --- one iteration at a time ------------------------------------------------------------------


class DesignStepper:
    """Algorithm 1 one iteration at a time, for a caller that evaluates the batches itself.

    :func:`run_design` drives one stepper with :func:`~benchmarks.evaluation.evaluate_batch`;
    ``benchmarks.runner`` drives many at once on one worker pool. The stepper owns the optimizer
    and the iteration count; the caller owns the executor and the store.

    Args:
        config: The run's designer, budget and task.
        suite: ``suite`` column of the rows it makes.
        variant: ``variant`` column of the rows it makes.
        label: ``optimizer`` column of the rows; ``config.optimizer`` if ``None``.

    Raises:
        ValueError: If the optimizer is unknown or its settings are invalid.
        ImportError: If the optimizer's backend is not installed (the message names the extra).
    """

    def __init__(
        self,
        config: DesignConfig,
        *,
        suite: str = DESIGN_SUITE,
        variant: str = "",
        label: str | None = None,
    ) -> None:
        self.config = config
        self.optimizer = _make_optimizer(config)
        self.iteration = 0
        self._suite, self._variant, self._label = suite, variant, label
        self._asked: tuple[np.ndarray, np.ndarray, float] | None = None

    def replay(self, logged: Sequence[pd.DataFrame]) -> None:
        """Ask and tell the logged iterations again, checking each ask against the log.

        Args:
            logged: The logged batches of iterations 0, 1, ..., in order.

        Raises:
            ResumeError: If the optimizer asks other designs than the log holds.
        """
        if self.iteration or self._asked is not None:
            raise RuntimeError("replay() must come before the first ask()")
        _replay(self.optimizer, self.config, list(logged))
        self.iteration = len(logged)

    def ask(self) -> np.ndarray:
        """The next batch: (batch_size, n) coefficients to evaluate, in order."""
        if self._asked is not None:
            raise RuntimeError("tell() the last batch before asking the next one")
        tick = time.perf_counter()
        ids, x = _ask(self.optimizer, self.config)
        self._asked = (ids, x, time.perf_counter() - tick)
        return x

    def tell(self, rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
        """Tell the evaluated batch and return its rows of the evaluation log.

        Args:
            rows: One row of :func:`~benchmarks.evaluation.evaluate_design` per asked design, in
                the asked order.

        Returns:
            The batch's evaluation-log rows, ``opt_time`` = (ask + tell time) / batch size.
        """
        if self._asked is None:
            raise RuntimeError("ask() a batch before telling it")
        ids, x, ask_time = self._asked
        if len(rows) != len(ids):
            raise ValueError(f"expected {len(ids)} evaluated rows, got {len(rows)}")
        frame = _batch_frame(
            self.config,
            self.iteration,
            ids,
            x,
            rows,
            0.0,
            suite=self._suite,
            variant=self._variant,
            optimizer=self._label,
        )
        values, failed = _values(frame)
        tick = time.perf_counter()
        _tell(self.optimizer, ids, values, failed)
        frame["opt_time"] = (ask_time + time.perf_counter() - tick) / len(ids)
        self._asked = None
        self.iteration += 1
        return frame


def best_evaluation(evaluations: pd.DataFrame) -> pd.Series:
    """The design of a run: its lowest-F ``ok`` evaluation (the first in log order on ties).

    Args:
        evaluations: The evaluation-log rows of one run, in log order.

    Returns:
        That row; the lowest-penalty ``invalid`` row (with a warning) if none is ``ok``.

    Raises:
        RuntimeError: If every evaluation failed.
    """
    return _best_row(evaluations)


# --- Algorithm 1 -------------------------------------------------------------------------------


def run_design(
    config: DesignConfig,
    out_dir: str | os.PathLike[str],
    *,
    resume: bool = False,
    progress: bool = True,
    video: bool = False,
) -> DesignResult:
    """Design a tool: K iterations of ask a batch, evaluate it, tell the scores (Algorithm 1).

    Args:
        config: The designer, budget, executor and task.
        out_dir: The run folder (see ``docs/design-runs.md``); created if absent.
        resume: Continue the interrupted (or finished) run in ``out_dir``. Only the runtime
            fields (``iterations`` (not fewer than are logged), ``workers``, ``executor``,
            ``scheduler``) may differ from the run's settings. A missing or empty folder starts
            a new run.
        progress: Show a tqdm progress bar (iteration, evaluations, best F) on stderr.
        video: Also write ``rollout.gif``, the best design's rollout rendered headless (about
            20 s more; ``tooldesign design`` does it unless ``--no-video``).

    Returns:
        The best design and what was written.

    Raises:
        TypeError: If ``config`` is not a :class:`DesignConfig` or ``out_dir`` not a path.
        ValueError: If ``out_dir`` is not empty and ``resume`` is false, the optimizer is
            unknown, or (:class:`ResumeError`) the folder cannot be resumed with ``config``.
        RuntimeError: If no design of the run could be evaluated at all.
    """
    if not isinstance(config, DesignConfig):
        raise TypeError(f"config must be a DesignConfig, got {type(config).__name__}")
    out = _check_out_dir(out_dir)
    session_start = time.perf_counter()
    session = {"start_time": _now().isoformat(), "wall_time": 0.0}
    previous = _previous_session(out, config, bool(resume))
    stepper = DesignStepper(config)
    store = ResultStore(out)
    if previous is None:
        start_time = _now()
        sessions: list[dict[str, Any]] = [session]
        store.write_manifest(_manifest(config, start_time, sessions, None, None, store))
    else:
        start_time = dt.datetime.fromisoformat(previous["start_time"])
        sessions = [*previous.get("extra", {}).get("sessions", []), session]
        # Only this process writes here; leftovers are from the interrupted session.
        store.remove_stale_temp_files()
        store.write_manifest(_manifest(config, start_time, sessions, None, None, store))
    logged = _logged_iterations(store, config)
    stepper.replay(logged)
    best = min((_best_ok(p) for p in logged), default=math.inf)
    evaluations_done = sum(len(p) for p in logged)
    task = config.task()

    from tqdm.auto import tqdm

    with make_executor(config.executor, config.workers, config.scheduler) as executor:
        bar = tqdm(
            total=config.iterations,
            initial=len(logged),
            desc=f"design {config.optimizer}",
            unit="it",
            disable=not progress,
            file=sys.stderr,
            dynamic_ncols=True,
        )
        try:
            bar.set_postfix(evals=evaluations_done, best_F=_fmt(best))
            for iteration in range(len(logged), config.iterations):
                x = stepper.ask()
                rows = evaluate_batch(executor, x, task)
                frame = stepper.tell(rows)
                store.write_batch(frame)
                _warn_failures(iteration, rows)
                best = min(best, _best_ok(frame))
                evaluations_done += len(frame)
                session["wall_time"] = time.perf_counter() - session_start
                store.write_manifest(_manifest(config, start_time, sessions, None, None, store))
                bar.set_postfix(evals=evaluations_done, best_F=_fmt(best), refresh=False)
                bar.update(1)
        finally:
            bar.close()
        evaluations = store.read()
        result = _finish(config, out, store, evaluations, executor, video=bool(video))
    session["wall_time"] = time.perf_counter() - session_start
    end_time = _now()
    manifest = _manifest(config, start_time, sessions, evaluations, end_time, store)
    store.write_manifest(manifest)
    card = _card(config, result, evaluations, manifest)
    atomic_write_text(out / FILES["card"], json_text(card))
    return dataclasses.replace(result, card=card)


def _best_ok(frame: pd.DataFrame) -> float:
    """Lowest finite F of the valid rows, inf if there is none."""
    energy = frame.loc[frame["status"] == "ok", "free_energy"].to_numpy(dtype=np.float64)
    energy = energy[np.isfinite(energy)]
    return float(energy.min()) if energy.size else math.inf


def _fmt(value: float) -> str:
    return f"{value:.6g}" if math.isfinite(value) else "-"


def _warn_failures(iteration: int, rows: Sequence[Mapping[str, Any]]) -> None:
    for candidate, row in enumerate(rows):
        if row["status"] == "failed":
            warnings.warn(
                f"iteration {iteration}, candidate {candidate} failed: {row['message']}",
                RuntimeWarning,
                stacklevel=3,
            )


# --- the finished run --------------------------------------------------------------------------


def _best_row(evaluations: pd.DataFrame) -> pd.Series:
    """The lowest-F valid evaluation (the first in log order on ties)."""
    finite = evaluations[np.isfinite(evaluations["free_energy"])]
    ok = finite[finite["status"] == "ok"]
    if len(ok):
        return ok.loc[ok["free_energy"].idxmin()]
    if len(finite):
        warnings.warn(
            "no design of the run was valid; the design card holds the lowest-penalty invalid one",
            RuntimeWarning,
            stacklevel=3,
        )
        return finite.loc[finite["free_energy"].idxmin()]
    raise RuntimeError(
        "no design of the run could be evaluated (every evaluation failed); see the status "
        "column of the evaluation log and the warnings above"
    )


def _iteration_bests(evaluations: pd.DataFrame) -> pd.DataFrame:
    """Per iteration, its lowest-F valid evaluation (iterations without one are left out)."""
    ok = evaluations[(evaluations["status"] == "ok") & np.isfinite(evaluations["free_energy"])]
    index = ok.groupby("iteration", sort=True)["free_energy"].idxmin()
    return ok.loc[index.to_numpy()].reset_index(drop=True)


def _coeffs(row: pd.Series, degree: int) -> np.ndarray:
    return row[_coefficient_columns(degree)].to_numpy(dtype=np.float64)


def _finish(
    config: DesignConfig,
    out: Path,
    store: ResultStore,
    evaluations: pd.DataFrame,
    executor: Any,
    *,
    video: bool = False,
) -> DesignResult:
    from tooldesign_env import export_mesh, make_tool, tool_urdf

    degree = config.degree
    best = _best_row(evaluations)
    coeffs = _coeffs(best, degree)
    geometry = make_tool(coeffs, config.tool_spec())
    export_mesh(geometry, out / FILES["stl"])
    export_mesh(geometry, out / FILES["obj"])
    atomic_write_text(out / FILES["urdf"], tool_urdf(geometry))
    store.consolidate(format="csv")  # a design run is small and read by people: CSV

    # The trajectories are not logged; the rollouts are deterministic, so simulate them again.
    bests = _iteration_bests(evaluations)
    designs = [_coeffs(row, degree) for _, row in bests.iterrows()]
    rows = evaluate_batch(executor, designs, config.task(), keep_trajectory=True)
    paths = [r.get("box_trajectory", np.zeros((0, 3))) for r in rows]
    robustness = _robustness(config, best, coeffs, executor)
    atomic_write_text(out / FILES["robustness"], json_text(_without_paths(robustness)))
    _figures(config, out, evaluations, bests, designs, paths, coeffs, best, robustness)
    if video and best["status"] == "ok":
        _video(config, coeffs, out / VIDEO_FILE)
    from benchmarks.html_report import write_html_report

    write_html_report(out)
    return DesignResult(
        out_dir=out,
        coefficients=coeffs,
        free_energy=float(best["free_energy"]),
        goal_error=float(best["goal_error"]),
        confidence=float(best["confidence"]),
        final_distance=float(best["final_distance"]),
        status=str(best["status"]),
        iteration=int(best["iteration"]),
        candidate=int(best["candidate"]),
        eval_id=int(best["eval_id"]),
        evaluations=evaluations,
        robustness=_without_paths(robustness),
        card={},
    )


def _video(config: DesignConfig, coeffs: np.ndarray, path: Path) -> None:
    from benchmarks.video import rollout_gif

    task = config.task()
    try:
        rollout_gif(
            coeffs,
            path,
            frames=24,
            goal=task.goal,
            goal_precision=task.goal_precision,
            box_mass=task.box_mass,
            estimator=task.estimator,
            objective_kind=task.objective,
            **dict(task.env_kwargs),
        )
    except Exception as exc:  # noqa: BLE001
        # The run's results are complete and stored; a picture that fails must not lose them.
        warnings.warn(f"rollout.gif not written: {type(exc).__name__}: {exc}", stacklevel=2)


def _robustness(
    config: DesignConfig, best: pd.Series, coeffs: np.ndarray, executor: Any
) -> dict[str, Any]:
    base: dict[str, Any] = {
        "coefficients": coeffs.tolist(),
        "nominal_mass": config.box_mass,
        "masses": list(config.robustness_masses),
        "goal": list(config.goal),
    }
    if best["status"] != "ok":
        return {
            **base,
            "robustness": None,
            "accuracy": None,
            "control_deviation": None,
            "error": "the best design is not valid, so it was not tested",
        }
    request = RobustnessRequest(
        coeffs=tuple(coeffs), task=config.task(), masses=config.robustness_masses
    )
    [(result, exc, _)] = map_robust(executor, evaluate_robustness_of_design, [request])
    if exc is not None:
        return {
            **base,
            "robustness": None,
            "accuracy": None,
            "control_deviation": None,
            "error": f"{type(exc).__name__}: {exc}",
        }
    return {**base, **result, "error": ""}


def _without_paths(robustness: Mapping[str, Any]) -> dict[str, Any]:
    return {
        k: v
        for k, v in robustness.items()
        if k not in ("nominal_box_trajectory", "box_trajectories")
    }


def _card(
    config: DesignConfig,
    result: DesignResult,
    evaluations: pd.DataFrame,
    manifest: Mapping[str, Any],
) -> dict[str, Any]:
    from tooldesign_env import make_tool

    geometry = make_tool(result.coefficients, config.tool_spec())
    counts = evaluations["status"].value_counts()
    return {
        "format_version": CARD_VERSION,
        "coefficients": result.coefficients.tolist(),
        "polynomial": "y = c1 x^n + ... + cn x (highest power first, constant term 0)",
        "free_energy": result.free_energy,
        "goal_error": result.goal_error,
        "confidence": result.confidence,
        "final_distance": result.final_distance,
        "status": result.status,
        "iteration": result.iteration,
        "candidate": result.candidate,
        "eval_id": result.eval_id,
        "tool": {
            "mass": float(geometry.mass),
            "arc_length": float(geometry.spec.arc_length),
            "handle_length": float(geometry.spec.handle_length),
            "section": float(geometry.spec.section),
            "min_radius_of_curvature": _finite_or_none(geometry.min_radius_of_curvature),
            "buildable": bool(geometry.buildable),
        },
        "robustness": {
            k: result.robustness.get(k)
            for k in ("robustness", "accuracy", "control_deviation", "masses")
        },
        "seed": config.seed,
        "config": config.to_json(),
        "evaluations": {
            "total": int(len(evaluations)),
            "iterations": int(evaluations["iteration"].nunique()),
            **{s: int(counts.get(s, 0)) for s in ("ok", "invalid", "failed")},
        },
        "packages": manifest["packages"],
        "git_commit": manifest["git_commit"],
        "start_time": manifest["start_time"],
        "end_time": manifest["end_time"],
        "wall_time": manifest["wall_time"],
        "simulation_time": manifest["simulation_time"],
        "optimizer_time": manifest["optimizer_time"],
        "files": dict(FILES),
    }


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


# --- figures -----------------------------------------------------------------------------------


def _iteration_colorbar(ax: Any, iterations: Sequence[int]) -> None:
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    if not len(iterations):
        return
    low, high = float(min(iterations)), float(max(iterations))
    mappable = ScalarMappable(
        Normalize(low, high if high > low else low + 1.0), colormaps["viridis"]
    )
    bar = ax.figure.colorbar(mappable, ax=ax, fraction=0.046, pad=0.04)
    bar.set_label("iteration")
    from matplotlib.ticker import MaxNLocator

    bar.locator = MaxNLocator(integer=True)
    bar.update_ticks()


def _best_index(bests: pd.DataFrame) -> int | None:
    """Position (in ``bests``) of the run's best design: the iteration best with the lowest F."""
    if not len(bests):
        return None
    return int(np.argmin(bests["free_energy"].to_numpy(dtype=float)))


def _panel_curves(
    ax: Any, designs: list[np.ndarray], bests: pd.DataFrame, labels: list[str] | None, spec: Any
) -> None:
    plots.plot_tool_shapes(
        ax, designs, labels, colors=plots.sequential_colors(len(designs)), spec=spec
    )
    k = _best_index(bests)
    if k is not None:
        plots.plot_tool_shapes(
            ax,
            [designs[k]],
            [f"best tool (iteration {int(bests['iteration'].iloc[k])})"],
            colors=["red"],
            linewidth=3.5,
            spec=spec,
        )
        ax.legend(frameon=False, fontsize="small")
    _iteration_colorbar(ax, bests["iteration"].tolist())
    ax.set_title("a) best tool of each iteration")


def _panel_free_energy(ax: Any, evaluations: pd.DataFrame, bests: pd.DataFrame) -> None:
    ok = evaluations[evaluations["status"] == "ok"]
    ax.plot(ok["iteration"], ok["free_energy"], "o", color="0.7", markersize=3, label="evaluations")
    ax.plot(
        bests["iteration"], bests["free_energy"], "o-", color="tab:blue", label="iteration best"
    )
    so_far = evaluations.groupby("iteration", sort=True)["best_so_far"].last()
    ax.step(so_far.index, so_far.to_numpy(), where="post", color="black", label="best so far")
    if len(bests) and len(ok):
        # Every evaluation stays visible. A bad candidate can score 100 times the good ones;
        # then a symmetric-log axis keeps the iteration bests readable without clipping it.
        low = float(ok["free_energy"].min())
        top = float(ok["free_energy"].max())
        spread = float(np.nanmax([bests["free_energy"].max(), low])) - low
        if top - low > 10.0 * max(spread, 1.0):
            ax.set_yscale("symlog", linthresh=max(abs(low), spread, 1.0))
        margin = 0.05 * max(top - low, abs(top), 1.0)
        ax.set_ylim(low - margin, top + margin)
    ax.set_xlabel("iteration")
    ax.set_ylabel("free energy F (dimensionless)")
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.grid(True, alpha=0.3)
    ax.legend(frameon=False, fontsize="small")
    ax.set_title("b) free energy per iteration")


def _panel_paths(
    ax: Any,
    paths: list[np.ndarray],
    bests: pd.DataFrame,
    labels: list[str] | None,
    goal: Sequence[float],
) -> None:
    plots.plot_box_paths(ax, paths, goal, labels, colors=plots.sequential_colors(len(paths)))
    k = _best_index(bests)
    if k is not None and len(paths[k]):
        path = np.asarray(paths[k])
        ax.plot(path[:, 0], path[:, 1], color="red", linewidth=3.0, label="best tool")
        ax.legend(frameon=False, fontsize="small")
    _iteration_colorbar(ax, bests["iteration"].tolist())
    ax.set_title("c) box paths of the best tools (top view)")


def _panel_tool(ax: Any, coeffs: np.ndarray, best: pd.Series, spec: Any) -> None:
    from matplotlib.patches import Polygon

    from tooldesign_env import make_tool

    geometry = make_tool(coeffs, spec)
    corners = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    for box in geometry.boxes:
        c, s = math.cos(box.yaw), math.sin(box.yaw)
        local = corners * np.asarray(box.half_extents)[:2]
        world = local @ np.array([[c, s], [-s, c]]) + np.asarray(box.center)[:2]
        ax.add_patch(Polygon(world, closed=True, facecolor="tab:orange", edgecolor="0.3", lw=0.5))
    plots.plot_tool_shapes(ax, [coeffs], colors=["black"], linewidth=0.8, spec=spec)
    text = ", ".join(f"{v:.3g}" for v in coeffs)
    ax.set_title(f"d) final tool: C = ({text}), F = {float(best['free_energy']):.4g}")


def _figures(
    config: DesignConfig,
    out: Path,
    evaluations: pd.DataFrame,
    bests: pd.DataFrame,
    designs: list[np.ndarray],
    paths: list[np.ndarray],
    coeffs: np.ndarray,
    best: pd.Series,
    robustness: Mapping[str, Any],
) -> None:
    spec = config.tool_spec()
    # The iterations are told apart by a colour bar (_iteration_colorbar), not a legend: a
    # legend of every iteration hides the plot, and one of the first and last says too little.
    labels = None
    panels = {
        "fig3a": lambda ax: _panel_curves(ax, designs, bests, labels, spec),
        "fig3b": lambda ax: _panel_free_energy(ax, evaluations, bests),
        "fig3c": lambda ax: _panel_paths(ax, paths, bests, labels, config.goal),
        "fig3d": lambda ax: _panel_tool(ax, coeffs, best, spec),
    }
    for key, draw in panels.items():
        figure, ax = plots.new_figure()
        draw(ax)
        plots.save_png(figure, out / FILES[key])
    figure, axes = plots.new_figure_grid(2, 2, figsize=(12.0, 9.0))
    for ax, draw in zip(axes.flat, panels.values(), strict=True):
        draw(ax)
    plots.save_png(figure, out / FILES["fig3"])

    figure, ax = plots.new_figure()
    if robustness.get("error"):
        ax.text(0.5, 0.5, f"not tested: {robustness['error']}", ha="center", va="center", wrap=True)
        ax.set_axis_off()
    else:
        masses = robustness["masses"]
        colors = ["black", *plots.sequential_colors(len(masses), "plasma")]
        labels = [f"m = {robustness['nominal_mass']:g} kg (nominal)"]
        labels += [f"m = {m:g} kg" for m in masses]
        trajectories = [robustness["nominal_box_trajectory"], *robustness["box_trajectories"]]
        plots.plot_box_paths(ax, trajectories, config.goal, labels, colors=colors)
        ax.set_title(
            f"robustness {robustness['robustness']:.4g} under box-mass changes\n"
            "(- sum over masses and control steps of the path deviation in m)",
            fontsize="medium",
        )
    plots.save_png(figure, out / FILES["robustness_png"])


# --- command line ------------------------------------------------------------------------------


def _setting(text: str) -> tuple[str, Any]:
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        value = json.loads(raw)
    except json.JSONDecodeError:
        value = raw  # a bare word is a string: --option method=lbfgs
    return key.strip(), value


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign design`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "design",
        help="design a tool: ask/evaluate/tell for K iterations (Algorithm 1)",
        description=(
            "Design a tool with an ask/tell optimizer (Algorithm 1 of the paper) and write a run "
            "folder: evaluation log, design card, meshes, Figure 3 panels, robustness test. "
            "See docs/design-runs.md."
        ),
    )
    defaults = DesignConfig.__dataclass_fields__
    from optimizers import registry

    parser.add_argument(
        "--optimizer",
        default="cmaes",
        metavar="NAME",
        help=f"optimizer: {', '.join(registry.available())}, an installed plugin's name, or "
        "'module:Class' (default: cmaes)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the optimizer (default: 0)")
    parser.add_argument(
        "--iterations",
        type=int,
        default=defaults["iterations"].default,
        metavar="K",
        help="iterations K (default: %(default)s)",
    )
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="run folder")
    parser.add_argument(
        "--batch-size",
        type=int,
        default=defaults["batch_size"].default,
        metavar="B",
        help="designs per iteration (default: %(default)s)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="W",
        help="worker processes (default: the number of CPUs)",
    )
    parser.add_argument(
        "--executor",
        choices=EXECUTORS,
        default="process",
        help="where designs are evaluated (default: process)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDR",
        help="Dask scheduler address, e.g. tcp://host:8786 (with --executor dask)",
    )
    add_task_arguments(parser)
    parser.add_argument(
        "--option",
        type=_setting,
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="optimizer setting (JSON value or word), repeatable, e.g. --option sigma0=0.3",
    )
    parser.add_argument("--resume", action="store_true", help="continue the run in --out")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--no-video", action="store_true", help="do not write rollout.gif (saves about 20 s)"
    )
    parser.set_defaults(run=_run)
    return parser


def config_from_args(args: argparse.Namespace) -> DesignConfig:
    """The :class:`DesignConfig` of parsed ``tooldesign design`` arguments."""
    settings = dict(args.option)
    if len(settings) != len(args.option):
        raise ValueError("--option: a KEY is given twice")
    return DesignConfig(
        optimizer=args.optimizer,
        optimizer_settings=settings,
        seed=args.seed,
        iterations=args.iterations,
        batch_size=args.batch_size,
        workers=args.workers,
        executor=args.executor,
        scheduler=args.scheduler,
        goal=tuple(args.goal),
        goal_precision=args.goal_precision,
        box_mass=args.box_mass,
        estimator=args.estimator,
        objective=args.objective,
    )


def _run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    result = run_design(
        config,
        args.out,
        resume=args.resume,
        progress=not args.no_progress,
        video=not args.no_video,
    )
    coeffs = ", ".join(repr(float(c)) for c in result.coefficients)
    print(
        f"best design: C = ({coeffs}), F = {result.free_energy!r} "
        f"(goal error {result.goal_error:.6g}, confidence {result.confidence:.6g}, "
        f"final distance {result.final_distance:.4g} m), iteration {result.iteration}, "
        f"candidate {result.candidate}\nrun folder: {result.out_dir}"
    )
    return 0
