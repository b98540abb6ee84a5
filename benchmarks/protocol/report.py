"""The protocol's report: measures, statistics and ECDFs of one or more protocol run folders.

:func:`make_protocol_report` reads the stored evaluations of every cell of every given folder
(a user's run beside the committed built-ins' folder: the folders must share the protocol's
instances, degrees, seeds and budgets, and no optimizer may appear twice), measures them
against the references (:mod:`benchmarks.protocol.measures`) and writes::

    report/
        report.md                 the tables below, and the figures
        ecdf_d<d>.png, ecdf_pooled.png
                                  ECDFs of runtimes over instances x targets (x seeds), with
                                  bootstrapped 95 % bands over instances
        runtimes.csv              one row per (optimizer, instance, d, seed, target)
        runs.csv                  one row per run: AUC of its ECDF, normalized regret at budgets
        references.csv            per cell: F_ref, noise floor, straight tool, random sampling,
                                  the ladder's quality (floor as % of F_ref and of the span,
                                  ``weak ladder``)
        comparisons.csv, ranks.csv, power.csv
                                  per d and pooled ("all"); comparisons.csv has, besides the
                                  score's test, the final-F difference f_diff [f_diff_low,
                                  f_diff_high], the floor, beyond_floor and told_apart

A run's score is the area under its own ECDF over its instance's targets (in [0, 1], higher
is better); the comparisons, the ranking and the power analysis use it
(:mod:`benchmarks.protocol.statistics`). Pooled over dimensions, an instance's (instance, d)
blocks are not independent: its score (and its final F) is the mean over its blocks
(:func:`~benchmarks.protocol.statistics.cluster_runs`), the paired test pairs instances, and
the ranking and the pooled ECDF's band resample instances, each with all its blocks. A pair is
*told apart* only when its Holm p is below alpha and its final-F difference is beyond the noise
floor (:mod:`benchmarks.protocol.effects`); each statistics section opens with a verdict
sentence built from its tables.

With the task axis (``ProtocolConfig.tasks``), the sections above are the first task's (push,
when it is run), as before; :mod:`benchmarks.protocol.task_report` adds a section per other
task and one pooled over tasks, ``ecdf_<task>.png`` and ``ecdf_tasks.png``, and the tables gain
a ``task`` column. A push-only report is what it was before the axis existed.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from benchmarks.protocol.effects import (
    compare_with_floor,
    instance_floors,
    section_floor,
    separation_sentence,
)
from benchmarks.protocol.measures import (
    best_so_far,
    bootstrap_ecdf,
    ecdf_area,
    expected_best_of_random,
    expected_running_time,
    normalized_regret,
    runtimes,
    target_ladder,
)
from benchmarks.protocol.references import load_references, packaged_references
from benchmarks.protocol.statistics import (
    WEAK_LADDER_FRACTION,
    cluster_runs,
    held_out_gap,
    ladder_quality,
    min_instances,
    power_analysis,
    rank_stability,
    weak_cell_sensitivity,
)
from benchmarks.protocol.suite import (
    PROTOCOL_FILE,
    ProtocolConfig,
    cell_folder,
    check_mergeable,
    protocol_record,
    read_protocol,
    write_protocol_record,
)
from benchmarks.protocol.task_report import REFERENCE_SUCCESS_NOTE, references_shown
from benchmarks.reports.success import (
    design_succeeded,
    has_standing,
    success_cell,
    success_criterion,
    success_rate,
    success_sentence,
    task_tolerance,
)
from tooldesign_env.schema import STANDING_COLUMNS

if TYPE_CHECKING:
    from tooldesign_env.tasks import TaskDefinition

__all__ = [
    "N_TARGETS",
    "REFERENCES_IN_FOLDER",
    "find_references",
    "folder_references",
    "load_runs",
    "make_protocol_report",
    "measure_runs",
    "record_references",
]

#: The references a run folder may hold (``tooldesign bench protocol --with-references``).
REFERENCES_IN_FOLDER = "references.json"

#: Targets per (instance, d).
N_TARGETS = 10

#: Budgets of the regret table, as fractions of the run budget.
REGRET_FRACTIONS: tuple[float, ...] = (0.25, 0.5, 1.0)


def load_runs(folder: str | os.PathLike[str]) -> tuple[ProtocolConfig, pd.DataFrame]:
    """The evaluations of every cell of a protocol run folder, one row per evaluation.

    Returns:
        The config, and a frame with ``optimizer``, ``task``, ``instance`` (its label:
        ``"i01"``, ``"hook/i01"``), ``instance_number``, ``set``, ``degree``, ``seed``,
        ``evaluation`` (1-based within its run), ``free_energy`` (NaN if failed), ``status``,
        ``final_distance`` (m, NaN where not stored), ``final_height`` (m) and ``final_tilt``
        (rad) where any cell stores them (NaN in the rows of a cell that does not; no such
        columns when none does) and ``c1..cd``.

    Raises:
        ValueError: If the folder is not a protocol run folder or a cell has no results.
    """
    from benchmarks.storage import ResultStore, refuse_links

    # A folder may come from someone else (a --baseline): a linked cell or table could make
    # this read any file of the machine.
    refuse_links(folder)
    config = read_protocol(folder)
    frames = []
    for instance, degree in config.cells():
        path = cell_folder(folder, instance, degree)
        if not (path / "manifest.json").is_file():
            raise ValueError(
                f"{path} has no results: run the protocol into {folder} first (it resumes)"
            )
        log = ResultStore(path).read()
        log = log.sort_values(["optimizer", "seed", "iteration", "candidate"], kind="stable")
        sizes = log.groupby(["optimizer", "seed"]).size()
        wanted = len(config.optimizers) * config.n_seeds
        if len(sizes) != wanted or not (sizes == config.budget(degree)).all():
            raise ValueError(
                f"{path} is unfinished ({len(sizes)} of {wanted} runs started, "
                f"{int(sizes.sum())} of {wanted * config.budget(degree)} evaluations): resume it "
                "with the command that made it"
            )
        log["evaluation"] = log.groupby(["optimizer", "seed"]).cumcount() + 1
        f = log["free_energy"].where(log["status"] != "failed")
        columns = [f"c{k}" for k in range(1, degree + 1)]
        # The box's final height and tilt, where the cell stores them (for the task's whole
        # success test); a cell stored before has no such columns, and its frame is as it was.
        standing = {c: log[c].to_numpy(dtype=float) for c in STANDING_COLUMNS if c in log.columns}
        frames.append(
            pd.DataFrame(
                {
                    "optimizer": log["optimizer"].astype(str).to_numpy(),
                    "task": instance.task,
                    "instance": instance.label,
                    "instance_number": instance.number,
                    "set": instance.set,
                    "degree": degree,
                    "seed": log["seed"].to_numpy(),
                    "evaluation": log["evaluation"].to_numpy(),
                    "free_energy": f.to_numpy(dtype=float),
                    "status": log["status"].astype(str).to_numpy(),
                    "final_distance": (
                        log["final_distance"].to_numpy(dtype=float)
                        if "final_distance" in log.columns
                        else np.full(len(log), np.nan)
                    ),
                    **standing,
                    **{c: log[c].to_numpy(dtype=float) for c in columns},
                }
            )
        )
    return config, pd.concat(frames, ignore_index=True)


def measure_runs(
    runs: pd.DataFrame,
    references: dict[tuple[str, int], dict[str, Any]],
    budgets: dict[int, int],
    *,
    n_targets: int = N_TARGETS,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Runtimes to every target and per-run scores.

    Args:
        runs: From :func:`load_runs` (one or more folders concatenated).
        references: From :func:`~benchmarks.protocol.references.load_references`.
        budgets: Run budget (evaluations) per degree.
        n_targets: Targets per cell.

    Returns:
        ``(runtimes, scores)``: one row per (optimizer, instance, d, seed, target) with
        ``task`` (push where ``runs`` has no such column), ``target``, ``runtime`` (inf if
        censored), ``budget``; one row per run with ``score`` (the area under its ECDF),
        ``final_f``, and per fraction of the budget in :data:`REGRET_FRACTIONS`
        ``regret_<fraction>`` and ``success_<fraction>``: whether the best design so far
        succeeded (True, False, or None where ``final_distance`` is not stored;
        :mod:`benchmarks.reports.success`: the run's task's whole test where the height and
        tilt are stored, its tolerance alone where not).

    Raises:
        ValueError: If a cell has no reference.
    """
    rows, scores = [], []
    for (instance, degree), cell in runs.groupby(["instance", "degree"], sort=True):
        ref = references.get((str(instance), int(degree)))
        if ref is None:
            tasks = [str(t) for t in dict.fromkeys(runs["task"])] if "task" in runs else []
            named = "" if set(tasks) <= {"push"} else f" --tasks {' '.join(tasks)}"
            raise ValueError(
                f"no reference for instance {instance} at d = {degree}; compute them with "
                f"`tooldesign bench protocol --references --size SIZE{named} --out FILE.json` "
                "and pass --reference-file FILE.json (or run with --with-references)"
            )
        f_ref = float(ref["f_ref"])
        pool = np.asarray(ref["random_pool"], dtype=float)
        budget = int(budgets[int(degree)])
        if budget >= pool.size:
            raise ValueError(
                f"the reference of {instance} at d = {degree} has a random pool of {pool.size} "
                f"designs; it needs more than the run budget {budget}"
            )
        targets = target_ladder(f_ref, float(np.median(pool)), float(ref["noise_floor"]), n_targets)
        checkpoints = [max(1, round(fr * budget)) for fr in REGRET_FRACTIONS]
        f_random = expected_best_of_random(pool, np.array(checkpoints))
        task = str(cell["task"].iloc[0]) if "task" in cell.columns else "push"
        criterion = success_criterion(task)
        for (optimizer, seed), run in cell.groupby(["optimizer", "seed"], sort=True):
            run = run.sort_values("evaluation")
            f = run["free_energy"].to_numpy(dtype=float)
            times = runtimes(f, targets)
            best = best_so_far(f)
            record: dict[str, Any] = {
                "optimizer": optimizer,
                "task": task,
                "instance": instance,
                "set": run["set"].iloc[0],
                "degree": int(degree),
                "seed": int(seed),
                "evaluations": len(f),
                "score": ecdf_area(times, budget) if targets.size else math.nan,
                "final_f": float(best[-1]) if best.size else math.nan,
            }
            at = np.array([best[min(c, len(best)) - 1] for c in checkpoints])
            # Undefined where random sampling is as good as the reference (no scale).
            scaled = f_random > f_ref
            regret = np.full(len(checkpoints), math.nan)
            if scaled.any():
                regret[scaled] = normalized_regret(at[scaled], f_ref, f_random[scaled])
            for fraction, value in zip(REGRET_FRACTIONS, regret, strict=True):
                record[f"regret_{fraction:g}"] = float(value)
            for fraction, checkpoint in zip(REGRET_FRACTIONS, checkpoints, strict=True):
                record[f"success_{fraction:g}"] = _best_succeeded(run, checkpoint, criterion)
            scores.append(record)
            for k, (target, time) in enumerate(zip(targets, times, strict=True)):
                rows.append(
                    {
                        "optimizer": optimizer,
                        "task": task,
                        "instance": instance,
                        "degree": int(degree),
                        "seed": int(seed),
                        "target_index": k,
                        "target": float(target),
                        "runtime": float(time),
                        "budget": budget,
                    }
                )
    return pd.DataFrame(rows), pd.DataFrame(scores)


