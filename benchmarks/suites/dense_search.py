"""A dense grid search of the design space: the yardstick for the optimizers.

Evaluates every design of a regular grid over the coefficient bounds (by default 11 points per
coefficient, 1331 designs, including the straight tool) on one task, through the same executors
as ``tooldesign design``, and writes one CSV row per design. Its best F is what a design run's
result is compared with (docs/design-runs.md).

Run: ``tooldesign dense-search --points 11 --goal-precision 20 --out DIR``.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.execution import TaskSettings, evaluate_batch, make_executor
from benchmarks.storage import atomic_write_text
from tooldesign_env import default_bounds
from tooldesign_env.schema import METRICS, coefficient_columns

__all__ = ["best_designs", "dense_search", "grid"]


def grid(points: int, degree: int = 3) -> np.ndarray:
    """(points^degree, degree) designs evenly spaced over the default coefficient bounds."""
    if not isinstance(points, int) or points < 2:
        raise ValueError(f"points must be an integer >= 2, got {points!r}")
    axes = [np.linspace(lo, hi, points) for lo, hi in default_bounds(degree)]
    return np.array(list(itertools.product(*axes)), dtype=float)


def dense_search(
    out_dir: str | os.PathLike[str],
    *,
    points: int = 11,
    task: TaskSettings | None = None,
    executor: str = "process",
    workers: int | None = None,
    batch: int = 64,
    progress: Callable[[int, int], None] | None = None,
) -> pd.DataFrame:
    """Evaluate every design of the grid and write ``out_dir/dense_search.csv``.

    Args:
        out_dir: Output folder (created).
        points: Grid points per coefficient, >= 2.
        task: The task (default: the paper's goal and p^X).
        executor: ``"serial"``, ``"process"`` or ``"dask"``.
        workers: Worker processes; ``None`` is the number of CPUs.
        batch: Designs per submitted batch, >= 1.
        progress: Called with (designs done, designs in all) after each batch.

    Returns:
        One row per design: ``c1..cn``, the metrics, ``status``, ``eval_time``.

    Raises:
        ValueError: If ``points`` or ``batch`` is out of range.
    """
    if isinstance(batch, bool) or not isinstance(batch, int) or batch < 1:
        raise ValueError(f"batch must be an int >= 1, got {batch!r}")
    designs = grid(points)
    task = task or TaskSettings()
    rows: list[dict[str, Any]] = []
    with make_executor(executor, workers) as pool:
        for start in range(0, len(designs), batch):
            rows += evaluate_batch(pool, designs[start : start + batch], task)
            if progress is not None:
                progress(len(rows), len(designs))
    columns = coefficient_columns(designs.shape[1])
    table = pd.concat(
        [
            pd.DataFrame(designs, columns=columns),
            pd.DataFrame(rows).drop(columns=["message"], errors="ignore"),
        ],
        axis=1,
    )
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "dense_search.csv", table.to_csv(index=False, float_format="%.17g"))
    return table


def best_designs(table: pd.DataFrame, n: int = 5) -> pd.DataFrame:
    """The ``n`` valid designs of lowest F, with their coefficients and metrics."""
    ok = table[table["status"] == "ok"].sort_values("free_energy")
    columns = [c for c in table.columns if c.startswith("c") and c[1:].isdigit()]
    return ok.head(n)[[*columns, *METRICS]]
