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
        report/               written by benchmarks.reports.suite.make_suite_report

Many runs are in flight at once: while the workers simulate one run's batch, the main process
asks and tells the optimizers of the others and writes their parts, so neither the optimizer
time (BO fits a Gaussian process per batch) nor the end of a batch leaves workers idle. Each
run's asks depend only on its own seed and told scores and every rollout is deterministic, so
the results do not depend on the interleaving, the executor or the number of workers.

Resume: a rerun of the same suite into the same folder checks the folder first (the checksums
the manifest records, see :class:`~benchmarks.storage.RunSession`, and every design file, see
:func:`~benchmarks.storage.read_designs`), skips every run whose design file is on disk,
replays the logged iterations of unfinished runs (each replayed ask must match the log
bit for bit, see :class:`~benchmarks.design.DesignStepper`) and goes on; a batch that was being
evaluated when the suite stopped is evaluated again. The final evaluation log and design files
equal those of an uninterrupted run apart from the timing fields (``eval_time``, ``opt_time``,
``test_time``).

Each design file and its box-path file are recorded in the manifest's ``extra.file_sha256`` when
they are written; a design file on disk that the manifest does not list (written just before a
kill, ahead of the manifest, or by a version that recorded no design checksums) is checked for
its form and recorded by the session that resumes.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.design import DesignStepper, best_evaluation
from benchmarks.execution import (
    EvaluationRequest,
    FinalTest,
    Outcome,
    Scheduler,
    check_main_guard,
    evaluate_item,
    make_executor,
    outcome_row,
    usable_cpus,
)
from benchmarks.storage import (
    DESIGN_VERSION,
    ResultStore,
    ResumeError,
    RunSession,
    design_path,
    json_text,
    paths_path,
    read_designs,
)
from benchmarks.suites.config import (
    ADDED_FIELDS,
    GROWABLE_FIELDS,
    RUNTIME_FIELDS,
    SUITE_KIND,
    RunSpec,
    SuiteConfig,
)
from tooldesign_env.schema import (
    METRICS,
    RUN_COLUMNS,
    STANDING_COLUMNS,
    STATUSES,
    coefficient_columns,
)

__all__ = ["SuiteResult", "run_suite", "summary_text"]


def check_optimizers(config: SuiteConfig) -> None:
    """Make every optimizer of ``config`` once, as :func:`run_suite` does before any file.

    No simulation is built: this is the check ``tooldesign bench --dump-config`` makes before
    writing a suite file, so a file the run would refuse is refused when written.

    Raises:
        TypeError: an unknown setting, or a setting of the wrong type.
        ValueError: an unknown optimizer, a bad setting value, or a backend that cannot be
            imported (then ``__cause__`` is the ``ImportError``); each message names the
            optimizer.
    """
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
            raise type(err)(_naming(spec.name, err)) from err
        except OverflowError as err:  # a setting a backend cannot convert
            raise ValueError(f"optimizer {spec.name!r}: a setting is out of range: {err}") from err


def _naming(name: str, err: Exception) -> str:
    """``err``'s message, led by the optimizer's name unless it names it already."""
    text = str(err)
    # "unknown optimizer 'x'; available: ..." names it already: no "optimizer 'x': " before it.
    return text if f"optimizer {name!r}" in text else f"optimizer {name!r}: {text}"


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
    log = store.read(verify=False)  # the session verified the folder when it opened it
    frames: dict[tuple[str, str, str, int], list[pd.DataFrame]] = {}
    for key, run in log.groupby(list(RUN_COLUMNS), sort=False):
        frames[tuple(key)] = [part for _, part in run.groupby("iteration", sort=True)]
    return frames


# --- one design run, as a job of the scheduler -------------------------------------------------


