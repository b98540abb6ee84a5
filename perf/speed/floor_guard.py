"""How close the floor guard's bound comes to its limit, and how often it re-simulates.

With ``SceneSpec.arm_floor_contacts="auto"`` (the default) every rollout ends with a lower bound
on the arm's and the tool's clearance from the floor (``floor_guard.floor_clearance_bound``); an
episode whose bound is below the limit is simulated again with the floor contacts. This script
evaluates the straight tool, a hook and ``--designs`` uniform random designs at the default
task, then ``--tasks`` random designs at random goals (the paper's range) and box masses in
``--mass-range``, and prints the bound's minimum, median and maximum and how many episodes were
simulated twice, for each set (docs/performance.md, "A lower floor").

Run: ``python -m perf.speed.floor_guard --designs 30 --tasks 40``.
"""

from __future__ import annotations

import argparse
import warnings
from typing import cast

import numpy as np
from gymnasium.spaces import Box

import tooldesign_env.floor_guard as floor_guard
from perf import _args
from tooldesign_env import ToolDesignEnv
from tooldesign_env.specs import BOX_MASS_MAX


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--designs",
        type=_args.count(0),
        default=30,
        help="random designs at the default task, besides the straight tool and the hook "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--tasks",
        type=_args.count(0),
        default=40,
        help="random designs at random tasks (default: %(default)s)",
    )
    parser.add_argument(
        "--mass-range",
        type=_args.number(0.0, BOX_MASS_MAX, above=True, unit="kg"),
        nargs=2,
        default=(0.1, 0.9),
        metavar="KG",
        help="LOW HIGH: the box masses of the random tasks (default: 0.1 0.9)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0)
    args = parser.parse_args(argv)
    low_mass, high_mass = args.mass_range
    if low_mass > high_mass:
        parser.error(f"--mass-range must be LOW <= HIGH kg, got {low_mass:g} {high_mass:g}")
    return args


def main(argv: list[str] | None = None) -> None:
    """Run the designs and tasks and print the bound's figures."""
    args = parse_args(argv)
    low_mass, high_mass = args.mass_range

    bounds: list[float] = []
    real = floor_guard.floor_clearance_bound

    def recorded(*arguments: object) -> float:
        bound = real(*arguments)  # type: ignore[arg-type]
        bounds.append(bound)
        return bound

    floor_guard.floor_clearance_bound = recorded  # type: ignore[assignment]
    rng = np.random.default_rng(args.seed)
    env = ToolDesignEnv()
    space = cast("Box", env.action_space)
    low, high = space.low, space.high
    fixed = [np.zeros(3), np.array([0.0, 1.5, 0.0])] + [
        rng.uniform(low, high) for _ in range(args.designs)
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        env.reset(seed=args.seed)
        for design in fixed:
            env.step(design)
        default_task, bounds[:] = list(bounds), []
        for _ in range(args.tasks):
            goal = (rng.uniform(-0.5, 0.5), rng.uniform(0.5, 1.5), 0.1)
            env.reset(options={"goal": goal, "box_mass": rng.uniform(low_mass, high_mass)})
            env.step(rng.uniform(low, high))
    env.close()
    limit = env.simulator.scene.floor_clearance
    for name, values in (("default task", default_task), ("random tasks", bounds)):
        if not values:
            continue
        v = np.array(values) * 100
        again = int(np.sum(np.array(values) < limit))
        print(
            f"{name}: {len(values)} rollouts, bound min {v.min():.2f} cm, median "
            f"{np.median(v):.2f} cm, max {v.max():.2f} cm; below {limit * 100:g} cm "
            f"(simulated again): {again}"
        )
    print(f"floor-guard warnings: {sum('floor' in str(w.message) for w in caught)}")


if __name__ == "__main__":
    main()