def _best_succeeded(
    run: pd.DataFrame, evaluations: int, criterion: float | TaskDefinition
) -> bool | None:
    """Whether the lowest-F design among a run's first ``evaluations`` succeeded.

    ``criterion``: the run's task, whose whole test (radius, resting height, tilt) applies
    where the run stores ``final_height`` and ``final_tilt``, its radius alone where not; or
    a bare radius in m (:func:`~benchmarks.reports.success.design_succeeded`).
    """
    f = run["free_energy"].to_numpy(dtype=float)[:evaluations]
    finite = np.where(np.isnan(f), np.inf, f)
    if not f.size or np.isinf(finite).all():
        return False  # no design with an F: nothing usable
    best = int(np.argmin(finite))  # the first of equal lowest F, as best_so_far keeps it
    status = run["status"].iloc[best] if "status" in run.columns else "ok"
    distance, height, tilt = (
        run[c].iloc[best] if c in run.columns else None
        for c in ("final_distance", "final_height", "final_tilt")
    )
    return design_succeeded(status, distance, criterion, height, tilt)


def _merge(folders: Sequence[str | os.PathLike[str]]) -> tuple[ProtocolConfig, pd.DataFrame]:
    if not folders:
        raise ValueError("give at least one protocol run folder")
    loaded = [load_runs(folder) for folder in folders]
    # The rule `tooldesign bench protocol --baseline` checks before running (one function).
    check_mergeable([(folder, config) for folder, (config, _) in zip(folders, loaded, strict=True)])
    return loaded[0][0], pd.concat([runs for _, runs in loaded], ignore_index=True)


