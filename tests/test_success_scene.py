"""One success test everywhere (review 42-35 finding 2): reports judge a design in the run's scene.

A run whose ``--scene`` makes the box taller (hook, box_size 0.1 x 0.1 x 0.3 m) rests its box at
0.15 m: judged in the task's own scene (0.1 m) it "does not stand" although the env says success.
"""

from __future__ import annotations

import types
from dataclasses import replace

import pandas as pd
import pytest

from benchmarks.reports.success import (
    design_succeeded,
    run_successes,
    scene_of_config,
    scene_of_manifest,
)
from tooldesign_env.specs import SceneSpec
from tooldesign_env.tasks import get_task

HOOK = get_task("hook")
TALL = replace(HOOK.scene, box_size=(0.1, 0.1, 0.3))
CONFIG = {"task_name": "hook", "goal": list(HOOK.goal), "scene": {"box_size": [0.1, 0.1, 0.3]}}
# Where the hook (0.4, 1.4, 0.18) leaves the tall box (the review's check): standing at 0.15 m.
ENDS = {"final_distance": 0.063, "final_height": 0.150, "final_tilt": 2e-4}


def test_a_design_is_judged_in_the_run_scene():
    row = ("ok", ENDS["final_distance"], HOOK, ENDS["final_height"], ENDS["final_tilt"])
    assert design_succeeded(*row, scene=TALL) is True
    assert design_succeeded(*row) is False  # the task's own box rests at 0.1 m
    assert design_succeeded("ok", 0.063, HOOK, 0.100, 2e-4, scene=TALL) is False  # lying lower


def test_run_successes_take_the_run_scene():
    log = pd.DataFrame(
        [{"optimizer": "cmaes", "seed": 0, "free_energy": 1.4, "status": "ok", **ENDS}]
    )
    assert run_successes(log, HOOK, scene=TALL)["success"].tolist() == [True]
    assert run_successes(log, HOOK)["success"].tolist() == [False]


def test_the_scene_of_a_stored_config_is_the_task_scene_with_its_overrides():
    assert scene_of_config(CONFIG) == TALL
    assert scene_of_manifest({"config": CONFIG}) == TALL
    assert scene_of_config({"task_name": "hook", "scene": {}}) is None
    assert scene_of_config(None) is None and scene_of_manifest({}) is None
    push = scene_of_config({"scene": {"box_position": [-0.4, 1.2]}})  # no task_name: push
    assert push == SceneSpec(box_position=(-0.4, 1.2))
    from benchmarks.design import DesignConfig

    assert scene_of_config(CONFIG) == DesignConfig(**CONFIG).task_scene()


def test_a_stored_scene_of_an_unknown_field_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"unknown SceneSpec field 'box_sise'"):
        scene_of_config({"task_name": "hook", "scene": {"box_sise": [0.1, 0.1, 0.3]}})
    with pytest.raises(ValueError, match=r"unknown task 'nope'"):
        scene_of_config({"task_name": "nope", "scene": {"box_friction": 0.3}})


def test_the_html_report_of_a_design_run_judges_it_in_its_scene():
    from benchmarks.reports.html import _success_line

    card = {"status": "ok", **ENDS}
    line = _success_line("ok", ENDS["final_distance"], "hook", standing=card, config=CONFIG)
    assert "Success: yes" in line
    old = _success_line("ok", ENDS["final_distance"], "hook", standing=card)
    assert "does not stand" in old  # without the run's config: the task's own scene


def test_the_suite_tables_judge_designs_in_the_run_scene():
    from benchmarks.reports.comparison import summary_table
    from benchmarks.reports.suite import designs_table

    record = {"optimizer": "cmaes", "seed": 0, "goal": list(HOOK.goal), "goal_precision": 20.0,
              "coefficients": [0.4, 1.4, 0.18], "status": "ok", "free_energy": 1.4, **ENDS}
    assert designs_table([record], tolerance=HOOK, scene=TALL)["success"].tolist() == [True]
    assert designs_table([record], tolerance=HOOK)["success"].tolist() == [False]
    log = pd.DataFrame([{"optimizer": "cmaes", "seed": 0, "iteration": 0, "candidate": 0,
                         "eval_id": 0, "free_energy": 1.4, "best_so_far": 1.4, "status": "ok",
                         **ENDS}])
    assert summary_table(log, n_boot=10, tolerance=HOOK, scene=TALL)["successes"].tolist() == [1]
    assert summary_table(log, n_boot=10, tolerance=HOOK)["successes"].tolist() == [0]


def _fake_run(card_extra):  # type: ignore[no-untyped-def]
    def run_design(config, out, **kwargs):  # type: ignore[no-untyped-def]
        card = {"evaluations": {"total": 1, "ok": 1, "invalid": 0, "failed": 0}, **card_extra}
        return types.SimpleNamespace(
            coefficients=[0.4, 1.4, 0.18], free_energy=1.4, goal_error=1.0, confidence=0.5,
            final_distance=ENDS["final_distance"], iteration=0, candidate=0, status="ok",
            card=card, straight_tool={}, out_dir=out,
            # The run's evaluation log, which the command counts the successes of.
            evaluations=pd.DataFrame(
                {"status": ["ok"], "free_energy": [1.4], "c1": [0.4], "c2": [1.4], "c3": [0.18],
                 "iteration": [0], "candidate": [0], **{k: [v] for k, v in ENDS.items()}}
            ),
        )
    return run_design


@pytest.mark.parametrize(
    ("stored", "word"),
    [
        ({"final_height": 0.150, "final_tilt": 2e-4}, "task hook: success (the box ends"),
        ({"final_height": 0.150, "final_tilt": None}, "task hook: success unknown (the box"),
    ],
)
def test_the_design_command_judges_in_the_run_scene_and_says_unknown(
    monkeypatch, capsys, tmp_path, stored, word
):
    import benchmarks.design as design
    import benchmarks.reports as reports
    from benchmarks.cli import main

    monkeypatch.setattr(design, "run_design", _fake_run(stored))
    monkeypatch.setattr(reports, "write_design_report", lambda folder: [])
    argv = ["design", "--task", "hook", "--scene", "box_size=[0.1,0.1,0.3]", "--no-progress",
            "--out", str(tmp_path / "run")]
    assert main(argv) == 0
    assert word in capsys.readouterr().out


@pytest.mark.slow
def test_the_env_and_the_reports_agree_on_a_tall_box_in_hook():
    from benchmarks.design import DesignConfig
    from tooldesign_env import ToolDesignEnv

    config = DesignConfig(**CONFIG)
    env = ToolDesignEnv(task="hook", scene_overrides={"box_size": (0.1, 0.1, 0.3)})
    env.reset()
    *_, info = env.step([0.4, 1.4, 0.18])
    env.close()
    assert info["success"] is True
    ours = design_succeeded("ok", info["final_distance"], HOOK, info["final_height"],
                            info["final_tilt"], scene=config.task_scene())
    assert ours is info["success"]


# ------------------------------------------------------------------ review 42-35 finding 9
@pytest.mark.parametrize("command", ["design", "evaluate"])
def test_the_goal_help_names_each_task_default_goal(command, capsys):
    from benchmarks.cli import main

    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    goals = ", ".join(
        f"{name} {' '.join(f'{v:g}' for v in get_task(name).goal)}"
        for name in ("push", "hook", "obstacle", "puck")
    )
    assert f"goal X^g in m (default: the task's: {goals}" in text


def test_the_readme_says_the_puck_slides():
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    assert "rolling puck" not in readme and "push a puck that slides" in readme
