"""Algorithm 1 of the paper, resumable: ask a batch of tools, evaluate them, tell, repeat.

``tooldesign design`` (and :func:`run_design`) runs the designer (an ask/tell optimizer from
:mod:`optimizers`, CMA-ES by default), the user and the evaluator (``ToolDesign-v0`` through an
executor of :mod:`benchmarks.execution`) for K iterations, and writes a run folder: the
evaluation log, the best design's card and meshes, the robustness test of the final tool and the
box paths the figures draw. The panels of the paper's Figure 3 and ``report.html`` are drawn
from those files by :func:`benchmarks.reports.write_design_report` (``tooldesign design`` calls
both). ``docs/design-runs.md`` documents the folder.

Resume: every finished iteration is one atomic part file of the evaluation log (see
:mod:`benchmarks.storage`), written after the optimizer was told its scores. A resumed run makes
the optimizer again from the seed and replays the logged iterations: each replayed ask must equal
the logged coefficients and ids bit for bit (else :class:`~benchmarks.storage.ResumeError`),
and is told the logged scores. The run then goes on as if it had never stopped, so an
interrupted and resumed run gives the same evaluation log and the same design as an
uninterrupted one.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from benchmarks.design.config import ADDED_FIELDS, DESIGN_SUITE, RUNTIME_FIELDS, DesignConfig
from benchmarks.design.progress import phase
from benchmarks.design.stepper import DesignStepper, best_evaluation, iteration_bests
from benchmarks.design.success import (
    SUCCESS_COLUMN,
    evaluation_successes,
    evaluations_success,
)
from benchmarks.execution import (
    RobustnessRequest,
    check_main_guard,
    evaluate_batch,
    evaluate_robustness_of_design,
    make_executor,
    map_robust,
)
from benchmarks.storage import (
    DESIGN_RUN_FILES,
    ResultStore,
    ResumeError,
    RunSession,
    atomic_write_text,
    check_out_dir,
    json_text,
)
from benchmarks.storage.runfolder import record_report_files
from tooldesign_env.schema import (
    METRICS,
    ROBUSTNESS_METRICS,
    STANDING_COLUMNS,
    STATUSES,
    coefficient_columns,
    rounded_path,
)

__all__ = ["CARD_VERSION", "DesignResult", "run_design"]

CARD_VERSION = 1

"""``format_version`` of ``design.json``."""

#: The files of :data:`DESIGN_RUN_FILES` that every session writes again at its end and whose
#: SHA-256 the manifest records (``tooldesign report`` and a resume refuse them changed).
REWRITTEN_FILES = ("card", "robustness", "box_paths")


"""The best design's rollout (``run_design(video=True)``, ``tooldesign design`` by default)."""


#: Key in the manifest's ``extra``: ``{part path relative to the run folder: sha256}``.
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
        straight_tool: The straight tool's (C = 0) F, terms and status on the same task, as
            ``design.json`` stores them under ``straight_tool``.
        success: Whether the best (lowest-F) design succeeded on the run's task (the env's
            ``info["success"]``: usable, and the box ends standing within the task's tolerance
            of the goal); None if its outcome is not stored. A lower F is not a success.
        successes: How many of the run's evaluations succeeded.
        success_known: How many evaluations have a known outcome (all, unless some were logged
            without their final pose).
        best_succeeding: The lowest-F evaluation that succeeded, as ``design.json`` stores it
            under ``best_succeeding`` (coefficients, F and its terms, final distance, where in
            the log); None if none did.
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
    straight_tool: dict[str, Any] = dataclasses.field(default_factory=dict)
    success: bool | None = None
    successes: int = 0
    success_known: int = 0
    best_succeeding: dict[str, Any] | None = None


