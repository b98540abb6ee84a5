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
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.execution import WORKERS_MAX, TaskSettings, evaluate_batch, make_executor
from benchmarks.storage import atomic_write_text, check_out_dir
from optimizers import BATCH_SIZE_MAX
from tooldesign_env import default_bounds
from tooldesign_env.schema import METRICS, coefficient_columns

__all__ = ["best_designs", "dense_search", "grid"]


#: Most designs of a grid: 50 points per coefficient of a cubic (about 10 hours on two cores at
#: 0.3 s a design, and a table of a few hundred MB); 10^6 points asked for 10^18 designs.
GRID_DESIGNS_MAX = 125_000

#: The name of the table ``dense_search`` writes.
TABLE = "dense_search.csv"


def grid(points: int, degree: int = 3) -> np.ndarray:
    """(points^degree, degree) designs evenly spaced over the default coefficient bounds.

    Raises:
        ValueError: ``points`` is not an int from 2 to the largest whose grid has at most
            ``GRID_DESIGNS_MAX`` designs (50 for a cubic).
    """
    largest = 2
    while (largest + 1) ** degree <= GRID_DESIGNS_MAX:
        largest += 1
    if isinstance(points, bool) or not isinstance(points, int) or not 2 <= points <= largest:
        raise ValueError(
            f"points must be an integer from 2 to {largest} (at most {GRID_DESIGNS_MAX:,} "
            f"designs of degree {degree}), got {points!r}"
        )
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
        out_dir: Output folder (created); it must not exist or be empty, so that an earlier
            search's table is never replaced.
        points: Grid points per coefficient, 2 to 50.
        task: The task (default: the paper's goal and p^X).
        executor: ``"serial"``, ``"process"`` or ``"dask"``.
        workers: Worker processes, 1 to 1024; ``None`` is the CPUs this process may use.
        batch: Designs per submitted batch, 1 to 10,000.
        progress: Called with (designs done, designs in all) after each batch.

    Returns:
        One row per design: ``c1..cn``, the metrics, ``status``, ``eval_time``.

    Raises:
        ValueError: If ``points``, ``workers`` or ``batch`` is out of range, or ``out_dir`` is
            a file or a folder that is not empty.
        TypeError: If ``out_dir`` is not a path.
    """
    if isinstance(batch, bool) or not isinstance(batch, int) or not 1 <= batch <= BATCH_SIZE_MAX:
        raise ValueError(f"batch must be an int from 1 to {BATCH_SIZE_MAX}, got {batch!r}")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= WORKERS_MAX
    ):
        raise ValueError(f"workers must be an int from 1 to {WORKERS_MAX}, got {workers!r}")
    designs = grid(points)
    out = check_out_dir(out_dir)  # before the simulation, as tooldesign evaluate
    if out.is_dir() and any(out.iterdir()):
        raise ValueError(
            f"--out {out} exists and is not empty; tooldesign dense-search writes a folder of "
            "its own: give a new folder, or delete this one first"
        )
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
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / TABLE, table.to_csv(index=False, float_format="%.17g"))
    return table


def best_designs(table: pd.DataFrame, n: int = 5) -> pd.DataFrame:
    """The ``n`` valid designs of lowest F, with their coefficients and metrics."""
    ok = table[table["status"] == "ok"].sort_values("free_energy")
    columns = [c for c in table.columns if c.startswith("c") and c[1:].isdigit()]
    return ok.head(n)[[*columns, *METRICS]]
