"""A user's policy on a break-even study's tasks: the evaluations of its row in the table.

``tooldesign rl score --policy SPEC --study DIR`` (docs/rl.md, "Add your policy to the table")
runs :func:`score_policy` and prints the row :func:`benchmarks.reports.breakeven.score_row`
makes of its evaluations. The policy is a card, a Stable-Baselines3 ``.zip`` or a
``"module:callable"`` (:func:`benchmarks.rl.evaluation.load_designer`). It is scored on the
study's tasks, in the study's scene, against the study's own references (its best F and its
random designs per task), so its row reads like the study's rows:

- zero-shot: its design for each task, one evaluation (the same regret at every budget); the
  designs are simulated through an executor (:func:`~benchmarks.rl.evaluation.
  evaluate_policy_on_tasks`); a design whose evaluation failed (an error in the simulation)
  counts as an unusable design (:func:`~benchmarks.rl.breakeven.unusable_free_energy`), as in
  the study, not as a missing value;
- with ``refine=True``: also warm-started CMA-ES from its design at each task and replicate,
  with the seeds of the study's cold CMA-ES there, for the study's largest budget (one unit
  per run on the executor); a simulation error inside a run is a failed evaluation with an
  unusable design's F, and the run goes on, as in the study.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.rl.breakeven import (
    BREAKEVEN_COLUMNS,
    _Guarded,
    load_breakeven,
    unusable_free_energy,
)
from benchmarks.rl.evaluation import RLTask, evaluate_policy_on_tasks, load_designer

__all__ = ["score_policy"]


def _study(folder: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    from benchmarks.storage import read_manifest

    log = load_breakeven(folder)
    config = read_manifest(folder)["config"]
    from benchmarks.rl.suite import _default_merge_fixed_links, _default_section_shape

    now = (_default_section_shape(), _default_merge_fixed_links())
    then = (config["section_shape"], config["merge_fixed_links"])
    if now != then:
        raise ValueError(
            f"the study in {folder} ran with section {then[0]} and merge_fixed_links={then[1]}, "
            f"this version's defaults are {now[0]} and {now[1]}: its references do not apply"
        )
    return log, config


def _warm_unit(item: tuple[Any, ...]) -> list[dict[str, Any]]:
    """One warm-started run of a user's policy (a worker function: loads the policy itself)."""
    from benchmarks.rl.warmstart import run_warm_cmaes

    spec, allow_pickle, algorithm, task, seed, budget, popsize = item
    policy, _ = load_designer(spec, allow_pickle=allow_pickle, algorithm=algorithm)
    env = _Guarded(task)  # a simulation error is a failed evaluation, as in the study
    try:
        records, sigma0 = run_warm_cmaes(
            policy,
            total_episodes=budget,
            seed=seed,
            goal=task.goal,
            box_mass=task.box_mass,
            popsize=popsize,
            env=env,
        )
    finally:
        env.close()
    return [
        {
            "free_energy": r.free_energy,
            "goal_error": r.goal_error,
            "confidence": r.confidence,
            "final_distance": r.final_distance,
            "status": "failed" if k in env.failures else "ok" if r.valid else "invalid",
            "normalized_reward": r.reward,
            "eval_time": r.seconds,
            **{f"a{i + 1}": a for i, a in enumerate(r.action)},
            **{f"c{i + 1}": c for i, c in enumerate(r.coefficients)},
            "sigma0": sigma0,
        }
        for k, r in enumerate(records)
    ]


