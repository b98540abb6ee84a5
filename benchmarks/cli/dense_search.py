"""``tooldesign dense-search``: a grid over the design space, the yardstick for the optimizers."""

from __future__ import annotations

import argparse
import time
from typing import Any, cast

from benchmarks.cli._common import add_task_arguments, check_out_folder, out_path, unique_pairs
from benchmarks.execution import EXECUTORS


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``tooldesign dense-search``."""
    parser = subparsers.add_parser(
        "dense-search",
        help="evaluate a regular grid of designs (the yardstick for the optimizers)",
        description="Evaluate every design of a regular grid over the default coefficient "
        "bounds on one task and write dense_search.csv. See docs/dense-search.md.",
    )
    parser.add_argument(
        "--points", type=int, default=11, help="grid points per coefficient, 2 to 50"
    )
    parser.add_argument(
        "--out",
        type=out_path,
        required=True,
        metavar="DIR",
        help="output folder, new or empty (an earlier search's table is never replaced)",
    )
    add_task_arguments(parser)
    parser.add_argument(
        "--workers", type=int, default=None, metavar="N", help="worker processes, 1 to 1024"
    )
    parser.add_argument("--executor", choices=EXECUTORS, default="process")
    parser.add_argument(
        "--batch", type=int, default=64, help="designs per submitted batch, 1 to 10000"
    )
    parser.set_defaults(run=_run)
    return cast("argparse.ArgumentParser", parser)


def _run(args: argparse.Namespace) -> int:
    check_out_folder(args.out)  # before the simulation is imported (seconds)
    from benchmarks.design import DesignConfig
    from benchmarks.suites.dense_search import best_designs, dense_search

    # The task of a design run with these arguments: the same checks and env settings.
    task = DesignConfig(
        goal=tuple(args.goal),
        goal_precision=args.goal_precision,
        box_mass=args.box_mass,
        estimator=args.estimator,
        objective=args.objective,
        scene_samples=args.scene_samples,
        section_shape=args.section_shape,
        scene=unique_pairs(args.scene, "--scene"),
    ).task()
    start = time.perf_counter()

    def progress(done: int, total: int) -> None:
        print(f"  {done}/{total} designs, {time.perf_counter() - start:.0f} s", flush=True)

    table = dense_search(
        args.out,
        points=args.points,
        task=task,
        executor=args.executor,
        workers=args.workers,
        batch=args.batch,
        progress=progress,
    )
    ok = int((table["status"] == "ok").sum())
    print(
        f"{len(table)} designs in {time.perf_counter() - start:.0f} s; {ok} valid; best 5 by F "
        f"(goal_precision {args.goal_precision}):"
    )
    print(best_designs(table).to_string(index=False))
    return 0
