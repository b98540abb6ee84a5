"""Benchmark suites: many design runs, declared in one place, run into one resumable folder.

- :mod:`~benchmarks.suites.config`: :class:`SuiteConfig` and its parts (optimizers, variants,
  tasks, runs).
- :mod:`~benchmarks.suites.builtin`: the paper's suites (``optimizers``, ``precision-sweep``,
  ``robustness``, ``mass-perturbation``) and ours, each at ``smoke`` and ``full`` size.
- :mod:`~benchmarks.suites.files`: suites as TOML or JSON files.
- :mod:`~benchmarks.suites.runner`: :func:`run_suite`, every run on one executor through the
  scheduler, into one run folder.
- :mod:`~benchmarks.suites.retest`: the final designs evaluated again in nudged scenes (the noise
  floor) and under other box masses and frictions (the stress test).
- :mod:`~benchmarks.suites.dense_search`: a grid over the design space, the optimizers' yardstick.

Reports of a suite are made from its stored results by :mod:`benchmarks.reports`.
"""

from __future__ import annotations

from benchmarks.suites.builtin import (
    BUILTIN_SUITES,
    OBJECTIVE_LABELS,
    ROBUSTNESS_PRECISIONS,
    SIZES,
    builtin_suite,
)
from benchmarks.suites.config import (
    ENV_IDS,
    FIGURES,
    RUNTIME_FIELDS,
    SUITE_KIND,
    OptimizerSpec,
    RunSpec,
    SuiteConfig,
    Task,
    Variant,
    suite_from_json,
    suite_of_manifest,
)
from benchmarks.suites.files import load_suite, save_suite
from benchmarks.suites.retest import RetestConfig, retest_design, retest_suite
from benchmarks.suites.runner import SuiteResult, check_optimizers, run_suite, summary_text

__all__ = [
    "BUILTIN_SUITES",
    "ENV_IDS",
    "FIGURES",
    "OBJECTIVE_LABELS",
    "ROBUSTNESS_PRECISIONS",
    "RUNTIME_FIELDS",
    "SIZES",
    "SUITE_KIND",
    "OptimizerSpec",
    "RetestConfig",
    "RunSpec",
    "SuiteConfig",
    "SuiteResult",
    "Task",
    "Variant",
    "builtin_suite",
    "check_optimizers",
    "load_suite",
    "retest_design",
    "retest_suite",
    "run_suite",
    "save_suite",
    "suite_from_json",
    "suite_of_manifest",
    "summary_text",
]