def _ecdf_figure(times: pd.DataFrame, title: str, path: Path) -> None:
    from benchmarks.reports.comparison import new_figure
    from benchmarks.reports.plots import save_png

    figure, ax = new_figure((6.0, 4.0))
    # Budgets in evaluations / d, as COCO plots them; runs of all degrees share the x axis.
    relative = times.assign(x=times["runtime"] / times["degree"])
    top = float((times["budget"] / times["degree"]).max())
    grid = np.geomspace(1.0 / times["degree"].max(), top, 200)
    for optimizer, frame in relative.groupby("optimizer", sort=True):
        blocks = list(frame.groupby(["instance", "degree"]))
        groups = [g["x"].to_numpy() for _, g in blocks]
        # An instance's blocks (its d) are resampled together: they are not independent.
        clusters = [instance for (instance, _), _ in blocks]
        est, low, high = bootstrap_ecdf(groups, grid, resamples=500, rng=0, clusters=clusters)
        (line,) = ax.step(grid, est, where="post", label=str(optimizer))
        ax.fill_between(grid, low, high, step="post", alpha=0.2, color=line.get_color())
    ax.set_xscale("log")
    ax.set_ylim(0, 1)
    ax.set_xlabel("evaluations / d")
    ax.set_ylabel("fraction of (instance, target, seed) reached")
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize="small")
    save_png(figure, path)