def score_policy(
    spec: str | os.PathLike[str],
    study: str | os.PathLike[str],
    *,
    name: str | None = None,
    refine: bool = False,
    executor: str = "serial",
    workers: int | None = None,
    scheduler: str | None = None,
    allow_pickle: bool = False,
    algorithm: str | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Evaluate a user's policy on a break-even study's tasks.

    Args:
        spec: The policy (see :func:`~benchmarks.rl.evaluation.load_designer`).
        study: A break-even run folder (``tooldesign rl breakeven``), or its
            ``evaluations.parquet`` with the manifest beside it.
        name: The method's name in the table (default: the policy's).
        refine: Also run warm-started CMA-ES from the policy's designs (method
            ``warm-<name>``).
        executor: ``"serial"``, ``"process"`` or ``"dask"``.
        workers: Worker processes of ``"process"`` / ``"dask"``.
        scheduler: A Dask scheduler's address.
        allow_pickle: Load a Stable-Baselines3 ``.zip`` (it is unpickled).
        algorithm: The ``.zip``'s algorithm (``ppo``, ``sac``, ``td3``, ``a2c``, ``ddpg``).

    Returns:
        The user's rows (:data:`~benchmarks.rl.breakeven.BREAKEVEN_COLUMNS`) and the study's
        log (for its references).

    Raises:
        FileNotFoundError / TypeError / ValueError: a bad policy, study or executor; the
            message names it.
    """
    from benchmarks.execution import EXECUTORS, make_executor, map_robust

    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {executor!r}")
    if not isinstance(refine, bool):
        raise TypeError(f"refine must be True or False, got {refine!r}")
    folder = Path(study)
    if folder.suffix == ".parquet":
        folder = folder.parent
    if not (folder / "manifest.json").is_file():
        raise FileNotFoundError(
            f"no break-even study at {study}: give the folder of `tooldesign rl breakeven`"
        )
    log, config = _study(folder)
    policy, info = load_designer(spec, allow_pickle=allow_pickle, algorithm=algorithm)
    method = name or str(info["name"])
    if not method.strip():
        raise ValueError("name must be a non-empty string")
    tasks = [RLTask(**t) for t in config["tasks"]]
    evaluated = evaluate_policy_on_tasks(
        policy,
        tasks,
        executor=executor,
        workers=workers,
        scheduler=scheduler,
        section_shape=config["section_shape"],
        merge_fixed_links=config["merge_fixed_links"],
    )
    rows = []
    for task, (_, row) in zip(tasks, evaluated.iterrows(), strict=True):
        metrics = {c: row[c] for c in ("free_energy", "goal_error", "confidence", "final_distance")}
        if row["status"] == "failed":
            # Counted against the policy as an unusable design, as in the study, not left out.
            metrics["free_energy"] = unusable_free_energy(task)
        rows.append(
            {
                **_common(task),
                **{c: row[c] for c in ("a1", "a2", "a3", "c1", "c2", "c3", "eval_time")},
                **metrics,
                "status": row["status"],
                "variant": "zero-shot",
                "method": method,
                "replicate": 0,
                "evaluation": 1,
                "seed": 0,
                "normalized_reward": math.nan,
                "sigma0": math.nan,
                "best_so_far": metrics["free_energy"],
                "opt_time": 0.0,
            }
        )
    if refine:
        budget = int(max(config["size"]["budgets"]))
        popsize = int(config["size"]["popsize"])
        cold = log[(log["method"] == "cmaes") & (log["evaluation"] == 1)]
        items, where = [], []
        for task in tasks:
            for _, run in cold[cold["task"] == task.id].sort_values("replicate").iterrows():
                seed = int(run["seed"])
                items.append((spec, allow_pickle, algorithm, task, seed, budget, popsize))
                where.append((task, int(run["replicate"]), seed))
        with make_executor(executor, workers, scheduler) as made:
            outcomes = map_robust(made, _warm_unit, items)
        for (task, replicate, seed), (result, error, _) in zip(where, outcomes, strict=True):
            if error is not None:
                raise RuntimeError(f"the warm-started run at task {task.id} failed: {error}")
            best = math.inf
            for n, record in enumerate(result):
                if np.isfinite(record["free_energy"]):
                    best = min(best, float(record["free_energy"]))
                rows.append(
                    {
                        **_common(task),
                        **record,
                        "variant": "warm",
                        "method": f"warm-{method}",
                        "replicate": replicate,
                        "evaluation": n + 1,
                        "seed": seed,
                        "best_so_far": best,
                        "opt_time": 0.0,
                    }
                )
    return pd.DataFrame(rows)[list(BREAKEVEN_COLUMNS)], log


def _common(task: RLTask) -> dict[str, Any]:
    return {**task.row_fields(), "task_set": task.set}
