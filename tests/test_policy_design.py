"""``tooldesign design --policy PATH --goal X Y Z``: a saved policy designs into a run folder (#12).

The policies are small contextual ones saved here (no torch); the PPO policy of the rl suite's
smoke run is tried too when Stable-Baselines3 is installed.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from policy_runs import GOAL, contextual_card, design_with_card, refused_design_error

from benchmarks.rl import ContextualConfig, ContextualPolicy, save_policy
from benchmarks.rl.designer import POLICY_DESIGNER, PolicyDesigner
from benchmarks.rl.policies import design_for_goal, policy_digest
from benchmarks.storage import read_manifest
from tooldesign_env import default_bounds


@pytest.mark.slow
def test_a_policy_designs_into_the_run_folder_of_any_design(tmp_path: Path) -> None:
    card = contextual_card(tmp_path / "policy.json")
    out = tmp_path / "run"
    assert design_with_card(card, out) == 0

    expected = design_for_goal(card, GOAL)  # the tool and F of `tooldesign rl design`
    log = pd.read_csv(out / "evaluations.csv")
    assert len(log) == 1 and log["status"].tolist() == ["ok"]
    assert log[["c1", "c2", "c3"]].to_numpy()[0].tolist() == list(expected.coefficients)
    assert log["free_energy"].iloc[0] == expected.free_energy
    card_json = json.loads((out / "design.json").read_text())
    assert card_json["coefficients"] == list(expected.coefficients)
    assert card_json["config"]["optimizer"] == POLICY_DESIGNER
    settings = card_json["config"]["optimizer_settings"]
    assert settings["policy"] == str(card.resolve())
    assert settings["sha256"] == policy_digest(card)
    assert settings["goal"] == list(GOAL) and card_json["config"]["goal"] == list(GOAL)
    # The same files as a design made by an optimizer.
    for name in ("manifest.json", "tool.stl", "tool.obj", "tool.urdf", "robustness.json"):
        assert (out / name).is_file(), name
    assert read_manifest(out)["extra"]["evaluation_counts"]["ok"] == 1

    # Resuming the finished run changes nothing; resuming with a changed policy is refused.
    before = (out / "evaluations.csv").read_bytes()
    assert design_with_card(card, out, "--resume") == 0
    assert (out / "evaluations.csv").read_bytes() == before
    contextual_card(card, action=(0.9, 0.9, 0.9))
    with pytest.raises(SystemExit) as excinfo:
        design_with_card(card, out, "--resume")
    assert excinfo.value.code == 2


@pytest.mark.slow
def test_a_saved_ppo_policy_designs_from_the_command_line(rl_smoke: Path, tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    card = rl_smoke / "policies" / "ppo.json"
    out = tmp_path / "run"
    assert design_with_card(card, out) == 0
    expected = design_for_goal(card, GOAL)
    log = pd.read_csv(out / "evaluations.csv")
    assert log["free_energy"].iloc[0] == expected.free_energy


@pytest.mark.slow
def test_the_command_shows_the_policys_warnings_as_warning_lines(tmp_path: Path) -> None:
    # They were Python's "/path/policies.py:358: UserWarning: ..." and a line of source.
    card = save_policy(
        ContextualPolicy([(-0.3, 0.8, 0.1), (0.4, 1.3, 0.1)], [(0.3, -0.2, 0.5)] * 2),
        "contextual",
        tmp_path / "policy.json",
        config=dataclasses.replace(ContextualConfig(), n_goals=2),
        train_episodes=2,
        goal_range=((-0.5, 0.5, 0.1), (0.5, 1.5, 0.1)),
        mass_range=(0.1, 0.9),
    )
    argv = ["design", "--policy", str(card), "--goal", "0.9", "1.0", "0.1", "--box-mass", "2"]
    argv += ["--out", str(tmp_path / "run"), "--no-progress", "--no-video"]
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines() == [
        f"tooldesign design: warning: the goal [0.9, 1.0, 0.1] is outside the goals {card} was "
        "trained on ([-0.5, 0.5, 0.1] to [0.5, 1.5, 0.1] m): the policy extrapolates",
        f"tooldesign design: warning: the box mass 2 kg is outside the masses {card} was "
        "trained on (0.1 to 0.9 kg): the policy extrapolates",
    ]
    assert "best design" in done.stdout
    # A library caller still gets real warnings.
    with pytest.warns(UserWarning, match="box mass 2 kg is outside"):
        design_for_goal(card, (0.2, 1.0, 0.1), box_mass=2.0, simulate=False)


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--iterations", "3"], "--iterations"),
        (["--batch-size", "4"], "--batch-size"),
        (["--optimizer", "bo"], "--optimizer"),
        (["--seed", "3"], "--seed"),
        (["--option", "sigma0=0.3"], "--option"),
    ],
)
def test_designer_options_are_refused_with_a_policy(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], named: str
) -> None:
    err = refused_design_error(tmp_path, capsys, extra)
    assert named in err and "does not apply" in err


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "No such file"),
        ("not json", "not a policy card"),
        ('{"format": 7}', "not a policy card of format"),
        ('{"format": 1, "method": "ppo", "file": "gone.zip"}', "does not exist"),
    ],
)
def test_a_bad_policy_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str | None, message: str
) -> None:
    card = tmp_path / "policy.json"
    if content is not None:
        card.write_text(content)
    with pytest.raises(SystemExit) as excinfo:
        design_with_card(card, tmp_path / "run")
    assert excinfo.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1


def test_the_designer_refuses_a_changed_policy_and_bad_batches(tmp_path: Path) -> None:
    card = contextual_card(tmp_path / "policy.json")
    bounds = default_bounds(3)
    kwargs = {"policy": card, "goal": GOAL, "box_mass": 0.1, "sha256": policy_digest(card)}
    designer = PolicyDesigner(bounds, **kwargs)
    batch = designer.ask()
    expected = design_for_goal(card, GOAL, simulate=False).coefficients
    assert batch.x.tolist() == [list(expected)]
    designer.tell(batch.ids, [123.0])
    assert designer.ask().x.tolist() == [list(expected)]  # it learns nothing
    with pytest.raises(ValueError, match="batch_size must be 1"):
        PolicyDesigner(bounds, batch_size=2, **kwargs)
    with pytest.raises(ValueError, match="has changed"):
        PolicyDesigner(bounds, **{**kwargs, "sha256": "0" * 64})
    narrow = np.array([[-0.01, 0.01]] * 3)
    with pytest.raises(ValueError, match="outside the run's bounds"):
        PolicyDesigner(narrow, **kwargs)
