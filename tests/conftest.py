"""Fixtures shared by several test files."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.cli import main


@pytest.fixture(scope="session")
def rl_smoke(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run folder of the rl suite at size smoke, made as ``tooldesign bench rl`` makes it."""
    out = tmp_path_factory.mktemp("rl-smoke") / "run"
    assert main(["bench", "rl", "--size", "smoke", "--out", str(out), "--no-progress"]) == 0
    return out
