"""Scene overrides of design runs and suites (``scene``): checks, storage, the env, resumes."""

from __future__ import annotations

import dataclasses
import json
import math
import re
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
    # The refusal names the nested field, recorded -> requested (it printed both scene tables).
    with pytest.raises(ResumeError, match="scene.merge_fixed_links: false -> true"):
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


# --- the command line's --scene -------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("merge_fixed_links=false", ("merge_fixed_links", False)),
        ("merge_fixed_links=False", ("merge_fixed_links", False)),
        ("box_position=[-0.4, 1.2]", ("box_position", [-0.4, 1.2])),
        (" box_yaw = 0.1 ", ("box_yaw", 0.1)),
        ("arm_floor_contacts=auto", ("arm_floor_contacts", "auto")),
    ],
)
def test_a_scene_item_is_a_field_and_a_json_value(text, expected):
    from benchmarks.cli._common import scene_item

    assert scene_item(text) == expected


@pytest.mark.parametrize("text", ["merge_fixed_links", "=1", "box_yaw=", "  =  "])
def test_a_scene_item_without_a_field_or_a_value_is_refused(text):
    import argparse

    from benchmarks.cli._common import scene_item

    with pytest.raises(argparse.ArgumentTypeError, match="FIELD=VALUE"):
        scene_item(text)


#: Each command that takes --scene, with the arguments of a quick run.
COMMAND_ARGS = {
    "design": ["design", "--iterations", "1", "--no-video"],
    "evaluate": ["evaluate", "--coeffs", "0", "0", "0"],
    "dense-search": ["dense-search", "--points", "2"],
    "bench": ["bench", "optimizers", "--size", "smoke"],
}


@pytest.mark.slow
@pytest.mark.parametrize("command", ["design", "evaluate", "dense-search", "bench"])
@pytest.mark.parametrize(
    ("value", "match"),
    [
        ("foo=1", "unknown SceneSpec field 'foo'"),
        ("box_mass=0.3", "must not set 'box_mass'"),
        ("merge_fixed_links=maybe", "merge_fixed_links must be True or False, got 'maybe'"),
        ("box_yaw=NaN", "must be a finite JSON value"),
    ],
)
def test_bad_scene_values_are_refused_by_every_command(command, value, match, tmp_path, capsys):
    from benchmarks.cli import main

    args = COMMAND_ARGS[command]
    with pytest.raises(SystemExit) as exit_info:
        main([*args, "--out", str(tmp_path / "out"), "--scene", value])
    assert exit_info.value.code == 2
    assert re.search(match, capsys.readouterr().err)
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_the_command_line_scene_reaches_the_configs():
    from benchmarks.cli import build_parser
    from benchmarks.cli.bench import config_from_args as suite_config
    from benchmarks.cli.design import config_from_args as design_config

    parse = build_parser().parse_args
    args = parse(["design", "--out", "x", "--scene", "merge_fixed_links=false"])
    config = design_config(args)
    assert dict(config.scene) == {"merge_fixed_links": False}
    assert dict(config.task().env_kwargs)["scene"] == SceneSpec(merge_fixed_links=False)
    assert dict(design_config(parse(["design", "--out", "x"])).scene) == {"merge_fixed_links": True}
    # bench: over the suite's own scene.
    args = parse(
        ["bench", "optimizers", "--out", "x", "--scene", "box_yaw=0.2"]
        + ["--scene", "merge_fixed_links=false"]
    )
    assert dict(suite_config(args).scene) == {"box_yaw": 0.2, "merge_fixed_links": False}


@pytest.mark.parametrize("command", ["design", "evaluate", "dense-search", "bench"])
def test_a_scene_field_given_twice_is_refused_by_every_command(command, tmp_path, capsys):
    # The last one won silently, while a KEY given twice to --option was refused.
    from benchmarks.cli import main

    args = COMMAND_ARGS[command]
    twice = ["--scene", "box_yaw=0.1", "--scene", "merge_fixed_links=false"]
    twice += ["--scene", "box_yaw=0.2"]
    with pytest.raises(SystemExit) as exit_info:
        main([*args, "--out", str(tmp_path / "out"), *twice])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--scene: box_yaw is given twice (box_yaw=0.1 and box_yaw=0.2)" in err, err
    assert not (tmp_path / "out").exists()


def test_an_option_given_twice_names_the_key_and_both_values(tmp_path, capsys):
    from benchmarks.cli import main

    with pytest.raises(SystemExit) as exit_info:
        argv = ["design", "--out", str(tmp_path / "out")]
        main([*argv, "--option", "sigma0=0.1", "--option", "sigma0=0.2"])
    assert exit_info.value.code == 2
    assert "--option: sigma0 is given twice (sigma0=0.1 and sigma0=0.2)" in capsys.readouterr().err


def test_the_rl_suite_takes_no_scene(tmp_path, capsys):
    from benchmarks.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["bench", "rl", "--out", str(tmp_path / "rl"), "--scene", "box_yaw=0.1"])
    assert exit_info.value.code == 2
    assert "not for the rl suite" in capsys.readouterr().err


@pytest.mark.slow
def test_a_design_run_made_with_13_links_is_resumed_from_the_command_line(tmp_path, capsys):
    from benchmarks.cli import main

    out = tmp_path / "run"
    base = ["design", "--optimizer", "random", "--batch-size", "2", "--executor", "serial"]
    base += ["--no-video", "--no-progress", "--out", str(out)]
    assert main([*base, "--iterations", "1"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["config"]["scene"] = {}  # as stored before the hand was merged by default
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(SystemExit) as exit_info:
        main([*base, "--iterations", "2", "--resume"])
    assert exit_info.value.code == 2
    # The dotted field and JSON values, as --scene takes them (it printed both scene tables).
    assert "scene.merge_fixed_links: false -> true" in capsys.readouterr().err
    grown = [*base, "--iterations", "2", "--resume", "--scene", "merge_fixed_links=false"]
    assert main(grown) == 0
    assert json.loads((out / "manifest.json").read_text())["config"]["scene"] == {
        "merge_fixed_links": False
    }


@pytest.mark.slow
def test_evaluate_records_the_scene_it_ran_in(tmp_path):
    from benchmarks.design.evaluate import evaluate_coefficients

    evaluate_coefficients((0.0, 0.0, 0.0), tmp_path / "a", scene={"merge_fixed_links": False})
    card = json.loads((tmp_path / "a" / "terms.json").read_text())
    assert card["settings"]["scene"] == {"merge_fixed_links": False}
    evaluate_coefficients((0.0, 0.0, 0.0), tmp_path / "b")
    card = json.loads((tmp_path / "b" / "terms.json").read_text())
    assert card["settings"]["scene"] == {"merge_fixed_links": True}


def test_the_committed_suite_files_describe_their_folders():
    # Each docs/results/*/suite.toml reruns its folder: the same config as the folder stored,
    # read as the folder's own (so the arm and the section it ran with are spelled out).
    root = Path(__file__).resolve().parents[1] / "docs" / "results"
    files = sorted(root.glob("**/suite.toml"))
    assert files
    for path in files:
        stored = suite_of_manifest(json.loads((path.parent / "manifest.json").read_text()))
        written = load_suite(path)
        runtime = {"executor", "workers", "scheduler", "max_retries"}
        mismatched = [
            f.name
            for f in dataclasses.fields(stored)
            if f.name not in runtime and getattr(stored, f.name) != getattr(written, f.name)
        ]
        assert not mismatched, (path, mismatched)
