"""RunSession owns its sequence: the ``with`` block, start, batches, finish, files after it.

And a refused resume for other settings is a compact diff naming the differing fields.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from benchmarks.storage import (
    FILE_CHECKSUMS,
    PART_CHECKSUMS,
    FieldChange,
    ResultStore,
    ResumeError,
    RunSession,
    SettingsChanged,
    Unit,
    config_changes,
    describe_changes,
    file_sha256,
)
from benchmarks.storage.configdiff import ABSENT
from benchmarks.storage.session import HEARTBEAT
from tooldesign_env.schema import GOAL_COLUMNS, METRICS, coefficient_columns

CONFIG: dict[str, Any] = {"name": "sequence", "iterations": 3, "scene": {"box_position": [0, 1]}}


def _batch(iteration: int) -> pd.DataFrame:
    """One valid batch of two evaluations of iteration ``iteration``."""
    rows: dict[str, Any] = {
        "suite": ["design"] * 2,
        "optimizer": ["cmaes"] * 2,
        "seed": [0, 0],
        "iteration": [iteration] * 2,
        "candidate": [0, 1],
        "eval_id": [2 * iteration, 2 * iteration + 1],
    }
    for j, name in enumerate(coefficient_columns(3)):
        rows[name] = [0.1 * j, -0.1 * j]
    for k, name in enumerate(METRICS):
        rows[name] = [1.0 + k + iteration, 2.0 + k + iteration]
    rows["status"] = ["ok", "ok"]
    rows["eval_time"] = [0.5, 0.5]
    rows["opt_time"] = [0.01, 0.01]
    for axis, value in zip(GOAL_COLUMNS, (0.0, 1.5, 0.1), strict=True):
        rows[axis] = [value] * 2
    rows["goal_precision"] = [20.0] * 2
    rows["box_mass"] = [0.1] * 2
    return pd.DataFrame(rows)


def _session(out: Path, **kwargs: Any) -> RunSession:
    kwargs.setdefault("config", CONFIG)
    kwargs.setdefault("resume", True)
    return RunSession(out, kind="design", **kwargs)


def _manifest(out: Path) -> dict[str, Any]:
    return json.loads((out / "manifest.json").read_text(encoding="utf-8"))  # type: ignore[no-any-return]


def test_a_batch_written_in_a_block_that_stops_on_an_error_is_resumed(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt), _session(out) as session:
        session.start()
        session.write_batch(_batch(0))
        raise KeyboardInterrupt  # as a user's Ctrl-C in the middle of iteration 1
    # The block closed the session: the part is recorded, the folder unlocked, the heartbeat's
    # file left as after a kill, and no end time written.
    manifest = _manifest(out)
    assert manifest["end_time"] is None
    assert len(manifest["extra"][PART_CHECKSUMS]) == 1
    assert (out / HEARTBEAT).is_file()

    with _session(out) as resumed:
        assert resumed.resumed
        assert [u.iteration for u in resumed.store.completed_units()] == [0]
        resumed.start()
        resumed.write_batch(_batch(1))
        resumed.finish(resumed.store.read(verify=False))
    manifest = _manifest(out)
    assert manifest["end_time"] is not None
    assert len(manifest["extra"]["sessions"]) == 2
    assert len(manifest["extra"][PART_CHECKSUMS]) == 2
    assert not (out / HEARTBEAT).exists()
    log = ResultStore(out).read()  # every checksum verified
    assert sorted(log["iteration"].unique()) == [0, 1]


def test_a_refusal_before_start_leaves_the_folder_as_it_was(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with _session(out) as session:
        session.start()
        session.write_batch(_batch(0))
        session.finish(None)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    with pytest.raises(ResumeError, match="parts of other runs"), _session(out):
        # The caller's own check of the parts refuses the folder before start().
        raise ResumeError("cannot resume: parts of other runs")
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    # ... and the block unlocked the folder: another session opens it.
    with _session(out) as again:
        assert again.resumed


def test_leaving_the_block_unfinished_keeps_the_time_and_the_records(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with _session(out) as session:
        session.start()
        (out / "notes.json").write_text("{}", encoding="utf-8")
        session.record_file(out / "notes.json")
    manifest = _manifest(out)
    assert manifest["end_time"] is None
    assert "notes.json" in manifest["extra"][FILE_CHECKSUMS]


def test_write_file_records_before_and_after_finish(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with _session(out) as session:
        session.start()
        session.write_file(out / "design.json", '{"a": 1}\n')
        manifest = session.finish(None)
        assert "design.json" in manifest["extra"][FILE_CHECKSUMS]
        # After the final manifest: added to the manifest on disk at once.
        card = session.write_file(out / "card.json", '{"b": 2}\n')
        assert _manifest(out)["extra"][FILE_CHECKSUMS]["card.json"] == file_sha256(card)
        # Rewritten: its record follows the new text.
        session.write_file(out / "card.json", '{"b": 3}\n')
        assert _manifest(out)["extra"][FILE_CHECKSUMS]["card.json"] == file_sha256(card)
    with _session(out) as resumed:  # every recorded file checks out
        assert resumed.is_recorded(out / "card.json")
    with pytest.raises(ValueError, match="not inside the run folder"), _session(out) as session:
        session.write_file(tmp_path / "elsewhere.json", "{}")


def test_rewritten_files_are_left_out_of_the_first_manifest(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with _session(out) as session:
        session.start()
        session.write_file(out / "design.json", "{}\n")
        session.finish(None)
    assert "design.json" in _manifest(out)["extra"][FILE_CHECKSUMS]
    with _session(out, rewritten_files=[out / "design.json"]) as session:
        session.start()
        # A kill now, while design.json is rewritten, leaves it unrecorded, not mis-recorded.
        assert "design.json" not in _manifest(out)["extra"][FILE_CHECKSUMS]
        (out / "design.json").write_text('{"new": true}\n', encoding="utf-8")
    with _session(out) as resumed:  # the rewritten file is not refused
        assert not resumed.is_recorded(out / "design.json")


def test_forget_file_after_start_takes_the_record_off_disk_at_once(tmp_path: Path) -> None:
    out = tmp_path / "run"
    with _session(out) as session:
        session.start()
        session.write_file(out / "design.json", "{}\n")
        session.checkpoint()
        assert "design.json" in _manifest(out)["extra"][FILE_CHECKSUMS]
        session.forget_file(out / "design.json")
        assert "design.json" not in _manifest(out)["extra"][FILE_CHECKSUMS]


def _made(out: Path, config: dict[str, Any]) -> None:
    with RunSession(out, kind="design", config=config, resume=False) as session:
        session.start()
        session.finish(None)


def test_a_refusal_for_other_settings_names_the_differing_field_in_one_short_line(
    tmp_path: Path,
) -> None:
    out = tmp_path / "run"
    _made(out, CONFIG)
    before = (out / "manifest.json").read_bytes()
    other = {**CONFIG, "scene": {"box_position": [0, 2]}}
    with pytest.raises(SettingsChanged) as refused:
        _session(out, config=other)
    message = str(refused.value)
    assert "\n" not in message
    assert "other settings (scene.box_position: [0, 1] -> [0, 2])" in message
    assert message.endswith("use the same settings, or another folder")
    assert refused.value.changes == [FieldChange("scene.box_position", [0, 1], [0, 2])]
    assert refused.value.out == out
    assert isinstance(refused.value, ResumeError)  # callers that catch ResumeError still do
    assert (out / "manifest.json").read_bytes() == before


def test_a_long_diff_is_a_few_short_lines_with_the_first_fields_first_and_a_hint(
    tmp_path: Path,
) -> None:
    out = tmp_path / "run"
    recorded = {"size": {"name": "smoke", "seeds": 1}, "goals": [[0.0] * 3] * 20, "a": 1, "b": 2}
    _made(out, {**recorded, "workers": 1})
    requested = {"size": {"name": "full", "seeds": 3}, "goals": [[1.0] * 3] * 20, "a": 5, "b": 6}
    seen: list[Any] = []

    def hint(folder: Path, config: Any) -> list[str]:
        seen.append((folder, config))
        return [f"continue it with: tool --size {config['size']['name']}", "or another folder"]

    with pytest.raises(SettingsChanged) as refused:
        _session(
            out,
            config={**requested, "workers": 8},
            runtime_fields={"workers"},
            first_fields=("size.seeds",),
            resume_hint=hint,
        )
    lines = str(refused.value).splitlines()
    assert lines[0] == (
        f"cannot resume: the run in {out} was made with other settings (recorded -> requested):"
    )
    assert lines[1:6] == [
        "  size.seeds: 1 -> 3",
        "  a: 1 -> 5",
        "  b: 2 -> 6",
        "  goals: 20 items, other values",
        "  and 1 more (size.name)",
    ]
    assert lines[6:] == ["continue it with: tool --size smoke", "or another folder"]
    assert seen == [(out, {**recorded, "workers": 1})]
    assert all(len(line) < 100 for line in lines[1:])  # the first names the folder


def test_a_count_that_may_grow_is_no_difference_but_one_that_shrinks_is(tmp_path: Path) -> None:
    out = tmp_path / "run"
    _made(out, {"n_seeds": 2})
    with _session(out, config={"n_seeds": 3}, growable_fields={"n_seeds"}) as session:
        assert session.resumed
    with pytest.raises(SettingsChanged, match="n_seeds: 2 -> 1"):
        _session(out, config={"n_seeds": 1}, growable_fields={"n_seeds"})


def test_config_changes_and_describe_changes() -> None:
    changes = config_changes(
        {"a": {"b": 1, "c": [1]}, "d": "x", "w": 1},
        {"a": {"b": 2, "c": [1]}, "e": None, "w": 2},
        ignore={"w"},
    )
    assert changes == [
        FieldChange("a.b", 1, 2),
        FieldChange("d", "x", ABSENT),
        FieldChange("e", ABSENT, None),
    ]
    assert describe_changes(changes, first=("e",), shown=2) == [
        "  e: (none) -> null",
        "  a.b: 1 -> 2",
        "  and 1 more (d)",
    ]
    assert str(FieldChange("s", "x" * 60, "y")) == f's: "{"x" * 36}... -> "y"'


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: config_changes([1], {}), TypeError, "recorded must be a config"),  # type: ignore[arg-type]
        (lambda: config_changes({}, "x"), TypeError, "requested must be a config"),  # type: ignore[arg-type]
        (lambda: config_changes({}, {}, ignore="workers"), TypeError, "list of field names"),
        (lambda: describe_changes([], shown=0), ValueError, "shown must be an int >= 1"),
    ],
)
def test_the_diff_refuses_bad_input(call: Any, error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        call()


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"first_fields": "size"}, TypeError, "first_fields must be a list of field names"),
        ({"resume_hint": "continue"}, TypeError, "resume_hint must be a function"),
        ({"rewritten_files": ["/elsewhere/x.json"]}, ValueError, "not inside the run folder"),
    ],
)
def test_the_new_session_arguments_refuse_bad_input(
    tmp_path: Path, kwargs: dict[str, Any], error: type[Exception], match: str
) -> None:
    with pytest.raises(error, match=match):
        _session(tmp_path / "run", **kwargs)


def test_a_unit_of_the_stepper_names_its_part(tmp_path: Path) -> None:
    from benchmarks.design import DesignConfig, DesignStepper

    config = DesignConfig(optimizer="random", seed=3, iterations=1, batch_size=2)
    assert DesignStepper(config).unit(4) == Unit(
        suite="design", optimizer="random", seed=3, iteration=4
    )
    labelled = DesignStepper(config, suite="s", variant="v", label="lab")
    assert labelled.unit(0) == Unit(suite="s", variant="v", optimizer="lab", seed=3, iteration=0)


def test_the_task_fields_are_declared_once_and_shared_by_both_configs() -> None:
    from benchmarks.design import DesignConfig, TaskConfig
    from benchmarks.design.config import TASK_FIELDS
    from benchmarks.suites import SuiteConfig, Variant
    from benchmarks.suites.config import _FILE_ORDER

    for cls in (DesignConfig, SuiteConfig):
        assert issubclass(cls, TaskConfig)
        assert not set(TASK_FIELDS) & set(cls.__dict__.get("__annotations__", {}))
    # The suite's JSON (and its suite files) keep every field, in the order they had; the task
    # is written only when it is not push, so a push suite's JSON is as it was before tasks.
    fields = sorted(f.name for f in dataclasses.fields(SuiteConfig))
    assert sorted((*_FILE_ORDER, "task_name")) == fields
    assert "task_name" not in SuiteConfig(name="s").to_json()
    suite = SuiteConfig(
        name="shared",
        goal_precision=30,
        scene_samples=2,
        variants=[Variant(name="a", goal_precision=10)],
        n_seeds=1,
        iterations=1,
    )
    assert list(suite.to_json())[:4] == ["name", "description", "env_id", "goal"]
    [run] = suite.runs()
    assert {**run.design.task_fields(), "goal_precision": 30.0} == suite.task_fields()
    design = DesignConfig(scene_samples=2)
    assert list(design.to_json())[0] == "optimizer"
    assert list(design.to_json())[-len(TASK_FIELDS) :] == list(TASK_FIELDS)


@pytest.mark.parametrize(
    ("fields", "error", "match"),
    [
        ({"goal_precision": -1.0}, ValueError, "goal_precision"),
        ({"scene_samples": 0}, ValueError, "scene_samples must be >= 1"),
        ({"robustness_masses": []}, ValueError, "robustness_masses"),
        ({"section_shape": "hexagon"}, ValueError, "section_shape must be one of"),
        ({"scene": {"box_mass": 1.0}}, ValueError, "scene must not set 'box_mass'"),
    ],
)
def test_a_task_config_refuses_bad_input(
    fields: dict[str, Any], error: type[Exception], match: str
) -> None:
    from benchmarks.design import TaskConfig

    with pytest.raises(error, match=match):
        TaskConfig(**fields)
