"""Episodes per second of ``ToolDesignRL-v0``: one env in this process, and vector envs.

Every episode is one simulated tool (one step). The script runs ``--episodes`` episodes of
random actions (``action_space.seed(--seed)``) at random goals, first on one env in this
process (the rate of one core), then through :func:`tooldesign_env.rl.make_rl_vector_env` in
``sync`` and ``async`` mode with each of ``--num-envs``, and prints the episodes per second of
each (wall time, creation and first reset excluded). ``async`` runs one process per env, so its
rate grows with the cores it is given; ``sync`` runs its envs in turn in this process.
docs/rl.md, "Throughput", quotes its output.

Run: ``python -m perf.speed.rl_throughput --episodes 64 --num-envs 1 2``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from perf import _args
from perf._machine import machine_line
from tooldesign_env.rl import ToolDesignRLEnv, make_rl_vector_env


def single_env_rate(episodes: int, seed: int) -> float:
    """Episodes per second of one env stepped in this process."""
    env = ToolDesignRLEnv(randomize_goal=True)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    started = time.perf_counter()
    for _ in range(episodes):
        env.step(env.action_space.sample())
        env.reset()
    elapsed = time.perf_counter() - started
    env.close()
    return episodes / elapsed


def vector_env_rate(mode: str, num_envs: int, episodes: int, seed: int) -> float:
    """Episodes per second of ``make_rl_vector_env(num_envs, vectorization_mode=mode)``."""
    envs = make_rl_vector_env(num_envs, vectorization_mode=mode, randomize_goal=True)
    envs.action_space.seed(seed)
    envs.reset(seed=seed)
    steps = max(1, -(-episodes // num_envs))
    started = time.perf_counter()
    for _ in range(steps):
        _, rewards, *_ = envs.step(envs.action_space.sample())
        assert np.all(np.isfinite(rewards))
    elapsed = time.perf_counter() - started
    envs.close()
    return steps * num_envs / elapsed


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--episodes", type=_args.count(1), default=64, help="episodes per measurement"
    )
    parser.add_argument(
        "--num-envs",
        type=_args.count(1),
        nargs="+",
        default=[1, 2],
        metavar="N",
        help="envs of each vector env measured (default: 1 2)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Measure and print the rates."""
    args = parse_args(argv)
    print(machine_line())
    print(f"one env in this process: {single_env_rate(args.episodes, args.seed):.2f} episodes/s")
    for mode in ("sync", "async"):
        for n in args.num_envs:
            rate = vector_env_rate(mode, n, args.episodes, args.seed)
            print(f"make_rl_vector_env({n}, vectorization_mode={mode!r}): {rate:.2f} episodes/s")


if __name__ == "__main__":  # the async workers import this module again (spawn)
    main()
