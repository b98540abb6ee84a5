"""The normalized reward of random actions at random goals (docs/rl.md, "The normalized reward").

Runs ``--episodes`` episodes of ``ToolDesignRL-v0`` with ``randomize_goal=True``: the action
space is seeded once (``env.action_space.seed(--seed)``), episode k resets with ``seed=k`` and
steps ``env.action_space.sample()``. Prints how many designs were usable, the range of their
rewards, and the rewards of the unusable ones.

Run: ``python benchmarks/perf/rl_random_actions.py --episodes 40 --seed 0``.
"""

from __future__ import annotations

import argparse

from tooldesign_env.rl import ToolDesignRLEnv


def main() -> None:
    """Run the episodes and print the rewards."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--episodes", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    env = ToolDesignRLEnv(randomize_goal=True)
    env.action_space.seed(args.seed)
    usable: list[float] = []
    unusable: list[float] = []
    for k in range(args.episodes):
        env.reset(seed=k)
        _, reward, *_, info = env.step(env.action_space.sample())
        (usable if info["valid"] else unusable).append(reward)
    env.close()
    print(
        f"{len(usable)} usable designs, rewards {min(usable):.2f} to {max(usable):.2f}; "
        f"{len(unusable)} unusable, rewards {[round(r, 2) for r in unusable]}"
    )


if __name__ == "__main__":
    main()
