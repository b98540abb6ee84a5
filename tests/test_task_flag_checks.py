"""``--goal`` and ``--box-mass``: one check each for ``tooldesign design`` and ``evaluate``
(review 43, item 10).

They said the same thing four ways: ``TaskSpec.goal must be a finite number, got nan`` (push,
an internal class's name), ``--goal must be a finite number, got nan`` (hook), and for a mass
of 0 ``SceneSpec.box_mass must be a finite number > 0`` (evaluate) against ``box_mass must be >
0 and <= 1000 kg`` (design). Now both commands name the flag, the coordinate and the range,
before anything is simulated or written.
"""

from __future__ import annotations

import pytest

from benchmarks.cli import main

PUSH_RANGE = "x in [-2.5, 2.5], y in [-2.5, 2.5], z in [0, 1] m"
HOOK_RANGE = "x in [-0.6, -0.4], y in [0.8, 1.05], z in [0.1, 0.1] m"


def _refusal(tmp_path, capsys, command: str, flags: list[str]) -> str:
    """The one line of stderr ``tooldesign COMMAND FLAGS`` exits 2 with; nothing is written."""
    extra = ["--coeffs", "0", "0", "0"] if command == "evaluate" else []
    with pytest.raises(SystemExit) as exited:
        main([command, *extra, *flags, "--out", str(tmp_path / "out")])
    assert exited.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert not (tmp_path / "out").exists()
    return err[0]


@pytest.mark.parametrize("command", ["design", "evaluate"])
@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (
            ["--task", "push", "--goal", "nan", "1", "0.1"],
            "--goal x must be a finite number in [-2.5, 2.5] m (the push task takes any goal "
            f"in the workspace: {PUSH_RANGE}), got nan",
        ),
        (
            ["--goal", "0", "inf", "0.1"],
            "--goal y must be a finite number in [-2.5, 2.5] m (the push task takes any goal "
            f"in the workspace: {PUSH_RANGE}), got inf",
        ),
        (
            ["--goal", "0", "1.5", "1.2"],
            "--goal z must be a finite number in [0, 1] m (the push task takes any goal in the "
            f"workspace: {PUSH_RANGE}), got 1.2",
        ),
        (
            ["--task", "hook", "--goal", "nan", "1", "0.1"],
            "--goal x must be a finite number in [-0.6, -0.4] m (the hook task's goal range: "
            f"{HOOK_RANGE}), got nan",
        ),
        (
            ["--task", "hook", "--goal", "-0.5", "1.2", "0.1"],
            "--goal y must be a finite number in [0.8, 1.05] m (the hook task's goal range: "
            f"{HOOK_RANGE}), got 1.2",
        ),
        (
            ["--task", "hook", "--goal", "-0.5", "0.9", "0.2"],
            f"--goal z must be 0.1 m (the hook task's goal range: {HOOK_RANGE}), got 0.2",
        ),
        (["--box-mass", "0"], "--box-mass must be a finite mass in kg, > 0 and <= 1000, got 0.0"),
        (["--box-mass", "-1"], "--box-mass must be a finite mass in kg, > 0 and <= 1000, got -1.0"),
        (["--box-mass", "nan"], "--box-mass must be a finite mass in kg, > 0 and <= 1000, got nan"),
        (
            ["--task", "hook", "--box-mass", "1e4"],
            "--box-mass must be a finite mass in kg, > 0 and <= 1000, got 10000.0",
        ),
    ],
)
def test_both_commands_refuse_a_bad_goal_or_mass_in_the_same_words(
    tmp_path, capsys, command, flags, message
):
    line = _refusal(tmp_path, capsys, command, flags)
    assert line == f"tooldesign {command}: error: {message}"
    assert "TaskSpec" not in line and "SceneSpec" not in line


@pytest.mark.parametrize("command", ["design", "evaluate"])
def test_a_goal_on_the_edge_of_the_range_is_taken(tmp_path, capsys, command, monkeypatch):
    # Refused only past the edge: the check stops the command at its first step after it.
    from benchmarks.cli import _common

    seen = []
    check = _common.check_goal_flag

    def spy(goal, definition):
        seen.append(check(goal, definition))
        raise ValueError("stop here")

    monkeypatch.setattr(_common, "check_goal_flag", spy)
    edges = (["--goal", "-2.5", "2.5", "1"], ["--task", "hook", "--goal", "-0.6", "1.05", "0.1"])
    for flags in edges:
        _refusal(tmp_path, capsys, command, flags)
    assert seen == [(-2.5, 2.5, 1.0), (-0.6, 1.05, 0.1)]
