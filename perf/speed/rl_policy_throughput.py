"""Episodes per second per core of ``ToolDesignRL-v0``, and of a policy over many tasks at once.

Two ways to evaluate a policy on many tasks (each episode is one simulated tool):

1. **one env at a time**: one ``ToolDesignRL-v0`` in this process, reset to each task, the
   policy's action stepped (the usual RL loop). Its rate is the rate of one core.
2. **through the project's executors**: :func:`benchmarks.rl.evaluation.evaluate_policy_on_tasks`
   asks the policy for every task's design first, then simulates the designs on the ``process``
   pool or a Dask ``LocalCluster`` of ``--workers`` single-threaded workers (the executors every
   optimizer uses), which keep one env per worker.

The policy gives a pseudo-random action per task (seeded by the task), so the designs are as
varied as random sampling's; the tasks are ``--episodes`` goals and box masses drawn with
``--seed`` from the paper's goal range and 0.1-0.9 kg. Printed: episodes per second (wall time;
env creation, pool start and the first reset excluded for 1, pool start excluded for 2 by one
warm-up batch of ``--workers`` tasks) and per core (divided by the workers). The integrator
measures on an idle machine; on a loaded one the numbers are meaningless.

Run: ``python -m perf.speed.rl_policy_throughput --episodes 64 --workers 1 2``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from perf import _args
from perf._machine import machine_line


class PseudoRandomPolicy:
    """A deterministic action per task, uniform in [-1, 1]^3 (seeded by the task's bytes)."""

    def __init__(self, seed: int) -> None:
        self.seed = seed

    def predict(
        self, observation: np.ndarray, deterministic: bool = True
    ) -> tuple[np.ndarray, None]:
        """The task's action."""
        obs = np.asarray(observation, dtype=np.float32).ravel()
        entropy = [self.seed, *np.frombuffer(obs.tobytes(), dtype=np.uint32).tolist()]
        rng = np.random.default_rng(np.random.SeedSequence(entropy))
        return rng.uniform(-1.0, 1.0, 3).astype(np.float32), None


def make_tasks(n: int, seed: int) -> list:  # type: ignore[type-arg]
    """``n`` tasks: goals in the paper's range, box masses uniform in [0.1, 0.9] kg."""
    from benchmarks.rl.evaluation import RLTask
    from tooldesign_env.schema import GOAL_HIGH, GOAL_LOW

    rng = np.random.default_rng(seed)
    goals = rng.uniform(np.asarray(GOAL_LOW, float), np.asarray(GOAL_HIGH, float), (n, 3))
    masses = rng.uniform(0.1, 0.9, n)
    return [RLTask(id=f"t{k}", goal=tuple(goals[k]), box_mass=float(masses[k])) for k in range(n)]


def one_env_rate(policy: PseudoRandomPolicy, tasks: list) -> float:  # type: ignore[type-arg]
    """Episodes per second of one ``ToolDesignRL-v0`` in this process, one task at a time."""
    from tooldesign_env.rl import ToolDesignRLEnv

    env = ToolDesignRLEnv()
    env.reset(options={"goal": tasks[0].goal, "box_mass": tasks[0].box_mass})
    started = time.perf_counter()
    for task in tasks:
        obs, _ = env.reset(options={"goal": task.goal, "box_mass": task.box_mass})
        action, _ = policy.predict(obs)
        env.step(action)
    elapsed = time.perf_counter() - started
    env.close()
    return len(tasks) / elapsed


def executor_rate(
    kind: str,
    workers: int,
    policy: PseudoRandomPolicy,
    tasks: list,  # type: ignore[type-arg]
) -> float:
    """Episodes per second of ``evaluate_policy_on_tasks`` on a ``kind`` executor."""
    from benchmarks.execution import make_executor
    from benchmarks.rl.evaluation import evaluate_policy_on_tasks

    with make_executor(kind, workers) as executor:
        # One warm-up batch: every worker starts and builds its env before the clock runs.
        evaluate_policy_on_tasks(policy, tasks[:workers], executor=executor)
        started = time.perf_counter()
        rows = evaluate_policy_on_tasks(policy, tasks, executor=executor)
        elapsed = time.perf_counter() - started
    failed = int((rows["status"] == "failed").sum())
    if failed:
        raise RuntimeError(f"{failed} of {len(rows)} evaluations failed on the {kind} executor")
    return len(tasks) / elapsed


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--episodes", type=_args.count(1), default=64, help="tasks (episodes) per measurement"
    )
    parser.add_argument(
        "--workers",
        type=_args.count(1, 1024),
        nargs="+",
        default=[1, 2],
        metavar="N",
        help="workers of each executor measured (default: 1 2)",
    )
    parser.add_argument(
        "--executors",
        nargs="+",
        choices=("process", "dask"),
        default=["process", "dask"],
        help="executors measured (default: process dask)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Measure and print the rates."""
    args = parse_args(argv)
    print(machine_line())
    policy = PseudoRandomPolicy(args.seed)
    tasks = make_tasks(args.episodes, args.seed)
    rate = one_env_rate(policy, tasks)
    print(f"one ToolDesignRL-v0 env, one task at a time: {rate:.2f} episodes/s (per core)")
    for kind in args.executors:
        if kind == "dask":
            try:
                import distributed  # noqa: F401
            except ImportError:
                print("dask: not installed (pip install 'tooldesign[dask]'); skipped")
                continue
        for workers in args.workers:
            rate = executor_rate(kind, workers, policy, tasks)
            print(
                f"evaluate_policy_on_tasks on {kind} with {workers} worker(s): {rate:.2f} "
                f"episodes/s, {rate / workers:.2f} per core"
            )


if __name__ == "__main__":  # the pool's workers import this module again (spawn)
    main()
