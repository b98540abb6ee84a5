"""Success rates, as the reports show them: :mod:`benchmarks.design.success`, re-exported.

The module lives with the design runs (layer ``benchmarks.design``) because a design run writes
each evaluation's success into its log (``evaluations.csv``'s ``success`` column) and the
reports, a layer above, read it; this name is kept for the reports and for users' imports.
"""

from benchmarks.design.success import (
    SUCCESS_COLUMN,
    EvaluationSuccesses,
    SuccessRate,
    design_succeeded,
    evaluation_successes,
    evaluations_success,
    evaluations_success_text,
    has_standing,
    run_successes,
    scene_of_config,
    scene_of_manifest,
    success_cell,
    success_criterion,
    success_rate,
    success_sentence,
    task_of_manifest,
    task_tolerance,
    wilson_interval,
)

__all__ = [
    "SUCCESS_COLUMN",
    "EvaluationSuccesses",
    "SuccessRate",
    "design_succeeded",
    "evaluation_successes",
    "evaluations_success",
    "evaluations_success_text",
    "has_standing",
    "run_successes",
    "scene_of_config",
    "scene_of_manifest",
    "success_cell",
    "success_rate",
    "success_sentence",
    "success_criterion",
    "task_of_manifest",
    "task_tolerance",
    "wilson_interval",
]
