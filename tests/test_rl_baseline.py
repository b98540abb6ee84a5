"""ToolDesign-v0 as an RL baseline: an SB3 agent trains on it through RescaleAction."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import RescaleAction

import tooldesign_env  # noqa: F401


@pytest.mark.slow
def test_ppo_trains_on_randomized_goals(tmp_path, monkeypatch):
    from stable_baselines3 import PPO

    monkeypatch.setenv("SB3_LOGDIR", str(tmp_path))  # SB3's logger makes a folder per learn()

    env = RescaleAction(gym.make("ToolDesign-v0", randomize_goal=True), -1.0, 1.0)
    model = PPO("MlpPolicy", env, n_steps=8, batch_size=8, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=16)
    goal, _ = env.reset(seed=1)
    action, _ = model.predict(goal, deterministic=True)
    assert action.shape == (3,) and np.all(np.abs(action) <= 1.0)
    _, reward, terminated, _, info = env.step(action)
    assert terminated and np.isfinite(reward) and reward == -info["free_energy"]
    env.close()
