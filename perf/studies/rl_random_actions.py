"""The normalized reward of random actions at random goals (docs/rl.md, "The normalized reward").

Runs ``--episodes`` episodes of ``ToolDesignRL-v0`` with ``randomize_goal=True``: the action
space is seeded once (``env.action_space.seed(--seed)``), episode k resets with ``seed=k`` and
steps ``env.action_space.sample()``. Prints how many designs were usable, the range of their
rewards, and the rewards of the unusable ones.

Run: ``python -m perf.studies.rl_random_actions --episodes 40 --seed 0``.
"""

from __future__ import annotations

import argparse

from perf import _args
from tooldesign_env.rl import ToolDesignRLEnv


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument(
        "--episodes", type=_args.count(1, 100_000), default=40, help="episodes (default: 40)"
    )
    parser.add_argument(
        "--seed",
        type=_args.count(0, 2**32 - 1),
        default=0,
        help="the actions' seed (default: 0)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    """Run the episodes and print the rewards."""
    args = parse_args(argv)
    env = ToolDesignRLEnv(randomize_goal=True)
    env.action_space.seed(args.seed)
    usable: list[float] = []
    unusable: list[float] = []
    for k in range(args.episodes):
        env.reset(seed=k)
        _, reward, *_, info = env.step(env.action_space.sample())
        (usable if info["valid"] else unusable).append(reward)
    env.close()
    spread = f"rewards {min(usable):.2f} to {max(usable):.2f}" if usable else "no rewards"
    print(
        f"{len(usable)} usable designs, {spread}; "
        f"{len(unusable)} unusable, rewards {[round(r, 2) for r in unusable]}"
    )


if __name__ == "__main__":
    main()
