"""Run a benchmark suite into one run folder: resumable, on a pool of workers, with a report.

:func:`run_suite` executes every design run of a :class:`~benchmarks.suites.SuiteConfig`
(Algorithm 1 per (task, variant, optimizer)) and writes one run folder::

    run_folder/
        manifest.json         the suite config, package versions, git commit, host, times
        parts/...             the evaluation log, one atomic part file per finished batch
        designs/variant=<v>/optimizer=<o>/seed=<n>.json
                              each run's design (its lowest-F valid evaluation) and the
                              final test of it (robustness metrics), once the run is done
        designs/.../seed=<n>.paths.json
                              its box paths (nominal mass, and each altered mass), if kept
        evaluations.parquet   the whole log (evaluations.csv without pyarrow), at the end
        report/               benchmarks.suite_reports.make_suite_report

Many runs are in flight at once: while the workers simulate one run's batch, the main process
asks and tells the optimizers of the others and writes their parts, so neither the optimizer
time (BO fits a Gaussian process per batch) nor the end of a batch leaves workers idle. Each
run's asks depend only on its own seed and told scores and every rollout is deterministic, so
the results do not depend on the interleaving, the executor or the number of workers.

Resume: a rerun of the same suite into the same folder skips every run whose design file is on
disk, replays the logged iterations of unfinished runs (each replayed ask must match the log
bit for bit, see :class:`~benchmarks.design.DesignStepper`) and goes on; a batch that was being
evaluated when the suite stopped is evaluated again. The final evaluation log and design files
equal those of an uninterrupted run apart from the timing fields (``eval_time``, ``opt_time``,
``test_time``).
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import datetime as dt
import json
import math
import os
import sys
import time
import urllib.parse
import warnings
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.design import DesignStepper, ResumeError, best_evaluation
from benchmarks.evaluation import (
    EXECUTORS,
    EvaluationRequest,
    RobustnessRequest,
    TaskSettings,
    evaluate_design,
    evaluate_robustness_of_design,
    make_executor,
    map_robust,
    outcome_row,
)
from benchmarks.storage import (
    ResultStore,
    atomic_write_text,
    build_manifest,
    json_text,
    read_manifest,
    timing_totals,
)
from benchmarks.suites import (
    BUILTIN_SUITES,
    RUNTIME_FIELDS,
    SIZES,
    RunSpec,
    SuiteConfig,
    builtin_suite,
    load_suite,
    suite_from_json,
)

__all__ = [
    "DESIGNS_DIR",
    "SUITE_KIND",
    "FinalTest",
    "SuiteResult",
    "add_parser",
    "design_path",
    "paths_path",
    "read_designs",
    "run_final_test",
    "run_suite",
    "suite_of_manifest",
    "summary_text",
]

SUITE_KIND = "suite"
"""``manifest.json`` ``extra.kind`` of a suite run folder."""

DESIGNS_DIR = "designs"
"""Folder of the per-run design files in a run folder."""

DESIGN_VERSION = 1
PATH_DECIMALS = 6
"""Box paths are stored in m rounded to 1 um: far below what a figure shows, half the bytes."""


# --- the final test of a run's design ----------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
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
        out.update(
            {
                k: result[k]
                for k in ("robustness", "accuracy", "control_deviation", "nominal_mass", "masses")
            }
        )
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
            "nominal": np.round(nominal, PATH_DECIMALS).tolist(),
            "perturbed": [np.round(p, PATH_DECIMALS).tolist() for p in perturbed],
        }
    out["test_time"] = time.perf_counter() - start
    return out


def _work(item: EvaluationRequest | FinalTest) -> dict[str, Any]:
    # One worker function for both kinds, so a broken pool is recovered in one place.
    if isinstance(item, FinalTest):
        return run_final_test(item)
    return evaluate_design(item)


# --- files of a run folder ---------------------------------------------------------------------


def _q(name: str) -> str:
    return urllib.parse.quote(name, safe="")


def design_path(run_folder: str | os.PathLike[str], spec: RunSpec) -> Path:
    """The design file of a run: ``designs/variant=<v>/optimizer=<o>/seed=<n>.json``."""
    return (
        Path(run_folder)
        / DESIGNS_DIR
        / f"variant={_q(spec.variant.name)}"
        / f"optimizer={_q(spec.optimizer.column)}"
        / f"seed={spec.task.seed}.json"
    )


def paths_path(design_file: str | os.PathLike[str]) -> Path:
    """The box-path file next to a design file (``seed=<n>.paths.json``)."""
    path = Path(design_file)
    return path.with_name(path.name.removesuffix(".json") + ".paths.json")


def suite_of_manifest(manifest: Mapping[str, Any]) -> SuiteConfig:
    """The :class:`~benchmarks.suites.SuiteConfig` recorded in a suite run folder's manifest.

    Raises:
        ValueError: If the manifest is not one of a suite run folder.
    """
    if manifest.get("extra", {}).get("kind") != SUITE_KIND or "config" not in manifest:
        raise ValueError("manifest.json is not the manifest of a suite run folder")
    return suite_from_json(manifest["config"], where="manifest.json config")


def read_designs(run_folder: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The design files of a run folder, in a fixed order (variant, optimizer, seed).

    Args:
        run_folder: A suite run folder.

    Returns:
        One dict per finished run (the JSON of its design file); ``paths`` is added, loaded from
        its paths file, when there is one. Empty if the folder has no ``designs/``.

    Raises:
        ValueError: If a design file is not valid JSON.
    """
    folder = Path(run_folder) / DESIGNS_DIR
    if not folder.is_dir():
        return []
    records = []
    for path in sorted(folder.rglob("seed=*.json")):
        if path.name.endswith(".paths.json") or path.name.startswith("."):
            continue
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            extra = paths_path(path)
            if extra.is_file():
                record["paths"] = json.loads(extra.read_text(encoding="utf-8"))
        except json.JSONDecodeError as err:
            raise ValueError(f"{path}: not a valid design file: {err}") from err
        records.append(record)
    order = {"variant": str, "optimizer": str, "seed": int}
    records.sort(key=lambda r: tuple(t(r.get(k, "")) for k, t in order.items()))
    return records


