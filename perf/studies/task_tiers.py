"""Tiers per (task, degree): the share of random designs that succeed at d = 3, 5 and 8.

Issue 35 asks for each (task, degree) to be labelled easy, medium or hard from baseline
results. ``perf.studies.task_baselines`` labels each task at d = 3 from the share p of 64
random designs that succeed (its rule, :func:`perf.studies.task_baselines.tier`: *easy* for
p >= 10 %, *medium* for 1 % <= p < 10 %, *hard* for p < 1 %). This study applies the same rule
at every degree of the benchmark protocol's dimension axis: per task and d, ``--random`` (64)
designs drawn uniformly in the protocol's bounds of that degree
(:func:`benchmarks.protocol.dimensions.bounds_of`: +-1.5 for every coefficient but the linear
one, +-0.5), scored at the task's default goal with p^X = 20 and the env's defaults; success is
``info["success"]`` (the box stands within the task's radius of the goal), an unusable design a
failure. Printed and written (``--json``): per (task, d) the share, its 95 % Wilson interval,
the usable share, F's median over the usable designs and the tier; the interval says how far a
label near a boundary may move with another draw.

The d = 3 draw is the baselines' own (``np.random.SeedSequence(seed)`` in the same bounds), so
its shares equal ``docs/results/tasks/baselines.json`` (a test checks it); d = 5 and 8 draw
from ``SeedSequence((seed, d))``. The (task, d) pairs run in parallel on ``--workers``
processes, one env each.

Run: ``python -m perf.studies.task_tiers [--task hook] [--degrees 3 5 8] [--random 64]
[--seed 0] [--workers 2] [--json FILE]``; 64 x 3 x 4 = 768 evaluations, about a minute on 2
idle cores. Output: docs/results/tasks/tiers.json and tiers-output.txt.
"""

from __future__ import annotations

import argparse
import json
import statistics
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from benchmarks.protocol.dimensions import DEGREES, bounds_of
from benchmarks.reports.success import wilson_interval
from benchmarks.storage import atomic_write_text
from perf.studies.task_baselines import tier
from tooldesign_env.tasks import BUILTIN_TASKS, get_task


def draw(degree: int, random: int, seed: int) -> np.ndarray:
    """The (random, degree) designs of one cell: uniform in the protocol's bounds of ``degree``.

    At d = 3 the draw of ``perf.studies.task_baselines`` (the same seed sequence and bounds).
    """
    bounds = np.asarray(bounds_of(degree), dtype=float)
    key = np.random.SeedSequence(seed) if degree == 3 else np.random.SeedSequence((seed, degree))
    rng = np.random.default_rng(key)
    return rng.uniform(bounds[:, 0], bounds[:, 1], size=(random, degree))


def measure_cell(task: str, degree: int, random: int, seed: int) -> dict[str, Any]:
    """The success share and tier of ``random`` designs of one (task, d) at its default goal."""
    from tooldesign_env import ToolDesignEnv, ToolSpec

    env = ToolDesignEnv(task=task, tool=ToolSpec(degree=degree), bounds=bounds_of(degree))
    env.reset(seed=0)
    rows = []
    try:
        for design in draw(degree, random, seed):
            info = env.step(design)[4]
            rows.append((bool(info["valid"]), bool(info["success"]), float(info["free_energy"])))
    finally:
        env.close()
    successes = sum(s for _, s, _ in rows)
    usable = [f for v, _, f in rows if v]
    low, high = wilson_interval(successes, len(rows))
    return {
        "task": task,
        "degree": degree,
        "n": len(rows),
        "usable": len(usable),
        "successes": successes,
        "success_rate": successes / len(rows),
        "success_95": [low, high],
        "free_energy_median": statistics.median(usable) if usable else None,
        "tier": tier(successes / len(rows)),
    }


def _line(cell: dict[str, Any]) -> str:
    low, high = cell["success_95"]
    median = cell["free_energy_median"]  # None when no design was usable
    return (
        f"{cell['task']:<9} d = {cell['degree']}: {cell['successes']:>2}/{cell['n']} succeed "
        f"({100 * cell['success_rate']:.1f} %, 95 % [{100 * low:.1f}, {100 * high:.1f}] %), "
        f"{cell['usable']}/{cell['n']} usable, median F "
        f"{'n/a' if median is None else f'{median:.0f}'}: {cell['tier']}"
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The study's command line."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", action="append", choices=BUILTIN_TASKS, default=None)
    parser.add_argument("--degrees", type=int, nargs="+", default=list(DEGREES))
    parser.add_argument("--random", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = parser.parse_args(argv)
    for degree in args.degrees:
        if degree not in DEGREES:
            parser.error(f"--degrees: {degree} is not a degree of the protocol ({DEGREES})")
    if args.random < 1 or args.workers < 1:
        parser.error(f"--random and --workers must be >= 1, got {args.random}, {args.workers}")
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print every (task, d); write ``--json``."""
    args = parse_args(argv)
    tasks = args.task or list(BUILTIN_TASKS)
    for task in tasks:
        get_task(task)  # an unknown one is refused before anything runs
    cells = [(t, d) for t in tasks for d in args.degrees]
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(measure_cell, t, d, args.random, args.seed) for t, d in cells]
        results = [f.result() for f in futures]
    print(
        f"Tiers per (task, d): {args.random} random designs per cell (seed {args.seed}), "
        "at the task's default goal; easy p >= 10 %, medium 1 % <= p < 10 %, hard p < 1 %"
    )
    for cell in results:
        print(_line(cell))
    if args.json:
        record = {"random": args.random, "seed": args.seed, "cells": results}
        atomic_write_text(args.json, json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
