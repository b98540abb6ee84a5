"""A dense grid search of the design space: the yardstick for the optimizers.

Evaluates every design of a regular grid over the coefficient bounds (by default 11 points per
coefficient, 1331 designs, including the straight tool) on one task, through the same executors
as ``tooldesign design``, and writes one CSV row per design. Its best F is what a design run's
result is compared with (docs/design-runs.md).

Run: ``python -m benchmarks.dense_search --points 11 --goal-precision 20 --out DIR``.
"""

from __future__ import annotations

import argparse
import itertools
import time
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.evaluation import TaskSettings, evaluate_batch, make_executor
from benchmarks.storage import atomic_write_text
from tooldesign_env import default_bounds

__all__ = ["grid", "main"]


def grid(points: int, degree: int = 3) -> np.ndarray:
    """(points^degree, degree) designs evenly spaced over the default coefficient bounds."""
    if not isinstance(points, int) or points < 2:
        raise ValueError(f"points must be an integer >= 2, got {points!r}")
    axes = [np.linspace(lo, hi, points) for lo, hi in default_bounds(degree)]
    return np.array(list(itertools.product(*axes)), dtype=float)


def main(argv: list[str] | None = None) -> int:
    """Run the search and print the best designs."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--points", type=int, default=11, help="grid points per coefficient")
    parser.add_argument("--goal-precision", type=float, default=20.0)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--executor", choices=("serial", "process", "dask"), default="process")
    parser.add_argument("--batch", type=int, default=64, help="designs per submitted batch")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    designs = grid(args.points)
    task = TaskSettings(goal=(0.0, 1.5, 0.1), goal_precision=args.goal_precision)
    rows = []
    t0 = time.perf_counter()
    with make_executor(args.executor, args.workers) as executor:
        for start in range(0, len(designs), args.batch):
            chunk = designs[start : start + args.batch]
            rows += evaluate_batch(executor, chunk, task)
            print(
                f"  {len(rows)}/{len(designs)} designs, {time.perf_counter() - t0:.0f} s",
                flush=True,
            )
    table = pd.DataFrame(designs, columns=["c1", "c2", "c3"])
    table = pd.concat(
        [table, pd.DataFrame(rows).drop(columns=["message"], errors="ignore")], axis=1
    )
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(
        args.out / "dense_search.csv", table.to_csv(index=False, float_format="%.17g")
    )
    ok = table[table["status"] == "ok"].sort_values("free_energy")
    print(
        f"{len(designs)} designs in {time.perf_counter() - t0:.0f} s; "
        f"{len(ok)} valid; best 5 by F (goal_precision {args.goal_precision}):"
    )
    print(
        ok.head(5)[
            ["c1", "c2", "c3", "free_energy", "goal_error", "confidence", "final_distance"]
        ].to_string(index=False)
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
