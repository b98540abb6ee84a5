"""The one home of the task's defaults and of the names results are stored under.

Everything else imports these: the specs (``tooldesign_env.specs``), the environment's ``info``,
the robustness test, the designer, the suites, the run-folder tables and the reports. A default
goal or a column name written anywhere else is a bug: change it here and every layer follows.

Defaults of the task (the paper's Section IV):

- :data:`DEFAULT_GOAL`: X^g, the goal of the box centre, m.
- :data:`DEFAULT_GOAL_PRECISION`: p^X, 1/m^2.
- :data:`DEFAULT_BOX_MASS`: the nominal box mass, kg.
- :data:`ROBUSTNESS_MASSES`: the box masses of the robustness test, kg.
- :data:`EXPECTED_MASSES`: the box masses the robust-design baseline averages over, kg.

Names of stored results (``docs/results-format.md`` documents the files):

- :data:`METRICS`: the scalar outcomes of one evaluation (``info`` keys and table columns).
- :data:`STANDING_COLUMNS`: the box's final height and tilt, stored beside them so that reports
  apply a task's whole success test (``TaskDefinition.succeeded``), not the distance alone.
- :data:`ROBUSTNESS_METRICS`: the robustness test's outcomes (Table I of the paper).
- the column groups of the evaluation table: :data:`STRING_COLUMNS`, :data:`ID_COLUMNS`,
  :data:`TIMING_COLUMNS`, :data:`TASK_COLUMNS` (of which :data:`GOAL_COLUMNS`),
  :data:`RUN_COLUMNS`, :data:`SORT_COLUMNS`, and :data:`COEFFICIENT_PATTERN` for the coefficient
  columns ``c1, c2, ...``.
"""

from __future__ import annotations

import re
from typing import Any, cast

import numpy as np

__all__ = [
    "BEST_SO_FAR",
    "COEFFICIENT_PATTERN",
    "DEFAULT_BOX_MASS",
    "DEFAULT_GOAL",
    "DEFAULT_GOAL_PRECISION",
    "EXPECTED_MASSES",
    "FLOAT_COLUMNS",
    "GOAL_HIGH",
    "GOAL_LOW",
    "ID_COLUMNS",
    "METRICS",
    "PATH_DECIMALS",
    "ROBUSTNESS_MASSES",
    "ROBUSTNESS_METRICS",
    "RUN_COLUMNS",
    "SORT_COLUMNS",
    "STANDING_COLUMNS",
    "STATUSES",
    "STRING_COLUMNS",
    "TASK_COLUMNS",
    "TIMING_COLUMNS",
    "coefficient_columns",
    "rounded_path",
]

# --- defaults of the task ---------------------------------------------------------------------

DEFAULT_GOAL: tuple[float, float, float] = (0.0, 1.5, 0.1)
"""X^g of the paper's experiments: the box centre's goal (x, y, z), m."""

DEFAULT_GOAL_PRECISION = 20.0
"""p^X of the paper's optimizer comparison, 1/m^2."""

DEFAULT_BOX_MASS = 0.1
"""The nominal box mass, kg."""

ROBUSTNESS_MASSES: tuple[float, ...] = (0.3, 0.5, 0.7, 0.9)
"""Box masses of the paper's robustness test (Table I), kg."""

EXPECTED_MASSES: tuple[float, ...] = (0.1, 0.5, 0.9)
"""Box masses the robust-design baseline (``expected-goal-error``) averages over, kg."""

GOAL_LOW: tuple[float, float, float] = (-0.5, 0.5, 0.1)
GOAL_HIGH: tuple[float, float, float] = (0.5, 1.5, 0.1)
"""The paper's range of goals (task randomization, the robustness suite's goals), m."""

# --- names of stored results ------------------------------------------------------------------

METRICS: tuple[str, ...] = ("free_energy", "goal_error", "confidence", "final_distance")
"""Scalar outcomes of one evaluation: F, its two terms, and the box's final distance to X^g."""

STANDING_COLUMNS: tuple[str, ...] = ("final_height", "final_tilt")
"""The box's final state beside its distance (``info`` keys and table columns): its centre's
height above the floor, m, and the angle of its up axis from the vertical, rad. A task's success
test asks the box to stand at the goal (``TaskDefinition.succeeded``); a table written before
these columns existed lacks them, and its success is read from ``final_distance`` alone."""

ROBUSTNESS_METRICS: tuple[str, ...] = ("robustness", "accuracy", "control_deviation")
"""Outcomes of the robustness test over :data:`ROBUSTNESS_MASSES` (Table I of the paper)."""

STATUSES: tuple[str, ...] = ("ok", "invalid", "failed")
"""Status of an evaluation: scored, a design that cannot be used, or an error."""

STRING_COLUMNS: tuple[str, ...] = ("suite", "optimizer", "status", "variant")
ID_COLUMNS: tuple[str, ...] = ("seed", "iteration", "candidate", "eval_id")
TIMING_COLUMNS: tuple[str, ...] = ("eval_time", "opt_time")
GOAL_COLUMNS: tuple[str, str, str] = ("goal_x", "goal_y", "goal_z")
TASK_COLUMNS: tuple[str, ...] = (*GOAL_COLUMNS, "goal_precision", "box_mass")
FLOAT_COLUMNS: tuple[str, ...] = METRICS + STANDING_COLUMNS + TIMING_COLUMNS + TASK_COLUMNS
BEST_SO_FAR = "best_so_far"
"""The column derived on read: the lowest F of a run up to and including each row."""

RUN_COLUMNS: tuple[str, ...] = ("suite", "variant", "optimizer", "seed")
"""Columns that name one optimisation run."""

SORT_COLUMNS: tuple[str, ...] = RUN_COLUMNS + ("iteration", "candidate")
"""The canonical row order of an evaluation table."""

COEFFICIENT_PATTERN = re.compile(r"c([1-9][0-9]*)")
"""Coefficient columns: ``c1`` (highest power) to ``cn`` (the linear term)."""


PATH_DECIMALS = 6
"""Stored box paths are in m rounded to 1 um: far below what a figure shows, half the bytes."""


def rounded_path(path: Any) -> list[list[float]]:
    """A (T, 3) path in m as the nested lists stored in JSON, rounded to :data:`PATH_DECIMALS`."""
    return cast(
        "list[list[float]]", np.round(np.asarray(path, dtype=np.float64), PATH_DECIMALS).tolist()
    )


def coefficient_columns(degree: int) -> list[str]:
    """``["c1", ..., "c<degree>"]``, the coefficient columns of a polynomial of that degree."""
    return [f"c{i + 1}" for i in range(degree)]
