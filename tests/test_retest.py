"""tooldesign retest: the noise floor and stress test of a suite's final designs; its reports."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks.cli import main
from benchmarks.execution import SerialExecutor
from benchmarks.reports.comparison import pairwise_table
from benchmarks.reports.retest import noise_floor
from benchmarks.reports.suite import make_suite_report
from benchmarks.storage import read_designs, read_retests
from benchmarks.suites.retest import RetestConfig, retest_suite

TINY = (
    'base = "mass-perturbation"\n'
    'name = "tiny"\n'
    "n_seeds = 1\n"
    "batch_size = 3\n"
    "iterations = 2\n"
    "robustness_masses = [0.5]\n"
)
SMALL = RetestConfig(nudges=2, repeats=1, masses=(0.5,), frictions=(0.3,))


@pytest.fixture(scope="module")
def suite_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    config = tmp_path_factory.mktemp("config") / "tiny.toml"
    config.write_text(TINY, encoding="utf-8")
    out = tmp_path_factory.mktemp("suite") / "run"
    args = ["bench", "--config", str(config), "--out", str(out)]
    assert main([*args, "--executor", "serial", "--no-progress"]) == 0
    return out


@pytest.mark.slow
def test_retest_measures_every_design_and_resumes(suite_folder: Path) -> None:
    written = retest_suite(suite_folder, SMALL, executor=SerialExecutor())
    designs = [d for d in read_designs(suite_folder) if d["status"] == "ok"]
    assert len(written) == len(designs) >= 1
    retests = read_retests(suite_folder)
    for design, retest in zip(designs, retests, strict=True):
        assert retest["error"] == ""
        assert [r["nudge"] for r in retest["noise"]] == [0, 1]
        # The first scene is the suite's own: the design's logged F, bit for bit.
        assert retest["noise"][0]["free_energy"] == design["free_energy"]
        assert {(r["change"], r["value"]) for r in retest["stress"]} == {
            ("mass", 0.5),
            ("friction", 0.3),
        }
        for row in retest["stress"]:
            assert row["robustness"] <= 0 and row["control_deviation"] >= 0
            assert np.isfinite(row["final_distance"])
    # A rerun with the same settings has nothing left to do; other settings redo everything.
    assert retest_suite(suite_folder, SMALL, executor=SerialExecutor()) == []
    other = RetestConfig(nudges=2, repeats=1)
    assert len(retest_suite(suite_folder, other, executor=SerialExecutor())) == len(designs)
    assert all(r["stress"] == [] for r in read_retests(suite_folder))
    retest_suite(suite_folder, SMALL, executor=SerialExecutor())


@pytest.mark.slow
def test_reports_use_the_retest(suite_folder: Path) -> None:
    retest_suite(suite_folder, SMALL, executor=SerialExecutor())
    files = {p.name for p in make_suite_report(suite_folder, n_boot=50)}
    assert {"noise-floor.json", "noise.md", "stress.md", "stress-mass.png"} <= files
    floor = json.loads((suite_folder / "report" / "noise-floor.json").read_text())
    assert floor["all"]["designs"] >= 1 and floor["all"]["free_energy"] >= 0
    assert "noise floor" in (suite_folder / "report" / "pairwise.md").read_text().lower()


@pytest.mark.slow
def test_noise_floor_is_the_median_range_over_designs() -> None:
    def retest(values: list[float]) -> dict:
        rows = [
            {"free_energy": v, "goal_error": v, "confidence": 1.0, "final_distance": 0.1}
            for v in values
        ]
        return {"noise": rows}

    floor = noise_floor([retest([10, 11]), retest([10, 13]), retest([20, 20.5])])
    assert floor["free_energy"] == 1.0  # ranges 1, 3, 0.5
    assert floor["confidence"] == 0.0
    assert floor["designs"] == 3
    assert np.isnan(noise_floor([])["free_energy"])


def test_a_difference_below_the_noise_floor_is_not_significant() -> None:
    rows = []
    for optimizer, offset in (("a", 0.0), ("b", 5.0)):
        for seed in range(8):
            rows.append(
                {
                    "optimizer": optimizer,
                    "seed": seed,
                    "iteration": 0,
                    "candidate": 0,
                    "eval_id": 0,
                    "free_energy": 100.0 + offset + 0.01 * seed,
                    "status": "ok",
                }
            )
    frame = pd.DataFrame(rows)
    plain = pairwise_table(frame)
    assert plain["significant"].all() and plain["beyond_noise"].isna().all()  # no floor
    assert plain["mean_difference"].iloc[0] == pytest.approx(-5.0)
    noisy = pairwise_table(frame, noise_floor=6.0)
    assert not noisy["significant"].any() and not noisy["beyond_noise"].any()
    assert pairwise_table(frame, noise_floor=4.0)["significant"].all()


@pytest.mark.slow
@pytest.mark.parametrize(
    "kwargs",
    [
        {"nudges": 1},
        {"nudges": True},
        {"nudges": 2.0},
        {"repeats": 0},
        {"nudges": 2, "repeats": 3},
        {"shift": -1e-4},
        {"turn": float("nan")},
        {"masses": (0.0,)},
        {"masses": (float("inf"),)},
        {"frictions": (-0.1,)},
        {"seed": -1},
    ],
)
def test_retest_config_refuses_bad_values(kwargs: dict) -> None:
    with pytest.raises(ValueError, match="RetestConfig"):
        RetestConfig(**kwargs)


@pytest.mark.slow
def test_retest_command_refuses_a_folder_that_is_not_a_suite(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["retest", str(tmp_path / "missing")])
    assert exit_info.value.code == 2
    with pytest.raises(SystemExit) as exit_info:
        main(["retest", str(tmp_path), "--masses", "a,b"])
    assert exit_info.value.code == 2


@pytest.mark.slow
def test_a_retest_that_broke_is_tried_again_and_an_invalid_design_is_kept(
    suite_folder: Path,
) -> None:
    from benchmarks.storage import INVALID_IN_SCENE, retest_outcome, write_retest

    retest_suite(suite_folder, SMALL, executor=SerialExecutor())
    target = sorted((suite_folder / "retest").rglob("seed=*.json"))[0]
    record = json.loads(target.read_text(encoding="utf-8"))
    for error, redone in (
        ("WorkerDied: the worker running it died 2 times", 1),  # no outcome of the design
        (f"ValueError: {INVALID_IN_SCENE}: overlaps the box", 0),  # an outcome: kept
    ):
        broken = {**record, "error": error, "noise": [], "stress": []}
        write_retest(suite_folder, target, json.dumps(broken))
        assert len(retest_suite(suite_folder, SMALL, executor=SerialExecutor())) == redone
        again = json.loads(target.read_text(encoding="utf-8"))
        assert retest_outcome(again) == ("ok" if redone else "invalid")
    write_retest(suite_folder, target, json.dumps(record))


@pytest.mark.parametrize("task_name", ["hook", "obstacle", "push"])
def test_the_nudged_scenes_of_a_task_design_start_from_the_tasks_box(
    task_name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """DesignConfig.task() leaves out a task's own scene: the retest must not use push's."""
    import benchmarks.suites.retest as retest
    from benchmarks.design import DesignConfig
    from benchmarks.suites.retest import RetestItem, retest_design
    from tooldesign_env.tasks import get_task

    definition = get_task(task_name)
    task = DesignConfig(task_name=task_name, goal=definition.goal).task()
    assert task.task_scene() == definition.scene
    seen = []

    def rollout(settings, scene, coeffs, **changes):  # records the scene instead of simulating
        seen.append(scene)
        return {"final_distance": 0.0, **{name: 0.0 for name in retest.METRICS}}

    monkeypatch.setattr(retest, "_rollout", rollout)
    config = RetestConfig(nudges=4, repeats=1)  # no masses or frictions: no stress rollouts
    retest_design(RetestItem(coeffs=(0.0, 0.0, 0.0), task=task, config=config))
    assert seen[0] == definition.scene and len(seen) == 4
    start = np.asarray(definition.scene.box_position)
    for scene in seen[1:]:
        assert 0 < np.linalg.norm(np.asarray(scene.box_position) - start) <= config.shift
        assert scene.box_friction == definition.scene.box_friction


def test_a_task_settings_scene_is_its_own_else_its_tasks() -> None:
    from benchmarks.execution import TaskSettings
    from tooldesign_env.specs import SceneSpec
    from tooldesign_env.tasks import get_task

    assert TaskSettings().task_scene() == SceneSpec()
    puck = get_task("puck")
    assert TaskSettings(env_kwargs={"task": "puck"}).task_scene() == puck.scene
    assert TaskSettings(env_kwargs={"task": puck}).task_scene() == puck.scene
    moved = SceneSpec(box_position=(1.0, 0.5))
    assert TaskSettings(env_kwargs={"task": "hook", "scene": moved}).task_scene() == moved