def _md_table(frame: pd.DataFrame, floatfmt: str = ".3g") -> str:
    def cell(v: Any) -> str:
        if isinstance(v, (float, np.floating)):
            return "inf" if np.isinf(v) else ("" if np.isnan(v) else format(float(v), floatfmt))
        return str(v)

    head = "| " + " | ".join(str(c) for c in frame.columns) + " |"
    rule = "|" + "---|" * len(frame.columns)
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([head, rule, *body])


def _auc_table(scores: pd.DataFrame, by: str) -> pd.DataFrame:
    from benchmarks.reports.stats import t_interval

    rows = []
    for (group, optimizer), frame in scores.groupby([by, "optimizer"], sort=True):
        # An instance's blocks (its d) share its goal, mass and friction: the interval runs
        # over instances, each the mean of its blocks' means, as the pooled statistics do.
        blocks = frame.groupby(["instance", "degree"])["score"].mean()
        per = blocks.groupby(level="instance").mean().to_numpy()
        interval = t_interval(per, 0.95)  # the percentile bootstrap under-covers few instances
        # One instance has no interval (t_interval gives low = high = the value): say so.
        bounds = (interval.low, interval.high) if interval.n >= 2 else ("n/a", "n/a")
        rows.append(
            {
                by: group,
                "optimizer": optimizer,
                "AUC": interval.estimate,
                "95% low": bounds[0],
                "95% high": bounds[1],
                "final regret (median)": frame["regret_1"].median(),
                "success": success_cell(success_rate(frame["success_1"])),
                "runs": len(frame),
            }
        )
    return pd.DataFrame(rows)


def _reference_table(
    refs: dict[tuple[str, int], dict[str, Any]], config: ProtocolConfig, budgets: dict[int, int]
) -> pd.DataFrame:
    rows = []
    for instance, degree in config.cells():
        ref = refs.get((instance.label, degree))
        if ref is None:
            continue  # measure_runs has refused a run without a reference already
        pool = np.asarray(ref["random_pool"], dtype=float)
        f_ref, floor = float(ref["f_ref"]), float(ref["noise_floor"])
        median = float(np.median(pool))
        at_budget = float(expected_best_of_random(pool, np.array([budgets[degree]]))[0])
        quality = ladder_quality(f_ref, median, floor, at_budget)
        rows.append(
            {
                "task": instance.task,
                "d": degree,
                "instance": instance.label,
                "set": instance.set,
                "F_ref": f_ref,
                "noise floor": floor,
                "final distance (m)": float(ref["final_distance"]),
                "F straight": float(ref["f_straight"]),
                "F random median": median,
                "F_random(budget)": at_budget,
                "found by": str(ref["method"]),
                "floor % of F_ref": quality["floor_pct_ref"],
                "floor / span": quality["floor_share"],
                "weak ladder": quality["weak"],
            }
        )
    return pd.DataFrame(rows)


