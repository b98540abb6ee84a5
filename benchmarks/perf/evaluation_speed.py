"""How long one evaluation of F takes, next to the floor of simulating the same episode.

Prints, for a fixed set of designs evaluated in one process on one core:

* the median wall time of ``env.step`` with the default (trajectory) estimator, and its parts:
  building the world, the controlled rollout, the objective;
* the floor: building the same world and applying the same torques with no controller and no
  objective (``ToolSimulator.replay_open_loop``), for the same number of simulated steps;
* the cost of the reference (re-simulation) estimator.

Run: ``python benchmarks/perf/evaluation_speed.py [--designs 12] [--repeats 3]``. Pin it to one
core with ``taskset -c 0`` for a one-core figure. Target: a median of at most 0.15 s.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from tooldesign_env import ObjectiveSpec, ToolDesignEnv, make_tool
from tooldesign_env.objective import free_energy


def designs(n: int, seed: int) -> list[np.ndarray]:
    """The straight tool, a hook, and n - 2 uniform random designs in the default bounds."""
    rng = np.random.default_rng(seed)
    out = [np.zeros(3), np.array([0.0, 1.5, 0.0])]
    out += list(rng.uniform([-1.5, -1.5, -0.5], [1.5, 1.5, 0.5], size=(max(n - 2, 0), 3)))
    return out


def main() -> None:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=12)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--reference", type=int, default=3, help="designs for the reference")
    args = parser.parse_args()

    env = ToolDesignEnv()
    env.reset(seed=0)
    sim = env.simulator
    t0 = time.perf_counter()
    env.step(np.zeros(3))  # the first step solves the plan's inverse kinematics once
    first = time.perf_counter() - t0

    step_t, build_t, rollout_t, objective_t, floor_t, steps = [], [], [], [], [], []
    for _ in range(args.repeats):
        for c in designs(args.designs, args.seed):
            t0 = time.perf_counter()
            info = env.step(c)[4]
            step_t.append(time.perf_counter() - t0)
            if not info["valid"]:
                continue
            geometry = make_tool(c)
            t0 = time.perf_counter()
            sim.build(geometry)
            build_t.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            traj = sim.rollout(geometry)
            rollout_t.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            free_energy(traj.box_position, traj.torques, env._goal, env.objective)
            objective_t.append(time.perf_counter() - t0)
            simulated = traj.torques[: traj.fast_forward_from]
            t0 = time.perf_counter()
            sim.replay_open_loop(geometry, simulated)
            floor_t.append(time.perf_counter() - t0)
            steps.append(traj.fast_forward_from)

    ref = ToolDesignEnv(objective=ObjectiveSpec(estimator="resimulation"))
    ref.reset(seed=0)
    ref_t = []
    for c in designs(args.reference, args.seed):
        t0 = time.perf_counter()
        ref.step(c)
        ref_t.append(time.perf_counter() - t0)

    med = statistics.median
    n_total = len(sim.reference.times)
    print(
        f"designs x repeats: {args.designs} x {args.repeats}; control steps per episode: "
        f"{n_total} ({sim.controller.control_period} physics steps each)"
    )
    print(f"first evaluation in a process (solves the plan's IK): {first:.3f} s")
    print(
        f"evaluation of F, default estimator:   median {med(step_t):.3f} s "
        f"(min {min(step_t):.3f}, max {max(step_t):.3f})"
    )
    print(f"  build world (floor, box, arm+tool): median {med(build_t):.4f} s")
    print(
        f"  controlled rollout incl. build:     median {med(rollout_t):.3f} s "
        f"(simulated control steps: median {int(med(steps))} of {n_total})"
    )
    print(f"  objective (estimator + F):          median {med(objective_t):.4f} s")
    print(
        f"floor (build + same steps, open loop, no controller/objective): "
        f"median {med(floor_t):.3f} s"
    )
    print(f"ratio evaluation / floor: {med(step_t) / med(floor_t):.2f}")
    print(
        f"reference estimator (re-simulation): median {med(ref_t):.3f} s over {len(ref_t)} "
        f"designs ({med(ref_t) / med(step_t):.1f}x the default)"
    )
    env.close()
    ref.close()


if __name__ == "__main__":
    main()
