"""Seconds per evaluation of the break-even study, beside the benchmark protocol's, in one run.

The study's time estimate (``tooldesign rl breakeven --plan``) assumes
:data:`benchmarks.rl.breakeven.SECONDS_PER_EVALUATION` per evaluation per core, near the
protocol's 0.072 s (docs/protocol.md). This script checks that an evaluation of the study costs
what the protocol's does, side by side in one process so that the machine's load is the same
for both:

1. **the protocol's path**: :func:`benchmarks.execution.evaluate_design` on the worker's cached
   ``ToolDesign-v0`` env, with the task's goal, mass and friction;
2. **the study's path**: what a cold or warm unit does, a ``ToolDesignRL-v0`` env made for the
   unit (:func:`benchmarks.rl.breakeven._task_env`, inside the unit's failure guard), reset to
   the task and stepped once per design, through the episode log.

The same ``--designs`` uniform random designs at each of the study's first ``--tasks`` tasks,
alternating the two paths design by design after one warm-up evaluation each. Printed: the
median seconds per evaluation of each path, their ratio (study / protocol), the time to make
the study's env for a unit (once per 64 evaluations at the ``full`` size), and the ``full``
size's simulation time at the measured rate. The integrator measures on an idle machine; on a
loaded one only the ratio means something.

Run: ``python -m perf.speed.breakeven_evaluation --designs 16 --tasks 4``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from perf import _args
from perf._machine import machine_line


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--designs", type=_args.count(1), default=16, help="designs per task (default 16)"
    )
    parser.add_argument(
        "--tasks",
        type=_args.count(1, 20),
        default=4,
        help="the study's first tasks measured, 1 to 20 (default 4)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Measure and print the two paths' seconds per evaluation."""
    args = parse_args(argv)
    from benchmarks.execution import EvaluationRequest, evaluate_design
    from benchmarks.rl.agents import EpisodeLog
    from benchmarks.rl.breakeven import _Guarded, breakeven_config, breakeven_tasks
    from benchmarks.rl.evaluation import _task_settings, action_to_coefficients
    from tooldesign_env import default_bounds

    print(machine_line())
    rng = np.random.default_rng(args.seed)
    bounds = default_bounds(3)
    protocol: list[float] = []
    study: list[float] = []
    making: list[float] = []
    for task in breakeven_tasks()[: args.tasks]:
        settings = _task_settings(task, section_shape=None, merge_fixed_links=None)
        options = {"goal": task.goal, "box_mass": task.box_mass}
        started = time.perf_counter()
        log = EpisodeLog(_Guarded(task))
        making.append(time.perf_counter() - started)
        actions = rng.uniform(-1.0, 1.0, (args.designs + 1, 3)).astype(np.float32)
        for k, action in enumerate(actions):
            request = EvaluationRequest(
                coeffs=action_to_coefficients(action, bounds), task=settings
            )
            started = time.perf_counter()
            evaluate_design(request)
            seconds = time.perf_counter() - started
            if k:  # the first of each is a warm-up
                protocol.append(seconds)
            started = time.perf_counter()
            log.reset(options=options)
            log.step(action)
            seconds = time.perf_counter() - started
            if k:
                study.append(seconds)
        log.close()
    p, s = float(np.median(protocol)), float(np.median(study))
    print(f"protocol's path (evaluate_design, ToolDesign-v0): {p:.4f} s per evaluation (median)")
    print(f"study's path (ToolDesignRL-v0, one env per unit): {s:.4f} s per evaluation (median)")
    print(f"ratio study / protocol: {s / p:.3f}")
    print(f"making the study's env for a unit: {float(np.median(making)):.3f} s (median)")
    counts = breakeven_config("full").planned_evaluations()
    hours = counts["total"] * s / 3600
    print(
        f"full size: {counts['total']:,} evaluations, {hours:.2f} core-hours of simulation at "
        f"{s:.4f} s (PPO's and SAC's updates come on top)"
    )


if __name__ == "__main__":
    main()