# --- the run folder's manifest -----------------------------------------------------------------


def _now() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc)


def _comparable(config: Mapping[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in config.items() if k not in RUNTIME_FIELDS}


def _previous_session(out: Path, config: SuiteConfig, resume: bool) -> dict[str, Any] | None:
    """The manifest of the suite to continue, ``None`` for a new one; refuses to mix suites."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    if not (out.is_dir() and any(out.iterdir())):
        return None
    if not resume:
        raise ValueError(f"--out {out} exists and is not empty; resume it or choose another folder")
    try:
        manifest = read_manifest(out)
    except FileNotFoundError:
        raise ResumeError(
            f"cannot resume: {out} is not empty and has no manifest.json, so it is not a suite "
            "run folder; choose another folder"
        ) from None
    if manifest.get("extra", {}).get("kind") != SUITE_KIND:
        raise ResumeError(f"cannot resume: {out} holds a run of another kind, not a suite")
    old = _comparable(manifest.get("config", {}))
    new = _comparable(config.to_json())
    changed = sorted(k for k in old.keys() | new.keys() if old.get(k) != new.get(k))
    if changed:
        raise ResumeError(
            f"cannot resume: {out} holds suite {manifest['config'].get('name')!r} made with other "
            f"settings (differences in: {', '.join(changed)}); use the same suite and size, or "
            "another folder"
        )
    return manifest


def _check_optimizers(config: SuiteConfig) -> None:
    """Make every optimizer once: a bad name, setting or backend stops before any file is made."""
    import optimizers

    bounds = np.asarray(config.bounds, dtype=np.float64)
    for spec in config.optimizers:
        try:
            optimizers.make(
                spec.name,
                bounds=bounds,
                batch_size=config.batch_size,
                seed=0,
                **dict(spec.settings),
            )
        except ImportError as err:
            raise ValueError(f"optimizer {spec.name!r} cannot be used: {err}") from err
        except (TypeError, ValueError) as err:
            raise type(err)(f"optimizer {spec.name!r}: {err}") from err


def _logged_frames(
    store: ResultStore, config: SuiteConfig, runs: Sequence[RunSpec]
) -> dict[tuple[str, str, str, int], list[pd.DataFrame]]:
    """The logged batches of every run, checked to be whole runs of this suite from iteration 0."""
    planned = {run.key for run in runs}
    iterations: dict[tuple[str, str, str, int], list[int]] = collections.defaultdict(list)
    for unit in store.completed_units():
        key = (unit.suite, unit.variant, unit.optimizer, unit.seed)
        if key not in planned:
            raise ResumeError(
                f"cannot resume: {store.parts_dir} holds parts of a run this suite does not plan "
                f"({unit}); use another folder"
            )
        iterations[key].append(unit.iteration)
    for key, done in iterations.items():
        if sorted(done) != list(range(len(done))) or len(done) > config.iterations:
            raise ResumeError(f"cannot resume: run {key} has logged iterations {sorted(done)}")
    if not iterations:
        return {}
    log = store.read()
    frames: dict[tuple[str, str, str, int], list[pd.DataFrame]] = {}
    for key, run in log.groupby(["suite", "variant", "optimizer", "seed"], sort=False):
        frames[tuple(key)] = [part for _, part in run.groupby("iteration", sort=True)]  # type: ignore[index]
    return frames


# --- the scheduler -----------------------------------------------------------------------------


@dataclasses.dataclass(eq=False)
class _Run:
    spec: RunSpec
    frames: list[pd.DataFrame]
    stepper: DesignStepper | None = None
    items: list[Any] = dataclasses.field(default_factory=list)
    futures: list[Future[Any]] = dataclasses.field(default_factory=list)
    submitted: float = 0.0
    testing: bool = False
    best: pd.Series | None = None


def _done_future(result: Any = None, exc: BaseException | None = None) -> Future[Any]:
    future: Future[Any] = Future()
    if exc is not None:
        future.set_exception(exc)
    else:
        future.set_result(result)
    return future


def _broken(future: Future[Any]) -> bool:
    return (
        future.done()
        and not future.cancelled()
        and isinstance(future.exception(), BrokenProcessPool)
    )


class _Scheduler:
    """Keeps up to ``max_active`` runs in flight on one executor, from the main thread."""

    def __init__(
        self,
        config: SuiteConfig,
        out: Path,
        store: ResultStore,
        executor: Executor,
        bar: Any,
        max_active: int,
        on_run_done: Callable[[], None],
        work: Callable[[Any], Any] = _work,
    ) -> None:
        self.config = config
        self.out = out
        self.store = store
        self.executor = executor
        self.bar = bar
        self.max_active = max_active
        self.on_run_done = on_run_done
        self.work = work  # the worker function; a test seam

    def run(self, pending: Sequence[RunSpec], logged: Mapping[Any, list[pd.DataFrame]]) -> None:
        queue = collections.deque(pending)
        active: list[_Run] = []
        while queue or active:
            while queue and len(active) < self.max_active:
                spec = queue.popleft()
                run = _Run(spec=spec, frames=list(logged.get(spec.key, [])))
                if self._start(run):
                    active.append(run)
            if not active:
                continue
            in_flight = [f for run in active for f in run.futures]
            wait(in_flight, return_when=FIRST_COMPLETED)
            if any(_broken(f) for f in in_flight):
                self._recover(active)
            for run in [r for r in active if all(f.done() for f in r.futures)]:
                if not self._advance(run):
                    active.remove(run)

    # one run

    def _start(self, run: _Run) -> bool:
        if len(run.frames) < self.config.iterations:
            run.stepper = DesignStepper(
                run.spec.design,
                suite=run.spec.suite,
                variant=run.spec.variant.name,
                label=run.spec.optimizer.column,
            )
            run.stepper.replay(run.frames)
            self._submit_batch(run)
            return True
        return self._submit_test(run)

    def _submit(self, run: _Run, items: list[Any]) -> None:
        run.items = items
        run.submitted = time.perf_counter()
        run.futures = [self.executor.submit(self.work, item) for item in items]

    def _submit_batch(self, run: _Run) -> None:
        assert run.stepper is not None
        task = run.spec.design.task()
        x = run.stepper.ask()
        self._submit(run, [EvaluationRequest(coeffs=row, task=task) for row in x])

    def _outcomes(self, run: _Run) -> list[tuple[Any, BaseException | None, float]]:
        outcomes: list[tuple[Any, BaseException | None, float]] = []
        for future in run.futures:
            try:
                outcomes.append((future.result(), None, time.perf_counter() - run.submitted))
            except Exception as exc:  # every failure becomes a "failed" row or a test error
                outcomes.append((None, exc, time.perf_counter() - run.submitted))
        return outcomes

    def _advance(self, run: _Run) -> bool:
        """Handle a run whose futures are all done; whether it is still in flight."""
        outcomes = self._outcomes(run)
        if run.testing:
            result, exc, _ = outcomes[0]
            self._finish(run, result, exc)
            return False
        assert run.stepper is not None
        rows = [outcome_row(*outcome) for outcome in outcomes]
        frame = run.stepper.tell(rows)
        self.store.write_batch(frame)
        for candidate, row in enumerate(rows):
            if row["status"] == "failed":
                warnings.warn(
                    f"run {run.spec.key}, iteration {run.stepper.iteration - 1}, candidate "
                    f"{candidate} failed: {row['message']}",
                    RuntimeWarning,
                    stacklevel=2,
                )
        run.frames.append(frame)
        self.bar.update(len(frame))
        if run.stepper.iteration < self.config.iterations:
            self._submit_batch(run)
            return True
        run.stepper = None  # the optimizer is not needed any more
        return self._submit_test(run)

    def _submit_test(self, run: _Run) -> bool:
        evaluations = pd.concat(run.frames, ignore_index=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # reported in the design file
            try:
                run.best = best_evaluation(evaluations)
            except RuntimeError:
                run.best = None
        wanted = self.config.test_robustness or self.config.keep_paths
        if not wanted or run.best is None or run.best["status"] != "ok":
            why = "" if not wanted else "the run has no valid design, so it was not tested"
            self._finish(run, None, RuntimeError(why) if why else None)
            return False
        coeffs = run.best[[f"c{i}" for i in range(1, run.spec.design.degree + 1)]]
        test = FinalTest(
            coeffs=tuple(float(c) for c in coeffs),
            task=run.spec.design.task(),
            masses=self.config.robustness_masses if self.config.test_robustness else None,  # type: ignore[arg-type]
            keep_paths=self.config.keep_paths,
        )
        run.testing = True
        self._submit(run, [test])
        return True

    def _finish(self, run: _Run, result: Any, exc: BaseException | None) -> None:
        record = _design_record(self.config, run, result, exc)
        target = design_path(self.out, run.spec)
        paths = record.pop("paths", None)
        if paths is not None:
            # Written first: the design file is the mark that the run is complete.
            paths_record = {
                "nominal_mass": self.config.box_mass,
                "masses": list(self.config.robustness_masses)
                if self.config.test_robustness
                else [],
                **paths,
            }
            atomic_write_text(paths_path(target), json_text(paths_record, compact=True))
        atomic_write_text(target, json_text(record))
        if run.testing:
            self.bar.update(_test_rollouts(self.config))
        self.on_run_done()

    # a worker died

    def _recover(self, active: list[_Run]) -> None:
        """Evaluate again, in a fresh pool, every item whose worker pool broke.

        A dying worker takes every pending call of the pool with it. All in-flight calls are
        awaited, then the broken ones are retried through ``map_robust``, which isolates a
        design that kills its worker again (it becomes a failure); the others succeed. So the
        outcome of a design does not depend on which designs shared the pool with it.
        """
        wait([f for run in active for f in run.futures])
        broken = [(run, i) for run in active for i, f in enumerate(run.futures) if _broken(f)]
        restart = getattr(self.executor, "restart", None)
        if not broken or restart is None:
            return
        restart()
        items = [run.items[i] for run, i in broken]
        for (run, i), (result, exc, _) in zip(
            broken, map_robust(self.executor, self.work, items), strict=True
        ):
            run.futures[i] = _done_future(result, exc)


def _test_rollouts(config: SuiteConfig) -> int:
    if config.test_robustness:
        return 1 + len(config.robustness_masses)
    return 1 if config.keep_paths else 0


def _design_record(
    config: SuiteConfig, run: _Run, result: Any, exc: BaseException | None
) -> dict[str, Any]:
    spec = run.spec
    evaluations = pd.concat(run.frames, ignore_index=True)
    counts = evaluations["status"].value_counts()
    record: dict[str, Any] = {
        "format_version": DESIGN_VERSION,
        "suite": spec.suite,
        "variant": spec.variant.name,
        "label": spec.variant.label,
        "optimizer": spec.optimizer.column,
        "optimizer_name": spec.optimizer.name,
        "seed": spec.task.seed,
        "task_index": spec.task.index,
        "goal": list(spec.design.goal),
        "goal_precision": spec.design.goal_precision,
        "box_mass": spec.design.box_mass,
        "evaluations": {
            "total": int(len(evaluations)),
            **{s: int(counts.get(s, 0)) for s in ("ok", "invalid", "failed")},
        },
    }
    best = run.best
    columns = [f"c{i}" for i in range(1, spec.design.degree + 1)]
    if best is None:
        record.update(dict.fromkeys(("coefficients", "status"), None))
    else:
        record["coefficients"] = [float(best[c]) for c in columns]
        for name in ("free_energy", "goal_error", "confidence", "final_distance"):
            record[name] = float(best[name])
        record["status"] = str(best["status"])
        for name in ("iteration", "candidate", "eval_id"):
            record[name] = int(best[name])
    test: dict[str, Any] | None = None
    if config.test_robustness or config.keep_paths:
        test = {"error": "" if exc is None else f"{type(exc).__name__}: {exc}"}
        if result is not None:
            test.update({k: v for k, v in result.items() if k not in ("paths", "test_time")})
            record["test_time"] = float(result["test_time"])
            if "paths" in result:
                record["paths"] = result["paths"]
    record["test"] = test
    return record


# --- the suite ---------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class SuiteResult:
    """What :func:`run_suite` did.

    Attributes:
        out_dir: The run folder.
        config: The suite.
        evaluations: The whole evaluation log (``ResultStore.read`` format).
        designs: One design record per run (see :func:`read_designs`).
        wall_time: s, summed over the sessions of the run folder.
        session_time: s, of this call.
        simulation_time: s of worker time: sum of ``eval_time`` of the log.
        test_time: s of worker time in the final tests of the designs.
        optimizer_time: s of ask + tell in the main process: sum of ``opt_time``.
        report: The report files written.
    """

    out_dir: Path
    config: SuiteConfig
    evaluations: pd.DataFrame
    designs: list[dict[str, Any]]
    wall_time: float
    session_time: float
    simulation_time: float
    test_time: float
    optimizer_time: float
    report: list[Path]


def _max_active(config: SuiteConfig) -> int:
    if config.executor == "serial":
        return 1
    workers = config.workers or os.cpu_count() or 1
    # Enough queued evaluations to keep twice the workers busy, plus one run being told.
    return max(2, math.ceil(2 * workers / config.batch_size) + 1)


def _manifest(
    config: SuiteConfig,
    start_time: dt.datetime,
    sessions: list[dict[str, Any]],
    end_time: dt.datetime | None,
    totals: Mapping[str, float],
    extra: Mapping[str, Any],
) -> dict[str, Any]:
    return build_manifest(
        config=config.to_json(),
        start_time=start_time,
        end_time=end_time,
        wall_time=sum(s["wall_time"] for s in sessions),
        simulation_time=totals.get("simulation_time"),
        optimizer_time=totals.get("optimizer_time"),
        extra={"kind": SUITE_KIND, "sessions": sessions, **extra},
    )


def run_suite(
    config: SuiteConfig,
    out_dir: str | os.PathLike[str],
    *,
    resume: bool = True,
    progress: bool = True,
    size: str | None = None,
    report: bool = True,
) -> SuiteResult:
    """Run every design run of a suite into one run folder, resuming what is there.

    Args:
        config: The suite.
        out_dir: The run folder; created if absent.
        resume: Continue the suite in a non-empty ``out_dir`` (made with the same config apart
            from executor, workers and scheduler); with ``False`` a non-empty folder is an error.
        progress: Show a progress bar (simulations, runs done) on stderr.
        size: The built-in size the config came from, recorded in the manifest.
        report: Write the report (``report/``) at the end.

    Returns:
        The log, the designs, the times and the report files.

    Raises:
        TypeError: If ``config`` is not a :class:`~benchmarks.suites.SuiteConfig`.
        ValueError: If an optimizer cannot be made, ``out_dir`` is a file or holds another run
            (:class:`~benchmarks.design.ResumeError`), or is not empty and ``resume`` is false.
    """
    if not isinstance(config, SuiteConfig):
        raise TypeError(f"config must be a SuiteConfig, got {type(config).__name__}")
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir must be a path, got {type(out_dir).__name__}")
    out = Path(out_dir)
    session_start = time.perf_counter()
    session: dict[str, Any] = {"start_time": _now().isoformat(), "wall_time": 0.0}
    _check_optimizers(config)
    previous = _previous_session(out, config, bool(resume))
    store = ResultStore(out)
    if previous is None:
        start_time = _now()
        sessions: list[dict[str, Any]] = [session]
    else:
        start_time = dt.datetime.fromisoformat(previous["start_time"])
        sessions = [*previous.get("extra", {}).get("sessions", []), session]
        store.remove_stale_temp_files()  # only this process writes here
    extra: dict[str, Any] = {
        "size": size,
        "runs": len(config.runs()),
        "planned_evaluations": config.evaluations(),
    }

    def checkpoint() -> None:
        session["wall_time"] = time.perf_counter() - session_start
        store.write_manifest(_manifest(config, start_time, sessions, None, {}, extra))

    checkpoint()
    runs = config.runs()
    logged = _logged_frames(store, config, runs)
    pending = [run for run in runs if not design_path(out, run).is_file()]
    done_tests = (len(runs) - len(pending)) * _test_rollouts(config)
    total = config.evaluations() + len(runs) * _test_rollouts(config)
    initial = sum(sum(len(f) for f in frames) for frames in logged.values()) + done_tests

    from tqdm.auto import tqdm

    bar = tqdm(
        total=total,
        initial=initial,
        desc=config.name,
        unit="sim",
        disable=not progress,
        file=sys.stderr,
        dynamic_ncols=True,
    )
    try:
        if pending:
            with make_executor(config.executor, config.workers, config.scheduler) as executor:
                finished = len(runs) - len(pending)

                def on_run_done() -> None:
                    nonlocal finished
                    finished += 1
                    bar.set_postfix(runs=f"{finished}/{len(runs)}", refresh=False)
                    checkpoint()

                scheduler = _Scheduler(
                    config, out, store, executor, bar, _max_active(config), on_run_done
                )
                scheduler.run(pending, logged)
    finally:
        bar.close()
        checkpoint()

    evaluations = store.read()
    store.consolidate()
    designs = read_designs(out)
    session["wall_time"] = time.perf_counter() - session_start
    totals = timing_totals(evaluations)
    test_time = float(sum(d.get("test_time") or 0.0 for d in designs))
    extra["test_time"] = test_time
    extra["load_average_at_end"] = _load_average()
    store.write_manifest(_manifest(config, start_time, sessions, _now(), totals, extra))
    files: list[Path] = []
    if report:
        from benchmarks.suite_reports import make_suite_report

        files = make_suite_report(out)
    return SuiteResult(
        out_dir=out,
        config=config,
        evaluations=evaluations,
        designs=designs,
        wall_time=float(sum(s["wall_time"] for s in sessions)),
        session_time=float(session["wall_time"]),
        simulation_time=totals["simulation_time"],
        test_time=test_time,
        optimizer_time=totals["optimizer_time"],
        report=files,
    )


def _load_average() -> str:
    # Other processes on the machine slow the workers down; a time is read with the load.
    try:
        return ", ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:  # pragma: no cover - not on every platform
        return "n/a"


def summary_text(result: SuiteResult) -> str:
    """What a finished suite prints: counts, total time and its split."""
    log = result.evaluations
    counts = log["status"].value_counts()
    workers = 1 if result.config.executor == "serial" else result.config.workers or os.cpu_count()
    busy = (result.simulation_time + result.test_time) / max(result.wall_time, 1e-9)
    lines = [
        f"suite {result.config.name}: {len(result.designs)} runs, {len(log)} evaluations "
        f"({int(counts.get('ok', 0))} ok, {int(counts.get('invalid', 0))} invalid, "
        f"{int(counts.get('failed', 0))} failed)",
        f"total time: {result.wall_time:.1f} s wall (this session {result.session_time:.1f} s), "
        f"executor {result.config.executor} with {workers} worker(s)",
        f"simulation: {result.simulation_time + result.test_time:.1f} s of worker time "
        f"(evaluations {result.simulation_time:.1f} s + final tests {result.test_time:.1f} s; "
        f"{busy:.2f} workers busy on average)",
        f"optimizer: {result.optimizer_time:.1f} s (ask + tell, in the main process)",
        f"load average (1, 5, 15 min) at the end: {_load_average()}",
        f"run folder: {result.out_dir}",
    ]
    if result.report:
        lines.append(f"report: {result.report[0].parent} ({len(result.report)} files)")
    lines.append(f"noise floor: tooldesign retest {result.out_dir}, then tooldesign report")
    return "\n".join(lines)


# --- command line ------------------------------------------------------------------------------


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign bench`` on the dispatcher's subparsers."""
    parser = subparsers.add_parser(
        "bench",
        help="run a benchmark suite (optimizers, precision-sweep, robustness, ...)",
        description=(
            "Run a benchmark suite into one run folder, resuming what is there, and write its "
            "report. See docs/benchmarks.md."
        ),
    )
    parser.add_argument(
        "suite",
        nargs="?",
        metavar="SUITE",
        help=f"a built-in suite: {', '.join(BUILTIN_SUITES)} (or omit it and give --config)",
    )
    parser.add_argument(
        "--size",
        default=None,
        help=f"size of the suite: {' or '.join(SIZES)} (default: full; a suite file may define "
        "its own)",
    )
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="run folder")
    parser.add_argument(
        "--config",
        type=Path,
        default=None,
        metavar="FILE",
        help="a suite file (.toml or .json); see docs/benchmarks.md",
    )
    parser.add_argument(
        "--workers", type=int, default=None, metavar="N", help="worker processes (default: CPUs)"
    )
    parser.add_argument(
        "--executor", choices=EXECUTORS, default=None, help="where designs are evaluated"
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDR",
        help="Dask scheduler address, e.g. tcp://host:8786 (implies --executor dask)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--dump-config",
        type=Path,
        default=None,
        metavar="FILE",
        help="write the resolved suite to FILE (.toml or .json) and exit without running",
    )
    parser.set_defaults(run=_run)
    return parser


