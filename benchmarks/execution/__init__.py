"""Where and how designs are evaluated: executors, the evaluator, and a scheduler of many runs.

- :mod:`~benchmarks.execution.executors`: serial, local process pool or Dask; a worker that
  dies is replaced and its items retried alone (knows nothing of tools).
- :mod:`~benchmarks.execution.scheduler`: keeps many jobs (design runs) in flight on one
  executor; the work function is a parameter.
- :mod:`~benchmarks.execution.evaluator`: the work functions of this project: simulate and score
  one design in a worker's cached ``ToolDesign-v0`` env, test a final design over box masses.
"""

from __future__ import annotations

from benchmarks.execution.evaluator import (
    EvaluationRequest,
    FinalTest,
    RobustnessRequest,
    TaskSettings,
    clear_env_cache,
    evaluate_batch,
    evaluate_design,
    evaluate_item,
    evaluate_robustness_of_design,
    outcome_row,
    run_final_test,
    worker_env,
)
from benchmarks.execution.executors import (
    EXECUTORS,
    Outcome,
    SerialExecutor,
    check_main_guard,
    make_executor,
    map_robust,
)
from benchmarks.execution.scheduler import Job, Scheduler

__all__ = [
    "EXECUTORS",
    "EvaluationRequest",
    "FinalTest",
    "Job",
    "Outcome",
    "RobustnessRequest",
    "Scheduler",
    "SerialExecutor",
    "TaskSettings",
    "check_main_guard",
    "clear_env_cache",
    "evaluate_batch",
    "evaluate_design",
    "evaluate_item",
    "evaluate_robustness_of_design",
    "make_executor",
    "map_robust",
    "outcome_row",
    "run_final_test",
    "worker_env",
]
