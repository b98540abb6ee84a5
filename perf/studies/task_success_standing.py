"""Whether the standing test of success changes any success of the tasks' baselines (docs/tasks.md).

``info["success"]`` asks the box to end within the task's tolerance of the goal AND standing on
the floor (``TaskDefinition.max_tilt``, ``height_tolerance``). For each task asked for, this
replays the evaluations of ``perf.studies.task_baselines`` (its named designs, its 64 random
designs of seed 0 and its CMA-ES run of 15 x 8, seed 0: the same designs, in the same order)
and compares each success flag with the radius alone (usable and ``final_distance <=
tolerance``). It prints how many differ, the largest final tilt and the range of final heights,
of all evaluations and of the successes.

Run: ``python -m perf.studies.task_success_standing [--task push ...]`` (default every built-in
task); about 190 evaluations a task.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from optimizers import make as make_optimizer
from perf.studies.task_baselines import NAMED
from tooldesign_env import ToolDesignEnv, default_bounds
from tooldesign_env.tasks import BUILTIN_TASKS


def compare(name: str, *, random: int = 64, iterations: int = 15, batch: int = 8) -> str:
    """One line: the success flags of ``name``'s baseline evaluations by both rules."""
    env = ToolDesignEnv(task=name)
    env.reset(seed=0)
    tolerance = env.task_definition.tolerance
    bounds = default_bounds(3)
    rng = np.random.default_rng(np.random.SeedSequence(0))
    designs = [*map(np.asarray, NAMED.values()), *rng.uniform(bounds[:, 0], bounds[:, 1],
                                                              size=(random, 3))]
    rows: list[tuple[bool, bool, float, float]] = []

    def score(design: Any) -> dict[str, Any]:
        info = env.step(np.asarray(design, dtype=np.float64))[4]
        by_radius = bool(info["valid"]) and info["final_distance"] <= tolerance
        rows.append((by_radius, bool(info["success"]), info["final_height"], info["final_tilt"]))
        return info

    try:
        for design in designs:
            score(design)
        optimizer = make_optimizer("cmaes", bounds=bounds, batch_size=batch, seed=0)
        for _ in range(iterations):
            asked = optimizer.ask()
            infos = [score(x) for x in asked.x]
            optimizer.tell(asked.ids, [i["free_energy"] if i["valid"] else None for i in infos])
    finally:
        env.close()
    differ = sum(a != b for a, b, _, _ in rows)
    heights = [h for _, _, h, _ in rows]
    won = [h for _, ok, h, _ in rows if ok]
    tilt = max(t for _, _, _, t in rows)
    return (
        f"{name}: {len(rows)} evaluations, successes by the radius alone "
        f"{sum(a for a, _, _, _ in rows)}, standing too {sum(b for _, b, _, _ in rows)}, "
        f"differing {differ}; largest final tilt {math.degrees(tilt):.3f} degrees; final heights "
        f"{min(heights):.4f} to {max(heights):.4f} m"
        + (f", of the successes {min(won):.4f} to {max(won):.4f} m" if won else "")
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The study's command line: ``--task`` (repeatable; default every built-in task)."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--task", action="append", choices=BUILTIN_TASKS, default=None)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Print one line per task."""
    args = parse_args(argv)
    for name in args.task or BUILTIN_TASKS:
        print(compare(name), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
