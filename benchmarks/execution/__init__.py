"""Where and how designs are evaluated: executors, the evaluator, and a scheduler of many runs.

- :mod:`~benchmarks.execution.executors`: serial, local process pool or Dask; a worker that
  dies is replaced, its items run again alone and retried up to ``max_retries`` times (knows
  nothing of tools).
- :mod:`~benchmarks.execution.scheduler`: keeps many jobs (design runs) in flight on one
  executor; the work function is a parameter.
- :mod:`~benchmarks.execution.evaluator`: the work functions of this project: simulate and score
  one design in a worker's cached ``ToolDesign-v0`` env, test a final design over box masses.
"""

from __future__ import annotations

from benchmarks.execution.evaluator import (
    ENV_CACHE_SIZE,
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
    MAX_RETRIES_MAX,
    WORKERS_MAX,
    Outcome,
    SerialExecutor,
    WorkerDied,
    check_main_guard,
    check_max_retries,
    make_executor,
    map_robust,
    run_alone,
    usable_cpus,
)
from benchmarks.execution.scheduler import Job, Scheduler

__all__ = [
    "EXECUTORS",
    "MAX_RETRIES_MAX",
    "WORKERS_MAX",
    "EvaluationRequest",
    "FinalTest",
    "Job",
    "Outcome",
    "RobustnessRequest",
    "Scheduler",
    "SerialExecutor",
    "TaskSettings",
    "WorkerDied",
    "check_main_guard",
    "check_max_retries",
    "ENV_CACHE_SIZE",
    "clear_env_cache",
    "evaluate_batch",
    "evaluate_design",
    "evaluate_item",
    "evaluate_robustness_of_design",
    "make_executor",
    "map_robust",
    "outcome_row",
    "run_alone",
    "usable_cpus",
    "run_final_test",
    "worker_env",
]