def _logged_iterations(
    store: ResultStore, config: DesignConfig, stepper: DesignStepper
) -> list[pd.DataFrame]:
    units = store.completed_units()
    mine = sorted(u.iteration for u in units if u == stepper.unit(u.iteration))
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
    log = store.read(verify=False)  # the session verified the folder when it opened it
    return [part for _, part in log.groupby("iteration", sort=True)]


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
            ``scheduler``, ``max_retries``) may differ from the run's settings. A missing or
            empty folder starts a new run.
        progress: Show a tqdm progress bar (iteration, evaluations, best F) on stderr.
        video: Also write ``rollout.gif``, the best design's rollout rendered headless (about
            20 s more; ``tooldesign design`` does it unless ``--no-video``).

    Returns:
        The best design and what was written.

    Raises:
        TypeError: If ``config`` is not a :class:`DesignConfig` or ``out_dir`` not a path.
        ValueError: If ``out_dir`` is not empty and ``resume`` is false, the optimizer is
            unknown, or (:class:`ResumeError`) the folder cannot be resumed with ``config``.
        NothingEvaluated: (a RuntimeError) If no design of the run could be evaluated at all.
    """
    if not isinstance(config, DesignConfig):
        raise TypeError(f"config must be a DesignConfig, got {type(config).__name__}")
    # Before the run folder is made: a script refused here, a missing dask or a scheduler that
    # does not answer leaves nothing, so the same call reruns cleanly once that is fixed.
    check_main_guard(config.executor, config.scheduler, function="run_design")
    out = check_out_dir(out_dir)
    # The session checks the folder (and refuses it, changing nothing) before the executor is
    # made; it writes nothing before start(), so a missing dask or a scheduler that does not
    # answer leaves nothing either. Leaving the block on an error keeps the session's time.
    with RunSession(
        out,
        kind=DESIGN_SUITE,
        config=config.to_json(),
        resume=bool(resume),
        runtime_fields=RUNTIME_FIELDS,
        added_fields=ADDED_FIELDS,
        # Every session writes these again at its end (see RunSession's rewritten_files).
        rewritten_files=[out / DESIGN_RUN_FILES[name] for name in REWRITTEN_FILES],
    ) as session:
        store = session.store
        stepper = DesignStepper(config)
        logged = _logged_iterations(store, config, stepper)
        with make_executor(
            config.executor, config.workers, config.scheduler, max_retries=config.max_retries
        ) as executor:
            session.start()
            evaluations = _iterate(config, session, stepper, logged, executor, progress)
            what = "meshes, box paths and robustness test of the final tool"
            with phase(f"design {config.optimizer}: {what}", enabled=progress):
                result = _finish(config, out, store, evaluations, executor)
            for name in ("robustness", "box_paths"):
                session.record_file(out / DESIGN_RUN_FILES[name])  # in the manifest of finish()
        manifest = session.finish(evaluations)  # the card and the GIF come after
        card = _card(config, result, evaluations, manifest)
        # The session has written its last manifest: the card's checksum is added to it.
        session.write_file(out / DESIGN_RUN_FILES["card"], json_text(card))
        if video and result.status == "ok":
            with phase(f"design {config.optimizer}: rendering rollout.gif", enabled=progress):
                if _video(config, result.coefficients, out / DESIGN_RUN_FILES["video"]):
                    # A figure made from the card: recorded as the report's files are.
                    record_report_files(out, [out / DESIGN_RUN_FILES["video"]])
    return dataclasses.replace(result, card=card)


def _iterate(
    config: DesignConfig,
    session: RunSession,
    stepper: DesignStepper,
    logged: list[pd.DataFrame],
    executor: Any,
    progress: bool,
) -> pd.DataFrame:
    """Replay the logged iterations, run the others (one part each); the whole log."""
    stepper.replay(logged)
    best = min((_best_ok(p) for p in logged), default=math.inf)
    evaluations_done = sum(len(p) for p in logged)
    task = config.task()
    judge = _success_judge(config)

    from tqdm.auto import tqdm

    bar = tqdm(
        total=config.iterations,
        initial=len(logged),
        desc=f"design {config.optimizer}",
        unit="it",
        disable=not progress,
        file=sys.stderr,
        dynamic_ncols=True,
    )
    with bar:
        bar.set_postfix(evals=evaluations_done, best_F=_fmt(best))
        for iteration in range(len(logged), config.iterations):
            x = stepper.ask()
            rows = evaluate_batch(executor, x, task)
            frame = stepper.tell(rows)
            frame[SUCCESS_COLUMN] = judge(frame)
            session.write_batch(frame)
            _warn_failures(iteration, rows)
            best = min(best, _best_ok(frame))
            evaluations_done += len(frame)
            bar.set_postfix(evals=evaluations_done, best_F=_fmt(best), refresh=False)
            bar.update(1)
    return session.store.read(verify=False)  # written or verified by this session


def _success_judge(config: DesignConfig) -> Any:
    """A function of a batch's rows: each row's success (1.0, 0.0, NaN if unknown).

    The task's own test (``TaskDefinition.succeeded``, as the env's ``info["success"]``) on the
    row's stored final pose, in the run's scene (the task's with the run's ``scene``
    overrides): the column says for every evaluation what ``info["success"]`` said.
    """
    from tooldesign_env.tasks import get_task

    definition, scene = get_task(config.task_name), config.task_scene()

    def judge(frame: pd.DataFrame) -> list[float]:
        outcomes = evaluation_successes(frame, definition, scene=scene)
        return [math.nan if o is None else float(o) for o in outcomes]

    return judge


def _success_summary(
    config: DesignConfig, evaluations: pd.DataFrame, best: pd.Series
) -> dict[str, Any]:
    """The best design's success, the count of succeeding evaluations and the lowest-F one."""
    from tooldesign_env.tasks import get_task

    definition, scene = get_task(config.task_name), config.task_scene()
    [success] = evaluation_successes(pd.DataFrame([best]), definition, scene=scene)
    summary = evaluations_success(evaluations, definition, scene=scene)
    entry = None
    if summary.best is not None:
        row = summary.best
        entry = {"coefficients": _coeffs(row, config.degree).tolist()}
        for key in METRICS:
            entry[key] = float(row[key])
        standing = {c: float(row[c]) for c in STANDING_COLUMNS if c in row.index}
        if len(standing) == len(STANDING_COLUMNS) and all(map(math.isfinite, standing.values())):
            entry.update(standing)
        entry.update(
            iteration=int(row["iteration"]),
            candidate=int(row["candidate"]),
            eval_id=int(row["eval_id"]),
        )
    return {
        "success": success,
        "successes": summary.successes,
        "success_known": summary.n,
        "best_succeeding": entry,
    }


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