#: What the references table's success column says, and what it cannot.
def _ladder_section(scores: pd.DataFrame, references: pd.DataFrame, alpha: float) -> list[str]:
    """The "ladder quality" part: the weak cells, and the verdicts without them."""
    weak = references[references["weak ladder"].astype(bool)]
    lines = [
        "## Ladder quality",
        "",
        "A cell's target ladder is weak when its reference's noise floor exceeds "
        f"{WEAK_LADDER_FRACTION:g} of the ladder's span (median random F - F_ref) or random "
        "sampling's expected best at the budget, F_random(budget), already reaches the last "
        "target (F_ref + floor): its targets then lie in a narrow band that every optimizer "
        "reaches, and the cell adds ties rather than information. It comes from a reference "
        "that is the luckiest of thousands of noisy draws (docs/protocol.md, References).",
        "",
    ]
    if weak.empty:
        return [*lines, f"No weak cell among the {len(references)} of this run.", ""]
    shown = weak[
        ["d", "instance", "F_ref", "noise floor", "floor % of F_ref", "floor / span",
         "F random median", "F_random(budget)"]
    ]  # fmt: skip
    cells = [(str(i), int(d)) for i, d in zip(weak["instance"], weak["d"], strict=True)]
    comparisons, ranking = weak_cell_sensitivity(scores, cells, alpha=alpha)
    lines += [
        f"{len(weak)} of {len(references)} cells are weak:",
        "",
        _md_table(shown.reset_index(drop=True), ".4g"),
        "",
        "Sensitivity: each dimension's comparisons (Holm p, significant at alpha = "
        f"{alpha:g}) and ranking (by mean score) on every cell and without the weak cells; "
        'pooled ("all"), instances with their blocks averaged.',
        "",
    ]
    if comparisons.empty:
        return [*lines, "Fewer than two optimizers or instances: no comparison.", ""]
    changed = comparisons[comparisons["changed"].astype(bool)]
    reordered = ranking[ranking["changed"].astype(bool)]

    def group(d: str) -> str:
        return "pooled" if d == "all" else f"d = {d}"

    if changed.empty:
        sentence = "Without the weak cells no pair's verdict (significant or not) changes"
    else:
        sentence = "Without the weak cells these verdicts change: " + "; ".join(
            f"{r.a} vs {r.b} at {group(str(r.d))} ("
            f"{'significant' if r.significant else 'not significant'} -> "
            f"{'significant' if r.significant_without else 'not significant'})"
            for r in changed.itertuples()
        )
    if reordered.empty:
        sentence += ", and no ranking does."
    else:
        where = ", ".join(group(str(d)) for d in reordered["d"])
        sentence += f"; the ranking by mean score changes at {where}."
    return [
        *lines,
        _md_table(comparisons),
        "",
        _md_table(ranking),
        "",
        sentence,
        "",
    ]