class _RunJob:
    """One design run of the suite: its batches, then the test of its design, then its file.

    A :class:`~benchmarks.execution.Job` of the scheduler: ``start`` and ``advance`` return the
    next work items (evaluation requests, or the one final test), or ``None`` when the design
    file is written.
    """

    def __init__(
        self,
        spec: RunSpec,
        frames: list[pd.DataFrame],
        config: SuiteConfig,
        session: RunSession,
        bar: Any,
        on_done: Callable[[], None],
    ) -> None:
        self.spec = spec
        self.frames = frames
        self.config = config
        self.session = session
        self.bar = bar
        self.on_done = on_done
        self.stepper: DesignStepper | None = None
        self.testing = False
        self.best: pd.Series | None = None

    def start(self) -> list[Any] | None:
        if len(self.frames) < self.config.iterations:
            self.stepper = DesignStepper(
                self.spec.design,
                suite=self.spec.suite,
                variant=self.spec.variant.name,
                label=self.spec.optimizer.column,
            )
            self.stepper.replay(self.frames)
            return self._batch()
        return self._test()

    def advance(self, outcomes: list[Outcome]) -> list[Any] | None:
        if self.testing:
            result, exc, _ = outcomes[0]
            self._finish(result, exc)
            return None
        assert self.stepper is not None
        rows = [outcome_row(*outcome) for outcome in outcomes]
        frame = self.stepper.tell(rows)
        self.session.write_batch(frame)
        for candidate, row in enumerate(rows):
            if row["status"] == "failed":
                warnings.warn(
                    f"run {self.spec.key}, iteration {self.stepper.iteration - 1}, candidate "
                    f"{candidate} failed: {row['message']}",
                    RuntimeWarning,
                    stacklevel=2,
                )
        self.frames.append(frame)
        self.bar.update(len(frame))
        if self.stepper.iteration < self.config.iterations:
            return self._batch()
        self.stepper = None  # the optimizer is not needed any more
        return self._test()

    def _batch(self) -> list[Any]:
        assert self.stepper is not None
        task = self.spec.design.task()
        return [EvaluationRequest(coeffs=row, task=task) for row in self.stepper.ask()]

    def _test(self) -> list[Any] | None:
        evaluations = pd.concat(self.frames, ignore_index=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # reported in the design file
            try:
                self.best = best_evaluation(evaluations)
            except RuntimeError:
                self.best = None
        config = self.config
        wanted = config.test_robustness or config.keep_paths
        if not wanted or self.best is None or self.best["status"] != "ok":
            why = "" if not wanted else "the run has no valid design, so it was not tested"
            self._finish(None, RuntimeError(why) if why else None)
            return None
        coeffs = self.best[coefficient_columns(self.spec.design.degree)]
        test = FinalTest(
            coeffs=tuple(float(c) for c in coeffs),
            task=self.spec.design.task(),
            masses=tuple(config.robustness_masses) if config.test_robustness else None,
            keep_paths=config.keep_paths,
        )
        self.testing = True
        return [test]

    def _finish(self, result: Any, exc: BaseException | None) -> None:
        record = _design_record(self.config, self, result, exc)
        target = _design_file(self.session.out, self.spec)
        paths = record.pop("paths", None)
        if paths is not None:
            # Written first: the design file is the mark that the run is complete.
            masses = list(self.config.robustness_masses) if self.config.test_robustness else []
            paths_record = {"nominal_mass": self.config.box_mass, "masses": masses, **paths}
            self.session.write_file(paths_path(target), json_text(paths_record, compact=True))
        # Recorded in the manifest at the checkpoint of on_done.
        self.session.write_file(target, json_text(record))
        if self.testing:
            self.bar.update(_test_rollouts(self.config))
        self.on_done()


def _design_file(run_folder: Path, spec: RunSpec) -> Path:
    return design_path(
        run_folder, variant=spec.variant.name, optimizer=spec.optimizer.column, seed=spec.task.seed
    )


def _adopt_designs(session: RunSession, runs: Sequence[RunSpec]) -> list[RunSpec]:
    """The runs without a design file; the design files on disk checked and recorded.

    The session has verified the files the manifest records; :func:`read_designs` checks the
    form of every design file (and the recorded ones again). A design file the manifest does
    not list is recorded now, with its box-path file: one written just before a kill, or by a
    version that recorded no design checksums. A pending run's box-path file (written just
    before its design file) is not: it is written again.

    Raises:
        ResumeError: If a design file is malformed or differs from its recorded checksum.
    """
    try:
        if session.out.is_dir():  # a new session makes its folder at its first write
            read_designs(session.out)
    except ValueError as error:
        raise ResumeError(f"cannot resume: {error}") from None
    pending = []
    for run in runs:
        target = _design_file(session.out, run)
        extra = paths_path(target)
        if not target.is_file():
            session.forget_file(target)
            session.forget_file(extra)
            pending.append(run)
            continue
        for path in (target, extra):
            if path.is_file() and not session.is_recorded(path):
                session.record_file(path)
    return pending


def _test_rollouts(config: SuiteConfig) -> int:
    if config.test_robustness:
        return 1 + len(config.robustness_masses)
    return 1 if config.keep_paths else 0


def _design_record(
    config: SuiteConfig, run: _RunJob, result: Any, exc: BaseException | None
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
            **{s: int(counts.get(s, 0)) for s in STATUSES},
        },
    }
    best = run.best
    columns = coefficient_columns(spec.design.degree)
    if best is None:
        record.update(dict.fromkeys(("coefficients", "status"), None))
    else:
        record["coefficients"] = [float(best[c]) for c in columns]
        for name in METRICS:
            record[name] = float(best[name])
        for name in STANDING_COLUMNS:  # for the task's success test in reports
            if name in best.index and not math.isnan(float(best[name])):
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