def _coeffs(row: pd.Series, degree: int) -> np.ndarray:
    return cast("np.ndarray", row[coefficient_columns(degree)].to_numpy(dtype=np.float64))


def _finish(
    config: DesignConfig,
    out: Path,
    store: ResultStore,
    evaluations: pd.DataFrame,
    executor: Any,
) -> DesignResult:
    from tooldesign_env import export_mesh, make_tool, tool_urdf

    degree = config.degree
    best = best_evaluation(evaluations)
    coeffs = _coeffs(best, degree)
    geometry = make_tool(coeffs, config.tool_spec())
    export_mesh(geometry, out / DESIGN_RUN_FILES["stl"])
    export_mesh(geometry, out / DESIGN_RUN_FILES["obj"])
    atomic_write_text(out / DESIGN_RUN_FILES["urdf"], tool_urdf(geometry))
    store.consolidate(format="csv")  # a design run is small and read by people: CSV

    # The trajectories are not logged; the rollouts are deterministic, so simulate them again
    # and store them for the figures (which are made from stored files only).
    bests = iteration_bests(evaluations)
    designs = [_coeffs(row, degree) for _, row in bests.iterrows()]
    # The straight tool (C = 0) in the same batch: the yardstick report.html sets the design
    # beside, scored on the run's own task.
    rows = evaluate_batch(
        executor, [*designs, np.zeros(degree)], config.task(), keep_trajectory=True
    )
    straight = _straight_tool(rows.pop(), degree)
    robustness = _robustness(config, best, coeffs, executor)
    atomic_write_text(out / DESIGN_RUN_FILES["robustness"], json_text(_without_paths(robustness)))
    paths = {
        "iterations": [int(i) for i in bests["iteration"]],
        "iteration_bests": [rounded_path(r.get("box_trajectory", np.zeros((0, 3)))) for r in rows],
        "nominal_mass": config.box_mass,
        "masses": list(config.robustness_masses),
        "nominal": rounded_path(robustness.get("nominal_box_trajectory", np.zeros((0, 3)))),
        "perturbed": [rounded_path(x) for x in robustness.get("box_trajectories", [])],
    }
    atomic_write_text(out / DESIGN_RUN_FILES["box_paths"], json_text(paths, compact=True))
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
        straight_tool=straight,
        **_success_summary(config, evaluations, best),
    )


