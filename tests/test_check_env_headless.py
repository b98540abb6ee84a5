"""Gymnasium's check_env with default arguments passes on a machine without a display.

It makes the env again in every render mode the instance's ``metadata`` lists; "human" (a
PyBullet window) raised without a display (issue 34), so it is listed only where it can work.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tooldesign_env.env import ToolDesignEnv


def test_an_instance_lists_human_only_where_a_display_is(monkeypatch):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    env = ToolDesignEnv()
    try:
        assert env.metadata["render_modes"] == ["rgb_array"]
    finally:
        env.close()
    assert ToolDesignEnv.metadata["render_modes"] == ["human", "rgb_array"]  # the class: both
    with pytest.raises(RuntimeError, match="needs a display, but DISPLAY is not set"):
        ToolDesignEnv(render_mode="human")
    monkeypatch.setenv("DISPLAY", ":0")
    env = ToolDesignEnv()  # not rendered: no window is opened
    try:
        assert env.metadata["render_modes"] == ["human", "rgb_array"]
    finally:
        env.close()


@pytest.mark.slow
def test_gymnasium_check_env_passes_headless():
    code = (
        "import gymnasium as gym\nimport tooldesign_env\n"
        "from gymnasium.utils.env_checker import check_env\n"
        "check_env(gym.make('ToolDesign-v0').unwrapped)\nprint('passed')\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, env=env
    )
    assert out.returncode == 0 and out.stdout.strip() == "passed", out.stderr[-2000:]