def _max_active(config: SuiteConfig, executor: object = None) -> int:
    if config.executor == "serial":
        return 1
    # A Dask scheduler's cluster may have far more workers than this machine has CPUs.
    cluster = getattr(executor, "max_workers", None) if config.scheduler is not None else None
    workers = config.workers or cluster or usable_cpus()
    # Enough queued evaluations to keep twice the workers busy, plus one run being told.
    return max(2, math.ceil(2 * workers / config.batch_size) + 1)


def run_suite(
    config: SuiteConfig,
    out_dir: str | os.PathLike[str],
    *,
    resume: bool = True,
    progress: bool = True,
    size: str | None = None,
    own_files: Sequence[str | os.PathLike[str]] = (),
) -> SuiteResult:
    """Run every design run of a suite into one run folder, resuming what is there.

    The report is not written here: :func:`benchmarks.reports.suite.make_suite_report` makes it
    from the stored results (``tooldesign bench`` calls both).

    Args:
        config: The suite.
        out_dir: The run folder; created if absent.
        resume: Continue the suite in a non-empty ``out_dir`` (made with the same config apart
            from executor, workers, scheduler and max_retries); with ``False`` a non-empty
            folder is an error.
        progress: Show a progress bar (simulations, runs done) on stderr.
        size: The built-in size the config came from, recorded in the manifest.
        own_files: The user's files in ``out_dir`` that are not a run (the suite's own file,
            kept with its results): a folder holding only these is a new run folder.

    Returns:
        The log, the designs and the times.

    Raises:
        TypeError: If ``config`` is not a :class:`~benchmarks.suites.SuiteConfig`.
        ValueError: If an optimizer cannot be made, ``out_dir`` is a file or holds another run
            (:class:`~benchmarks.storage.ResumeError`), or is not empty and ``resume`` is false.
    """
    if not isinstance(config, SuiteConfig):
        raise TypeError(f"config must be a SuiteConfig, got {type(config).__name__}")
    check_optimizers(config)
    runs = config.runs()
    # Before the run folder is made: a script refused here, a missing dask or a scheduler that
    # does not answer leaves nothing, so the same call reruns cleanly once that is fixed.
    check_main_guard(config.executor, config.scheduler, function="run_suite")
    # The session checks the folder (refusing it changes nothing) before the executor is made,
    # and writes nothing before start(): a missing dask or a scheduler that does not answer
    # leaves nothing. Leaving the block on an error keeps the session's time and records.
    with RunSession(
        out_dir,
        kind=SUITE_KIND,
        config=config.to_json(),
        resume=bool(resume),
        runtime_fields=RUNTIME_FIELDS,
        growable_fields=GROWABLE_FIELDS,
        added_fields=ADDED_FIELDS,
        extra={"size": size, "runs": len(runs), "planned_evaluations": config.evaluations()},
        own_files=own_files,
    ) as session:
        out, store = session.out, session.store
        logged = _logged_frames(store, config, runs)
        pending = _adopt_designs(session, runs)
        with make_executor(
            config.executor, config.workers, config.scheduler, max_retries=config.max_retries
        ) as executor:
            session.start()
            _run_pending(config, runs, pending, logged, session, executor, progress)
        evaluations = store.read(verify=False)  # written or verified by this session
        store.consolidate()
        designs = read_designs(out)
        test_time = float(sum(d.get("test_time") or 0.0 for d in designs))
        session.update_extra(test_time=test_time, load_average_at_end=_load_average())
        manifest = session.finish(evaluations)
    return SuiteResult(
        out_dir=out,
        config=config,
        evaluations=evaluations,
        designs=designs,
        wall_time=float(manifest["wall_time"]),
        # read at the same moment as the total (the final manifest), not later
        session_time=float(manifest["extra"]["sessions"][-1]["wall_time"]),
        simulation_time=float(manifest["simulation_time"] or 0.0),
        test_time=test_time,
        optimizer_time=float(manifest["optimizer_time"] or 0.0),
    )