def config_from_args(args: argparse.Namespace) -> SuiteConfig:
    """The suite of parsed ``tooldesign bench`` arguments."""
    if args.size is not None and args.size not in SIZES and args.config is None:
        raise ValueError(f"unknown size {args.size!r}; sizes: {', '.join(SIZES)}")
    if args.config is not None:
        config = load_suite(args.config, size=args.size)
        if args.suite is not None and args.suite != config.name:
            raise ValueError(
                f"SUITE {args.suite!r} does not match the name {config.name!r} in {args.config}; "
                "omit SUITE with --config"
            )
    elif args.suite is None:
        raise ValueError(f"give a SUITE ({', '.join(BUILTIN_SUITES)}) or --config FILE")
    else:
        config = builtin_suite(args.suite, args.size or "full")
    changes: dict[str, Any] = {}
    if args.workers is not None:
        changes["workers"] = args.workers
    if args.scheduler is not None:
        changes["scheduler"] = args.scheduler
        changes["executor"] = args.executor or "dask"
    if args.executor is not None:
        changes["executor"] = args.executor
    return config.replace(**changes) if changes else config


def _run(args: argparse.Namespace) -> int:
    config = config_from_args(args)
    if args.dump_config is not None:
        from benchmarks.suites import save_suite

        print(f"suite written to {save_suite(config, args.dump_config)}")
        return 0
    size = args.size or ("full" if args.config is None else None)
    result = run_suite(config, args.out, progress=not args.no_progress, size=size)
    print(summary_text(result))
    return 0
