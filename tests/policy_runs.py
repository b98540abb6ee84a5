"""Helpers of the tests of ``tooldesign design --policy``: a small saved policy and the command.

Shared by ``test_policy_design.py`` (zero-shot) and ``test_warm_start.py`` (``--refine``).
The policy is a contextual one of two training goals (no torch needed).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from benchmarks.cli import main
from benchmarks.rl import ContextualConfig, ContextualPolicy, save_policy

#: A goal, (x, y, z) in m, that no training goal of :func:`contextual_card`'s policy is at.
GOAL = (0.15, 1.05, 0.1)


def contextual_card(path: Path, action: tuple[float, float, float] = (0.3, -0.2, 0.5)) -> Path:
    """A contextual policy of two training goals (``action``, its opposite), saved as ``path``."""
    goals = [(-0.3, 0.8, 0.1), (0.4, 1.3, 0.1)]
    actions = [action, tuple(-a for a in action)]
    policy = ContextualPolicy(goals, actions)
    config = dataclasses.replace(ContextualConfig(), n_goals=2)
    return save_policy(policy, "contextual", path, config=config, train_episodes=2)


def design_with_card(card: Path, out: Path, *extra: str) -> int:
    """``tooldesign design --policy CARD --goal GOAL --out OUT`` (no progress, no video)."""
    goal = [str(v) for v in GOAL]
    args = ["design", "--policy", str(card), "--goal", *goal, "--out", str(out)]
    return main([*args, "--no-progress", "--no-video", *extra])


def refused_design_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str]
) -> str:
    """The error text of a design with a policy and ``extra`` that must exit 2 without a run.

    Asserts the exit code 2, no traceback and no run folder.
    """
    card = contextual_card(tmp_path / "policy.json")
    with pytest.raises(SystemExit) as excinfo:
        design_with_card(card, tmp_path / "run", *extra)
    assert excinfo.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert not (tmp_path / "run").exists()
    return err
