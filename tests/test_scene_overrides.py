"""Scene overrides of design runs and suites (``scene``): checks, storage, the env, resumes."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest

from benchmarks.design import DesignConfig
from benchmarks.design.config import ADDED_FIELDS as DESIGN_ADDED
from benchmarks.execution import clear_env_cache, worker_env
from benchmarks.suites import SuiteConfig, load_suite, save_suite, suite_from_json
from benchmarks.suites.config import ADDED_FIELDS as SUITE_ADDED
from benchmarks.suites.config import SUITE_KIND, suite_of_manifest
from benchmarks.suites.retest import retest_task
from tooldesign_env import SceneSpec

CAGE = {"box_position": [-0.3, 1.1]}


@pytest.mark.parametrize(
    ("scene", "error", "match"),
    [
        ({"box_place": [0, 1]}, ValueError, r"unknown SceneSpec field 'box_place'.*box_position"),
        ({"box_mass": 0.3}, ValueError, r"must not set 'box_mass'.*own field"),
        ({"box_position": [1.0]}, ValueError, r"SceneSpec.box_position must be 2 finite"),
        ({"box_position": ["a", 1.0]}, TypeError, r"SceneSpec.box_position must be a real"),
        ({"box_yaw": math.nan}, ValueError, r"scene\['box_yaw'\] must be a finite JSON value"),
        ({"box_yaw": "0.1"}, TypeError, r"SceneSpec.box_yaw must be a real number"),
        (
            {"box_friction": -0.1},
            ValueError,
            r"SceneSpec.box_friction must be a finite number >= 0",
        ),
        ({"solver_iterations": 2.5}, ValueError, r"SceneSpec.solver_iterations must be an int"),
        ({"fast_forward_rest": "no"}, TypeError, r"SceneSpec.fast_forward_rest must be True"),
        (
            {"box_position": {1, 2}},
            TypeError,
            r"scene\['box_position'\] must be a finite JSON value",
        ),
        ({1: 2}, TypeError, r"scene keys must be SceneSpec field names"),
        ("box_position", TypeError, r"scene must be a mapping"),
        (3, TypeError, r"scene must be a mapping"),
    ],
)
def test_bad_scene_overrides_name_the_field_and_what_is_allowed(scene, error, match):
    with pytest.raises(error, match=match):
        DesignConfig(scene=scene)
    with pytest.raises(error, match=match):
        SuiteConfig(name="s", scene=scene)


def test_scene_reaches_the_env_only_when_set():
    assert "scene" not in dict(DesignConfig().task().env_kwargs)
    assert "scene" not in dict(DesignConfig(scene={}).task().env_kwargs)
    assert "scene" not in dict(DesignConfig(scene={"merge_fixed_links": True}).task().env_kwargs)
    unmerged = dict(DesignConfig(scene={"merge_fixed_links": False}).task().env_kwargs)["scene"]
    assert unmerged == SceneSpec(merge_fixed_links=False)
    spec = dict(DesignConfig(scene=CAGE).task().env_kwargs)["scene"]
    assert spec == SceneSpec(box_position=(-0.3, 1.1))
    hash(spec)  # the task's env settings are hashed to key the workers' envs
    # Every run of a suite gets the suite's scene.
    suite = SuiteConfig(name="s", scene=CAGE, n_seeds=2)
    assert all(dict(r.design.task().env_kwargs)["scene"] == spec for r in suite.runs())
    assert all(
        "scene" not in dict(r.design.task().env_kwargs) for r in suite.replace(scene={}).runs()
    )


def test_the_env_a_worker_builds_has_the_scene():
    clear_env_cache()
    try:
        env = worker_env(DesignConfig(scene=CAGE).task())
        assert env.unwrapped.simulator.scene.box_position == (-0.3, 1.1)
        default = worker_env(DesignConfig().task())
        assert default.unwrapped.simulator.scene == SceneSpec()
    finally:
        clear_env_cache()


def test_retest_uses_the_suite_scene():
    record = {"goal": [0.0, 1.0, 0.1], "goal_precision": 20.0, "box_mass": 0.1}
    moved = retest_task(SuiteConfig(name="s", scene=CAGE), record)
    assert dict(moved.env_kwargs)["scene"].box_position == (-0.3, 1.1)
    assert moved.env_kwargs == retest_task(SuiteConfig(name="s", scene=CAGE), record).env_kwargs
    assert retest_task(SuiteConfig(name="s"), record).env_kwargs == ()


def test_scene_is_stored_as_json_and_reads_back(tmp_path: Path):
    config = DesignConfig(scene=CAGE)
    # merge_fixed_links is always stored: its default changed (RECORDED_SCENE_FIELDS).
    assert config.to_json()["scene"] == {**CAGE, "merge_fixed_links": True}
    assert DesignConfig().to_json()["scene"] == {"merge_fixed_links": True}
    suite = SuiteConfig(name="s", scene=CAGE)
    assert suite.to_json()["scene"] == {**CAGE, "merge_fixed_links": True}
    assert suite_from_json(json.loads(json.dumps(suite.to_json()))) == suite
    for suffix in (".toml", ".json"):
        assert load_suite(save_suite(suite, tmp_path / f"s{suffix}")) == suite


def test_a_suite_file_takes_a_scene_table(tmp_path: Path):
    path = tmp_path / "cage.toml"
    path.write_text(
        'base = "robustness"\nname = "cage"\n\n'
        "[scene]\nbox_position = [-0.3, 1.1]\nbox_yaw = 0.1\n",
        encoding="utf-8",
    )
    suite = load_suite(path, size="smoke")
    assert dict(suite.scene) == {
        "box_position": (-0.3, 1.1),
        "box_yaw": 0.1,
        "merge_fixed_links": True,
    }
    assert suite.test_robustness and suite.name == "cage"
    path.write_text('name = "cage"\n[scene]\nbox_mass = 0.3\n', encoding="utf-8")
    with pytest.raises(ValueError, match=f"{path.name}.*must not set 'box_mass'"):
        load_suite(path)


def test_older_configs_read_as_the_scene_they_ran_in():
    # Before scene existed, and before the hand was merged by default, runs had the 13-link arm.
    assert DESIGN_ADDED["scene"] == SUITE_ADDED["scene"] == {"merge_fixed_links": False}
    unmerged = SuiteConfig(name="s", scene={"merge_fixed_links": False})
    data = SuiteConfig(name="s").to_json()
    del data["scene"]
    manifest = {"extra": {"kind": SUITE_KIND}, "config": data}
    assert suite_of_manifest(manifest) == unmerged
    data["scene"] = dict(CAGE)  # stored with the overrides alone, before merge_fixed_links
    moved = suite_of_manifest(manifest)
    assert dict(moved.scene) == {"box_position": (-0.3, 1.1), "merge_fixed_links": False}
    data["scene"] = {"merge_fixed_links": True}  # stored since: kept as stored
    assert suite_of_manifest(manifest) == SuiteConfig(name="s")


def test_the_committed_results_keep_the_arm_they_were_made_with():
    root = Path(__file__).resolve().parents[1] / "docs" / "results"
    manifests = sorted(root.glob("*/manifest.json"))
    suites = [m for m in manifests if json.loads(m.read_text())["extra"].get("kind") == SUITE_KIND]
    assert suites
    for path in suites:
        config = suite_of_manifest(json.loads(path.read_text()))
        assert dict(config.scene)["merge_fixed_links"] is False, path


def test_added_tables_fill_in_the_keys_a_stored_table_lacks():
    from benchmarks.storage import with_added_fields

    added = {"scene": {"merge_fixed_links": False}, "scene_samples": 1}
    assert with_added_fields({}, added) == added
    assert with_added_fields({"scene": {"box_yaw": 0.1}}, added) == {
        "scene": {"merge_fixed_links": False, "box_yaw": 0.1},
        "scene_samples": 1,
    }
    stored = {"scene": {"merge_fixed_links": True}, "scene_samples": 4}
    assert with_added_fields(stored, added) == stored
    # A stored value of another type is kept as stored, for the resume check to report.
    assert with_added_fields({"scene": None}, added)["scene"] is None


@pytest.mark.slow
def test_a_run_stored_before_scene_existed_is_resumed(tmp_path: Path):
    from benchmarks.design import run_design
    from benchmarks.storage import ResumeError

    config = DesignConfig(optimizer="random", iterations=1, batch_size=2, executor="serial")
    out = tmp_path / "run"
    run_design(config, out, progress=False, video=False)
    manifest_path = out / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    del manifest["config"]["scene"]
    manifest_path.write_text(json.dumps(manifest))
    # That run had the 13-link arm: today's default (the merged hand) may not continue it ...
    grown = replace(config, iterations=2)
    with pytest.raises(ResumeError, match="scene.*'merge_fixed_links': False"):
        run_design(grown, out, resume=True, progress=False, video=False)
    # ... the scene it ran in may.
    grown = replace(grown, scene={"merge_fixed_links": False})
    run_design(grown, out, resume=True, progress=False, video=False)
    with pytest.raises(ResumeError, match="scene"):
        run_design(replace(grown, scene=CAGE), out, resume=True, progress=False, video=False)


def test_a_suite_file_may_sit_in_its_own_run_folder(tmp_path: Path):
    # docs/results/cage/suite.toml is run with --out docs/results/cage: the file alone does not
    # make the folder a (foreign) run folder; anything else still does.
    from benchmarks.storage import ResumeError
    from benchmarks.storage.session import RunSession

    out = tmp_path / "cage"
    out.mkdir()
    suite_file = save_suite(SuiteConfig(name="s", scene=CAGE), out / "suite.toml")
    session = RunSession(out, kind="suite", config={}, resume=True, own_files=[suite_file])
    assert not session.resumed
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ResumeError, match="no manifest.json"):
        RunSession(tmp_path / "cage", kind="suite", config={}, resume=True, own_files=[suite_file])
