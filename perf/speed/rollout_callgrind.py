r"""A few rollouts and their open-loop floors, to be counted by valgrind's callgrind.

Where the C loop's requests to PyBullet go is below what a sampling profiler resolves (a few
microseconds a request), so they are counted in instructions instead. The script builds the
default scene, warms up with one rollout, then for each of ``--designs`` random valid designs
runs the controlled rollout with the contact log (what ``env.step`` simulates) and the same
torques open loop (the floor of ``evaluation_speed.py``).

Run (about a minute under valgrind; it counts instructions, not time)::

    valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out \
        python -m perf.speed.rollout_callgrind --designs 3
    callgrind_annotate --inclusive=yes /tmp/cg.out | grep -E \
        "rollout|apply_and_step|arm_state|box_state|postProcessStatus|processContactPointData"
    callgrind_annotate --tree=calling --inclusive=yes /tmp/cg.out   # callees of each

docs/performance.md ("The control loop in C") reads the counts of 2026-11-25 from it.
"""

from __future__ import annotations

import argparse

import numpy as np

from perf import _args
from tooldesign_env import ToolGeometry, ToolSimulator, default_bounds, make_tool


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--designs", type=_args.count(1), default=3, help="random buildable designs"
    )
    parser.add_argument("--seed", type=_args.seed, default=3, help="the random designs' seed")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Simulate and exit; the counting is valgrind's."""
    args = parse_args(argv)
    sim = ToolSimulator()
    rng = np.random.default_rng(args.seed)
    bounds = default_bounds(3)
    geometries: list[ToolGeometry] = []
    while len(geometries) < args.designs:
        geometry = make_tool(rng.uniform(bounds[:, 0], bounds[:, 1]))
        if geometry.buildable:
            geometries.append(geometry)
    try:
        sim.build(geometries[0])
        sim.run(record_mobility=True)  # warm: the plan, the plugin, PyBullet's first calls
        for geometry in geometries:
            sim.build(geometry)
            trajectory = sim.run(record_mobility=True)
            sim.replay_open_loop(geometry, np.asarray(trajectory.torques))
    finally:
        sim.close()
    print(f"{args.designs} rollouts with the contact log and their open-loop floors")


if __name__ == "__main__":
    main()
