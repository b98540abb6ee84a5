"""Gymnasium's vector environments step ToolDesign-v0 like the single env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import tooldesign_env  # noqa: F401  (registers ToolDesign-v0)

# A hook and a straight tool: both simulated, with different rewards.
DESIGNS = np.array([[1.0, -1.0, 0.3], [0.0, 0.0, 0.0]])


@pytest.fixture(scope="module")
def single_rewards() -> np.ndarray:
    env = gym.make("ToolDesign-v0", goal_precision=20.0)
    rewards = []
    for design in DESIGNS:
        env.reset(seed=0)
        _, reward, terminated, _, _ = env.step(design)
        assert terminated
        rewards.append(reward)
    env.close()
    return np.array(rewards)


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_env_steps_a_batch_of_designs(mode: str, single_rewards: np.ndarray) -> None:
    # spawn: the workers must not inherit a PyBullet client from this process.
    kwargs = {"context": "spawn"} if mode == "async" else {}
    envs = gym.make_vec(
        "ToolDesign-v0",
        num_envs=2,
        vectorization_mode=mode,
        vector_kwargs=kwargs,
        goal_precision=20.0,
    )
    try:
        assert envs.action_space.shape == (2, 3)
        observations, _ = envs.reset(seed=0)
        np.testing.assert_array_equal(observations, [[0.0, 1.5, 0.1]] * 2)
        _, rewards, terminated, truncated, infos = envs.step(DESIGNS)
        assert rewards.shape == (2,) and terminated.all() and not truncated.any()
        # Same simulation, same floats: equal, not approximately equal.
        np.testing.assert_array_equal(rewards, single_rewards)
        np.testing.assert_array_equal(infos["free_energy"], -single_rewards)
        assert infos["valid"].tolist() == [True, True]
    finally:
        envs.close()