def _ert_table(times: pd.DataFrame) -> pd.DataFrame:
    rows = []
    n = times["target_index"].max() + 1
    chosen = sorted({0, n // 2, n - 1})
    for (degree, optimizer), frame in times.groupby(["degree", "optimizer"], sort=True):
        row: dict[str, Any] = {"d": degree, "optimizer": optimizer}
        for k in chosen:
            at = frame[frame["target_index"] == k]
            erts = [
                expected_running_time(g["runtime"], g["budget"]) for _, g in at.groupby("instance")
            ]
            solved = np.isfinite(erts).mean() if erts else math.nan
            row[f"ERT target {k + 1} (median)"] = float(np.median(erts)) if erts else math.nan
            # COCO's aRT: the runs of all instances pooled (evaluations spent / successes).
            row[f"aRT target {k + 1} (pooled)"] = (
                expected_running_time(at["runtime"], at["budget"]) if len(at) else math.nan
            )
            row[f"instances solved, target {k + 1}"] = solved
        rows.append(row)
    return pd.DataFrame(rows)


def folder_references(folder: str | os.PathLike[str]) -> tuple[Path, str] | None:
    """A run folder's ``references.json`` and the SHA-256 its ``protocol.json`` records.

    ``None`` if the folder has no ``references.json``.

    Raises:
        ValueError: It has one that ``protocol.json`` does not record (it was not computed by
            ``--with-references`` in this folder: it is not trusted).
    """
    path = Path(folder) / REFERENCES_IN_FOLDER
    if not os.path.lexists(path):
        return None
    digest = protocol_record(folder).get("references_sha256")
    if digest is None:
        raise ValueError(
            f"{path} is not recorded in {Path(folder) / PROTOCOL_FILE} (no references_sha256): "
            "it was not computed into this folder by --with-references; if you trust it, pass "
            "it with --reference-file, else remove it and compute them again"
        )
    return path, str(digest)


def record_references(folder: str | os.PathLike[str]) -> str:
    """Record the SHA-256 of the folder's ``references.json`` in its ``protocol.json``.

    Returns:
        The SHA-256 (hex).
    """
    from benchmarks.storage import run_file_sha256

    digest = run_file_sha256(folder, REFERENCES_IN_FOLDER)
    write_protocol_record(folder, read_protocol(folder), references_sha256=digest)
    return digest


def find_references(
    folders: Sequence[str | os.PathLike[str]], size: str
) -> str | os.PathLike[str] | None:
    """The references a report uses by default.

    The first run folder's ``references.json`` (``--with-references`` writes it and records its
    SHA-256 in ``protocol.json``), else the committed ones of the size, else ``None``.

    Raises:
        ValueError: A folder's ``references.json`` is not recorded (:func:`folder_references`).
    """
    for folder in folders:
        found = folder_references(folder)
        if found is not None:
            return found[0]
    return packaged_references(size)


def _shown_references(path: str | os.PathLike[str], size: str) -> str:
    """The references' path as a report shows it.

    The committed ones by their place in the package (``benchmarks/protocol/data/...``), not by
    where it is installed on this machine.
    """
    packaged = packaged_references(size)
    if packaged is not None and Path(path).resolve() == packaged.resolve():
        return f"benchmarks/protocol/data/{packaged.name}"
    return str(path)


def make_protocol_report(
    folders: Sequence[str | os.PathLike[str]],
    out_dir: str | os.PathLike[str] | None = None,
    *,
    references: str | os.PathLike[str] | None = None,
    alpha: float = 0.01,
) -> list[Path]:
    """Measure, compare and plot the runs of one or more protocol run folders.

    Args:
        folders: Protocol run folders of the same plan (a user's run and the committed one).
        out_dir: Where to write; ``<first folder>/report`` if ``None``.
        references: A references file; if ``None``, :func:`find_references`.
        alpha: Family-wise level of the comparisons.

    Returns:
        The files written.

    Raises:
        ValueError: Folders of different plans, an optimizer in two folders, a missing
            reference.
    """
    from benchmarks.storage import atomic_write_text, check_write_folder, run_file_sha256

    config, runs = _merge(folders)
    expected: str | None = None
    ref_path: str | os.PathLike[str] | None = references
    if references is None:
        for folder in folders:
            found = folder_references(folder)
            if found is not None:
                ref_path, expected = found
                break
        else:
            ref_path = packaged_references(config.size)
    if ref_path is None:
        raise ValueError(
            f"no references for size {config.size!r}: none committed, none in the run folders; "
            "compute them with `tooldesign bench protocol --size "
            f"{config.size} --with-references --out {folders[0]}` (or `--references --out "
            "FILE.json`, then --reference-file FILE.json)"
        )
    refs = load_references(ref_path, config=config, expected_sha256=expected)
    budgets = {d: config.budget(d) for d in config.all_degrees()}
    all_times, all_scores = measure_runs(runs, refs, budgets)
    all_references = _reference_table(refs, config, budgets)
    # The sections below are the first task's (push's when it runs); the other tasks' and the
    # pooled ones follow (task_report). One task alone: the tables as before the task axis.
    first, degrees = config.tasks[0], config.task_degrees_of(config.tasks[0])
    if len(config.tasks) == 1:
        all_times, all_scores, all_references = (
            f.drop(columns="task") for f in (all_times, all_scores, all_references)
        )
        times, scores, reference_table = all_times, all_scores, all_references
    else:
        times, scores, reference_table = (
            f[f["task"] == first].drop(columns="task")
            for f in (all_times, all_scores, all_references)
        )
    digest = run_file_sha256(Path(ref_path).parent, Path(ref_path).name)[:16]
    out = Path(out_dir) if out_dir is not None else Path(folders[0]) / "report"
    # report/ inside a run folder is never written through a link (it could lead anywhere).
    check_write_folder(folders[0], out)
    out.mkdir(parents=True, exist_ok=True)
    check_write_folder(folders[0], out)  # and not swapped for one while it was made
    written = []
    tables = (
        ("runtimes.csv", all_times),
        ("runs.csv", all_scores),
        ("references.csv", all_references),
    )
    for name, frame in tables:
        written.append(atomic_write_text(out / name, frame.to_csv(index=False)))
    for degree in degrees:
        path = out / f"ecdf_d{degree}.png"
        _ecdf_figure(times[times["degree"] == degree], f"d = {degree}", path)
        written.append(path)
    path = out / "ecdf_pooled.png"
    _ecdf_figure(times, "all dimensions", path)
    written.append(path)

    gap = held_out_gap(scores)
    sections = [
        "# Protocol report",
        "",
        f"Size `{config.size}`, instance set v{config.instance_version}, degrees "
        f"{list(degrees)}, {config.n_seeds} seed(s), budgets "
        f"{', '.join(f'd = {d}: {b}' for d, b in budgets.items())} evaluations, p^X = "
        f"{config.goal_precision:g}. Run folders: {', '.join(str(f) for f in folders)}. "
        f"References: `{_shown_references(ref_path, config.size)}` (SHA-256 {digest}...).",
        "",
        *(
            []
            if len(config.tasks) == 1
            else [
                f"Tasks {', '.join(config.tasks)}: the sections up to the ECDFs are the "
                f"{first} task's; each other task's, and all tasks pooled, follow them.",
                "",
            ]
        ),
        f"Targets: {N_TARGETS} per (instance, d), from the median F of a random design down to "
        "F_ref + noise floor. Score of a run: the area under its ECDF over its targets (0 to 1, "
        "higher is better). Regret: (F - F_ref) / (F_random(budget) - F_ref), 1 = random "
        "sampling, 0 = the reference. "
        + success_sentence(first, task_tolerance(first), what="run", standing=has_standing(runs))
        + " See docs/protocol.md.",
        "",
        "## Area under the ECDF (mean over instances, 95 % Student t interval over instances; "
        "pooled, each instance's d blocks averaged first)",
        "",
        _md_table(_auc_table(scores, "degree")),
        "",
        _md_table(_auc_table(scores.assign(pooled="all"), "pooled")),
        "",
        "## Expected running time (evaluations)",
        "",
        "ERT (median): each instance's ERT (its runs' evaluations until the target or the "
        "budget, per run that reached it), the median over instances. aRT (pooled): COCO's, "
        "the evaluations of all runs of all instances until the target or the budget, divided "
        "by the number of those runs that reached it; inf when none did.",
        "",
        _md_table(_ert_table(times)),
        "",
        "## References (F_random at the full budget; the noise floor is the last target's "
        "distance to F_ref)",
        "",
        _md_table(references_shown(reference_table, first), ".6g"),
        "",
        REFERENCE_SUCCESS_NOTE,
        "",
        *_ladder_section(scores, reference_table, alpha),
        "## Public and held-out instances (mean score)",
        "",
        "Held-out minus public mean score per optimizer, with a 95 % Welch t interval over "
        "instances (an instance's score: the mean over its seeds and dimensions; the two sets "
        "are different instances). A user's gap far below the built-ins' says the optimizer "
        "was tuned to the public set.",
        "",
        _md_table(gap),
        "",
        *(
            []
            if (gap["n_held_out"] > 0).any()
            else ["This run has no held-out instance: no gap can be measured.", ""]
        ),
    ]
    comparisons, ranks, powers = [], [], []
    # Each block's noise floor (its reference's): the floor an F difference must clear.
    block_floor = {
        (str(r["instance"]), int(r["d"])): float(r["noise floor"])
        for _, r in reference_table.iterrows()
    }
    groups = [(str(d), scores[scores["degree"] == d]) for d in degrees]
    # An instance's blocks (its d) share its goal, mass and friction: pooled, the instance is
    # the unit (its blocks averaged per seed), as in the pooled ECDF's band.
    groups.append(("all", cluster_runs(scores)))
    for label, frame in groups:
        frame = frame.dropna(subset=["score"])
        title = f"d = {label}" if label != "all" else "all dimensions (instances, blocks averaged)"
        sections += [f"## Statistics, {title}", ""]
        if frame["optimizer"].nunique() < 2 or frame["instance"].nunique() < 2:
            sections += ["Fewer than two optimizers or instances: no comparison.", ""]
            continue
        if label == "all":
            # An instance's floor pooled: the mean of its blocks' (its final F is their mean).
            floors = instance_floors(reference_table)
        else:
            floors = {i: f for (i, d), f in block_floor.items() if d == int(label)}
        table, in_f = compare_with_floor(frame, floors, alpha=alpha)
        table = table.assign(d=label)
        # The section's one floor, the rule's and the power sentence's alike.
        group_floor = section_floor(floors, frame["instance"].unique())
        pairs = len(table)
        floor = min_instances(alpha, max(1, pairs))
        blocks = int(frame["instance"].nunique())
        rank = rank_stability(frame, resamples=500).reset_index(names="optimizer").assign(d=label)
        power = power_analysis(frame, alpha=alpha).assign(d=label, measure="score")
        # A run with no valid evaluation has no final F (inf): it is left out of the F table.
        # Counted on the runs, not on the pooled section's cluster-seeds.
        at = [int(label)] if label != "all" else list(degrees)
        no_f = int(np.isinf(scores[scores["degree"].isin(at)]["final_f"]).sum())
        in_f = in_f.assign(d=label, measure="final F")
        comparisons.append(table)
        ranks.append(rank)
        powers.append(power)
        unit = "instances"
        if blocks < floor:
            verdict = (
                f"**This section cannot separate any pair.** With {blocks} {unit}, the exact "
                f"Wilcoxon signed-rank test's smallest p is 2 / 2^{blocks} = "
                f"{2.0 ** (1 - blocks):.3g}, and Holm's first step over {pairs} pair(s) needs "
                f"p < {alpha:g} / {pairs}: no difference, however large, is significant with "
                f"fewer than {floor} {unit}. The detectable differences below are therefore "
                "inf; more seeds do not help, more instances do."
            )
            if label != "all" and len(degrees) > 1:
                verdict += (
                    " Pooling the dimensions adds no instance (the pooled section averages "
                    "each instance's blocks): only more instances separate pairs."
                )
        else:
            verdict = (
                f"With {blocks} {unit} (at least {floor} are needed for any pair to be "
                f"significant at Holm alpha = {alpha:g} over {pairs} pair(s)), a pair can be "
                "told apart; the power table says how large a difference must be."
            )
        name = f"d = {label}" if label != "all" else "pooled"
        pooled_note = (
            [
                f"An instance's {len(degrees)} blocks (instance, d) are not independent (one "
                "goal, mass and friction), so each instance's score and final F here are the "
                f"means over its blocks, per seed: the paired test has n = {blocks} instances, "
                "the ranking's resamples and the pooled ECDF's band draw instances, each with "
                "all its blocks, and an instance's noise floor is the mean of its blocks' "
                f"floors; the section's floor, {group_floor:.4g}, is the median of those "
                "instance floors, for the told-apart rule and the F-unit power alike.",
                "",
            ]
            if label == "all"
            else []
        )
        sections += [
            verdict,
            "",
            separation_sentence(table, in_f, group=name, alpha=alpha, unit=unit),
            "",
            *pooled_note,
            f"Paired by instance (Wilcoxon signed-rank), Holm-corrected, alpha = {alpha:g}; "
            "mean_diff = mean(score a - score b) with a 95 % Student t interval over "
            f"{unit} (positive: a sooner); d_z = mean_diff / SD of the differences, with a 95 % "
            "percentile bootstrap interval over instances (d_z_low, d_z_high; rough with few "
            "instances, and infinite where a resample's differences are all equal, 0 where "
            "they are all 0). f_diff = "
            "mean(final F a - final F b) (each optimizer's final best F per block is its mean "
            "over seeds; negative: a ends lower, better) with its 95 % t interval "
            f"f_diff_low..f_diff_high over {unit}; floor = the median over {unit} of their "
            "references' noise floors; beyond_floor = the interval lies wholly beyond "
            "+-floor on one side. **A pair is told apart** (told_apart) only when "
            f"p_holm < {alpha:g} AND beyond_floor, the higher score with the lower F.",
            "",
            _md_table(table.drop(columns="d")),
            "",
            "Ranking and its stability (instances and seeds resampled):",
            "",
            _md_table(rank.drop(columns="d")),
            "",
            "Power (80 %, at the Holm family's first-step level, for normal paired differences: "
            "the exact signed-rank test's own power up to 50 instances, the t approximation "
            "with its efficiency 3/pi above): `detectable` is the smallest "
            "difference of mean score this run detects (inf when n < min_n: the test cannot "
            "reach the level at all); `instances_needed` (never below min_n) and `seeds_needed` "
            "what the observed difference would need.",
            "",
            _md_table(power.drop(columns=["d", "measure"])),
            "",
            "The same in F units (each run's final best F; compare `detectable` with the "
            f"section's noise floor, the floor of the rule above, {group_floor:.4g}"
            + (f"; {no_f} run(s) with no valid evaluation left out" if no_f else "")
            + "):",
            "",
            _md_table(in_f.drop(columns=["d", "measure"])),
            "",
        ]
        powers.append(in_f)
    for name, parts in (
        ("comparisons.csv", comparisons),
        ("ranks.csv", ranks),
        ("power.csv", powers),
    ):
        if parts:
            written.append(atomic_write_text(out / name, pd.concat(parts).to_csv(index=False)))
    figures = [f"ecdf_d{d}.png" for d in degrees] + ["ecdf_pooled.png"]
    sections += ["## ECDFs", ""] + [f"![{f}]({f})" for f in figures] + [""]
    if len(config.tasks) > 1:
        from benchmarks.protocol.task_report import task_sections

        more, files = task_sections(
            config,
            all_times,
            all_scores,
            all_references,
            out,
            alpha,
            md_table=_md_table,
            auc_table=_auc_table,
            ecdf_figure=_ecdf_figure,
        )
        sections += more
        written += files
    written.append(atomic_write_text(out / "report.md", "\n".join(sections)))
    return written