def _straight_tool(row: Mapping[str, Any], degree: int) -> dict[str, Any]:
    """The straight tool's entry of ``design.json``: its F, terms and status on the run's task."""
    entry: dict[str, Any] = {"coefficients": [0.0] * degree}
    for key in ("free_energy", "goal_error", "confidence", "final_distance"):
        value = float(row.get(key, math.nan))
        entry[key] = value if math.isfinite(value) else None
    standing = {c: float(row.get(c, math.nan)) for c in STANDING_COLUMNS if row.get(c) is not None}
    if len(standing) == len(STANDING_COLUMNS) and all(map(math.isfinite, standing.values())):
        entry.update(standing)  # for the task's success test
    entry["status"] = str(row.get("status", "failed"))
    entry["message"] = str(row.get("message") or "")
    return entry


def _video(config: DesignConfig, coeffs: np.ndarray, path: Path) -> bool:
    """Write the rollout GIF; whether it was written (a failure is warned about)."""
    from benchmarks.design.video import rollout_gif

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
        return False
    return True


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
        **_standing_of(evaluations, result.iteration, result.candidate),
        "format_version": CARD_VERSION,
        "coefficients": result.coefficients.tolist(),
        "polynomial": "y = c1 x^n + ... + cn x (highest power first, constant term 0)",
        "free_energy": result.free_energy,
        "goal_error": result.goal_error,
        "confidence": result.confidence,
        "final_distance": result.final_distance,
        "status": result.status,
        "success": result.success,
        "best_succeeding": result.best_succeeding,
        "iteration": result.iteration,
        "candidate": result.candidate,
        "eval_id": result.eval_id,
        "tool": {
            "mass": float(geometry.mass),
            "arc_length": float(geometry.spec.arc_length),
            "handle_length": float(geometry.spec.handle_length),
            "section": float(geometry.spec.section),
            "section_shape": geometry.spec.section_shape,
            "min_radius_of_curvature": _finite_or_none(geometry.min_radius_of_curvature),
            "buildable": bool(geometry.buildable),
        },
        "robustness": {k: result.robustness.get(k) for k in (*ROBUSTNESS_METRICS, "masses")},
        "straight_tool": result.straight_tool,
        "seed": config.seed,
        "config": config.to_json(),
        "evaluations": {
            "total": int(len(evaluations)),
            "iterations": int(evaluations["iteration"].nunique()),
            **{s: int(counts.get(s, 0)) for s in STATUSES},
            "succeeded": result.successes,
            "success_unknown": int(len(evaluations)) - result.success_known,
        },
        "packages": manifest["packages"],
        "git_commit": manifest["git_commit"],
        "start_time": manifest["start_time"],
        "end_time": manifest["end_time"],
        "wall_time": manifest["wall_time"],
        "simulation_time": manifest["simulation_time"],
        "optimizer_time": manifest["optimizer_time"],
        "files": dict(DESIGN_RUN_FILES),
    }


def _standing_of(evaluations: pd.DataFrame, iteration: int, candidate: int) -> dict[str, float]:
    """The best row's ``final_height`` (m) and ``final_tilt`` (rad), for the success test.

    {} where the log does not store them (a resumed old run) or they are not finite.
    """
    if not all(c in evaluations.columns for c in STANDING_COLUMNS):
        return {}
    rows = evaluations[
        (evaluations["iteration"] == iteration) & (evaluations["candidate"] == candidate)
    ]
    if len(rows) != 1:
        return {}
    values = {c: float(rows[c].iloc[0]) for c in STANDING_COLUMNS}
    return values if all(math.isfinite(v) for v in values.values()) else {}


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None