def _run_pending(
    config: SuiteConfig,
    runs: Sequence[RunSpec],
    pending: Sequence[RunSpec],
    logged: dict[tuple[str, str, str, int], list[pd.DataFrame]],
    session: RunSession,
    executor: Any,
    progress: bool,
) -> None:
    """Run the pending runs on the executor, with a progress bar; each batch is one part."""
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
    finished = len(runs) - len(pending)

    def on_run_done() -> None:
        nonlocal finished
        finished += 1
        bar.set_postfix(runs=f"{finished}/{len(runs)}", refresh=False)
        session.checkpoint()

    with bar:
        if pending:
            jobs = [
                _RunJob(spec, list(logged.get(spec.key, [])), config, session, bar, on_run_done)
                for spec in pending
            ]
            Scheduler(executor, evaluate_item, _max_active(config, executor)).run(jobs)


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
    config = result.config
    if config.scheduler is not None:
        # Its workers may come and go during a run; how many threads it had is not stored.
        executor = f"executor dask on the Dask cluster at {config.scheduler}"
    else:
        workers = 1 if config.executor == "serial" else config.workers or usable_cpus()
        executor = f"executor {config.executor} with {workers} worker(s)"
    busy = (result.simulation_time + result.test_time) / max(result.wall_time, 1e-9)
    lines = [
        f"suite {result.config.name}: {len(result.designs)} runs, {len(log)} evaluations "
        f"({int(counts.get('ok', 0))} ok, {int(counts.get('invalid', 0))} invalid, "
        f"{int(counts.get('failed', 0))} failed)",
        f"total time: {result.wall_time:.1f} s wall (this session {result.session_time:.1f} s), "
        f"{executor}",
        f"simulation: {result.simulation_time + result.test_time:.1f} s of worker time "
        f"(evaluations {result.simulation_time:.1f} s + final tests {result.test_time:.1f} s; "
        f"{busy:.2f} workers busy on average)",
        f"optimizer: {result.optimizer_time:.1f} s (ask + tell, in the main process)",
        f"load average (1, 5, 15 min) at the end: {_load_average()}",
        f"run folder: {result.out_dir}",
    ]
    lines.append(f"noise floor: tooldesign retest {result.out_dir}, then tooldesign report")
    return "\n".join(lines)
