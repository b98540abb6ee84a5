"""The protocol's run folders are data: no link followed, no file written through one; the
references it measures against are the ones recorded, of this run's plan (issue 33's rules)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import pandas as pd
import pytest

from benchmarks.protocol import (
    compute_references,
    export_ioh,
    load_references,
    load_runs,
    make_protocol_report,
    packaged_references,
    protocol_config,
    read_protocol,
    reference_plan,
    run_protocol,
)
from benchmarks.protocol.references import FLOOR_SCENES, floor_min_fraction
from benchmarks.protocol.report import folder_references, record_references
from benchmarks.protocol.suite import PROTOCOL_FILE, protocol_record, write_protocol_record

SMOKE = protocol_config("smoke").replace(executor="serial")


def _folder(tmp_path: Path) -> Path:
    """A protocol run folder that has its protocol.json (no cells run)."""
    folder = tmp_path / "run"
    folder.mkdir()
    write_protocol_record(folder, SMOKE)
    return folder


def _victim(tmp_path: Path) -> Path:
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "keep.txt").write_text("mine\n")
    return victim


def _untouched(victim: Path) -> bool:
    return sorted(p.name for p in victim.iterdir()) == ["keep.txt"]


# --- H3: never write through a link, never read through one --------------------------------------


@pytest.mark.parametrize("linked", ["cells", "report", "ioh"])
def test_run_protocol_refuses_a_folder_with_a_link_before_running(tmp_path, linked):
    folder = _folder(tmp_path)
    victim = _victim(tmp_path)
    (folder / linked).symlink_to(victim, target_is_directory=True)
    with pytest.raises(ValueError, match="symbolic link"):
        run_protocol(SMOKE, folder, progress=False)
    assert _untouched(victim)


def test_a_linked_protocol_file_is_not_read(tmp_path):
    folder = tmp_path / "run"
    folder.mkdir()
    elsewhere = tmp_path / "elsewhere.json"
    write_protocol_record(tmp_path, SMOKE)  # a real protocol.json, outside the folder
    (tmp_path / PROTOCOL_FILE).rename(elsewhere)
    (folder / PROTOCOL_FILE).symlink_to(elsewhere)
    with pytest.raises(ValueError, match="symbolic link"):
        read_protocol(folder)
    with pytest.raises(ValueError, match="symbolic link"):
        run_protocol(SMOKE, folder, progress=False)


def test_a_baseline_or_report_folder_with_a_link_is_refused(tmp_path):
    folder = _folder(tmp_path)
    victim = _victim(tmp_path)
    (folder / "report").symlink_to(victim, target_is_directory=True)
    with pytest.raises(ValueError, match="symbolic link"):
        load_runs(folder)  # what --baseline and the report read first
    with pytest.raises(ValueError, match="symbolic link"):
        make_protocol_report([folder])
    assert _untouched(victim)


def _runs() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "optimizer": "a",
            "instance_number": 1,
            "degree": 3,
            "seed": 0,
            "evaluation": [1, 2],
            "free_energy": [5.0, 4.0],
            "c1": 0.0,
            "c2": 0.0,
            "c3": 0.0,
        }
    )


def test_export_ioh_does_not_write_through_a_link(tmp_path):
    folder = _folder(tmp_path)
    victim = _victim(tmp_path)
    (folder / "ioh").symlink_to(victim, target_is_directory=True)
    with pytest.raises(ValueError, match="symbolic link"):
        export_ioh(_runs(), folder / "ioh", run_folder=folder)
    with pytest.raises(ValueError, match="symbolic link"):
        export_ioh(_runs(), folder / "ioh")  # the run folder is the parent by default
    (folder / "ioh").unlink()
    (folder / "ioh").mkdir()
    (folder / "ioh" / "a").symlink_to(victim, target_is_directory=True)
    with pytest.raises(ValueError, match="symbolic link"):
        export_ioh(_runs(), folder / "ioh", run_folder=folder)
    assert _untouched(victim)
    (folder / "ioh" / "a").unlink()
    assert export_ioh(_runs(), folder / "ioh", run_folder=folder)  # real folders: written


def _smoke_references(tmp_path: Path) -> Path:
    path = packaged_references("smoke")
    assert path is not None
    copy = tmp_path / "refs.json"
    copy.write_bytes(path.read_bytes())
    return copy


def test_folder_references_are_checked_against_the_recorded_sha256(tmp_path):
    folder = _folder(tmp_path)
    assert folder_references(folder) is None
    source = packaged_references("smoke")
    assert source is not None
    (folder / "references.json").write_bytes(source.read_bytes())
    # Not recorded: someone put it there.
    with pytest.raises(ValueError, match="not recorded"):
        folder_references(folder)
    digest = record_references(folder)
    assert digest == hashlib.sha256(source.read_bytes()).hexdigest()
    assert protocol_record(folder)["references_sha256"] == digest
    path, expected = folder_references(folder)
    assert load_references(path, config=SMOKE, expected_sha256=expected)
    # Swapped for other references (a cell's F_ref lowered): refused.
    data = json.loads(path.read_text())
    data["cells"][0]["f_ref"] -= 100.0
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="not the references this run folder recorded"):
        load_references(path, config=SMOKE, expected_sha256=expected)
    # A link to a file elsewhere is not read, whatever it holds.
    path.unlink()
    path.symlink_to(source)
    with pytest.raises(ValueError, match="symbolic link"):
        load_references(path, expected_sha256=expected)


def test_a_recorded_sha256_is_read_back_and_a_malformed_one_refused(tmp_path):
    folder = _folder(tmp_path)
    write_protocol_record(folder, SMOKE, references_sha256="0" * 64)
    assert protocol_record(folder)["references_sha256"] == "0" * 64
    data = json.loads((folder / PROTOCOL_FILE).read_text())
    (folder / PROTOCOL_FILE).write_text(json.dumps({**data, "references_sha256": "xyz"}))
    with pytest.raises(ValueError, match="references_sha256 must be 64 hex digits"):
        protocol_record(folder)


def test_a_linked_cells_folder_of_a_references_computation_is_refused(tmp_path):
    victim = _victim(tmp_path)
    out = tmp_path / "refs.json"
    (tmp_path / "refs.json.cells").symlink_to(victim, target_is_directory=True)
    with pytest.raises(ValueError, match="symbolic link"):
        compute_references(SMOKE, out)
    assert _untouched(victim)


# --- M4: references of another run are refused, naming the field ---------------------------------


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"instance_version": 2}, "instance_version = 2"),
        ({"goal_precision": 10.0}, "goal_precision = 10.0"),
        ({"size": "full"}, "size 'full'"),
        ({"plan": {**dataclasses.asdict(reference_plan("full"))}}, "plan grid_points = 11"),
    ],
)
def test_references_of_another_run_are_refused_naming_the_field(tmp_path, change, match):
    path = _smoke_references(tmp_path)
    assert load_references(path, config=SMOKE)
    data = json.loads(path.read_text())
    data.update(change)
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=match):
        load_references(path, config=SMOKE)


def test_quick_uses_full_references_but_not_smoke_ones(tmp_path):
    path = _smoke_references(tmp_path)
    with pytest.raises(ValueError, match="size 'smoke'"):
        load_references(path, config=protocol_config("quick"))


def test_compute_references_keeps_no_cell_of_another_plan(tmp_path):
    path = _smoke_references(tmp_path)
    other = dataclasses.replace(reference_plan("smoke"), pool_per_degree=5)
    with pytest.raises(ValueError, match="plan pool_per_degree = 4"):
        compute_references(SMOKE, path, plan=other)
    # Cells of an interrupted computation under another plan are refused too.
    parts = tmp_path / "new.json.cells"
    parts.mkdir()
    header = json.loads(path.read_text())
    del header["cells"]
    (parts / "plan.json").write_text(json.dumps(header))
    with pytest.raises(ValueError, match="plan pool_per_degree = 4"):
        compute_references(SMOKE, tmp_path / "new.json", plan=other)
    (parts / "plan.json").unlink()
    (parts / "d3-i01.json").write_text("{}")
    with pytest.raises(ValueError, match="no plan.json"):
        compute_references(SMOKE, tmp_path / "new.json", plan=other)


# --- M2: the noise floor over the equivalence rule's scenes, its minimum measured ---------------


def test_noise_floor_scenes_and_minimum_come_from_the_equivalence_rule():
    from benchmarks.suites.equivalence import read_reference

    assert FLOOR_SCENES == read_reference()["spec"]["scenes"] == 16
    assert floor_min_fraction() == read_reference()["median_relative_floor"]
    for size in ("smoke", "quick", "full"):
        assert reference_plan(size).nudges == FLOOR_SCENES


def test_committed_smoke_references_use_the_floor_rule():
    path = packaged_references("smoke")
    assert path is not None
    data = json.loads(path.read_text())
    fraction = data["plan"]["floor_min_fraction"]
    assert fraction == pytest.approx(floor_min_fraction())
    for cell in data["cells"]:
        assert cell["noise_nudges"] == FLOOR_SCENES
        assert cell["noise_floor"] == max(cell["noise_range"], fraction * abs(cell["f_ref"]))


def test_a_plan_refuses_a_bad_floor_fraction():
    from benchmarks.protocol import ReferencePlan

    for bad in (0.0, 1.0, -0.1, True, "0.01"):
        with pytest.raises(ValueError, match="floor_min_fraction must be None or a number"):
            ReferencePlan(floor_min_fraction=bad)


def test_links_are_not_followed_on_this_platform():
    assert hasattr(os, "symlink")


# --- the committed references evaluate again to what they say -------------------------------------


def _references_platform(path: Path) -> str | None:
    """The platform a references file's values reproduce on to the bit (its ``platform``)."""
    return json.loads(path.read_text()).get("platform")


def _on_the_references_platform() -> bool:
    from benchmarks.storage import platform_id

    source = packaged_references("smoke")
    assert source is not None
    return _references_platform(source) == platform_id()


@pytest.mark.slow
def test_the_committed_smoke_references_evaluate_again_to_what_they_say():
    from benchmarks.protocol import verify_references
    from benchmarks.protocol.references import verify_verdict

    table = verify_references(packaged_references("smoke"), SMOKE)
    assert len(table) == 2 * len(SMOKE.cells())
    assert set(table["value"]) == {"reference", "straight"}
    reference = table["value"] == "reference"
    assert table.loc[reference, "noise_floor"].notna().all()
    passed, sentence = verify_verdict(table)
    if table.attrs["same_platform"]:
        # The platform that computed them: the same bits, or the tree changed F.
        assert table["identical"].all(), table
        assert passed, sentence
    elif not passed:
        # Another CPU's last bits act like a nudge: a few values beyond their floor are
        # expected, and with 8 values the rule's share cannot judge; the command can.
        pytest.skip(f"another platform than the references': {sentence}")


@pytest.mark.slow
def test_the_straight_tool_is_judged_against_its_own_noise_floor(tmp_path: Path) -> None:
    """Not the reference design's: at push i01 the straight tool's F ranges over 500 across
    the nudges, its cell's floor is 32, so another CPU's last bits would fail it there."""
    from benchmarks.protocol import verify_references

    if not _on_the_references_platform():
        pytest.skip("the shifts below are judged against values identical to the bit here")

    one = SMOKE.replace(instances=("i01",), degrees=(3,))
    source = packaged_references("smoke")
    assert source is not None
    data = json.loads(source.read_text())
    (cell,) = [
        c for c in data["cells"] if "task" not in c and c["instance"] == "i01" and c["degree"] == 3
    ]
    shift = 2 * cell["noise_floor"]
    cell["f_straight"] += shift  # beyond the reference's floor, inside the straight tool's
    path = tmp_path / "refs.json"
    path.write_text(json.dumps(data))
    table = verify_references(path, one).set_index("value")
    straight = table.loc["straight"]
    assert not straight["identical"]
    assert straight["noise_floor"] > cell["noise_floor"] + shift  # measured, its own
    assert straight["within_floor"]
    cell["f_straight"] += 2 * straight["noise_floor"]  # beyond its own floor too
    cell["f_ref"] += shift  # beyond the reference design's floor
    path.write_text(json.dumps(data))
    table = verify_references(path, one).set_index("value")
    assert not table["within_floor"].any(), table
    assert table.loc["reference", "noise_floor"] == cell["noise_floor"]


def test_verify_references_refuses_a_file_of_another_run_or_of_none_of_its_cells(tmp_path):
    from benchmarks.protocol import verify_references

    data = json.loads(packaged_references("smoke").read_text())
    path = tmp_path / "refs.json"
    path.write_text(json.dumps({**data, "goal_precision": 5.0}))
    with pytest.raises(ValueError, match="goal_precision = 5.0"):
        verify_references(path, SMOKE)
    path.write_text(json.dumps({**data, "cells": [c for c in data["cells"] if "task" in c]}))
    with pytest.raises(ValueError, match="has no cell of this run"):
        verify_references(path, SMOKE)
    path.write_text("[]")
    with pytest.raises(ValueError, match="not a protocol references file"):
        verify_references(path, SMOKE)


def test_cli_verify_references_refuses_out_before_evaluating(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from benchmarks.cli import main

    command = ["bench", "protocol", "--size", "smoke", "--verify-references"]
    with pytest.raises(SystemExit) as done:
        main([*command, "--out", str(tmp_path / "run")])
    assert done.value.code == 2
    assert "no --out (it writes nothing" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
def test_cli_verify_references_fails_on_a_value_moved_beyond_its_noise_floor(tmp_path):
    import subprocess
    import sys

    if not _on_the_references_platform():
        pytest.skip("the counts below are those of values identical to the bit here")

    data = json.loads(packaged_references("smoke").read_text())
    cell = data["cells"][0]
    cell["f_ref"] += 2 * cell["noise_floor"]  # as if the physics had changed under it
    path = tmp_path / "refs.json"
    path.write_text(json.dumps(data))
    command = [sys.executable, "-m", "benchmarks", "protocol", "--size", "smoke", "--no-progress"]
    done = subprocess.run(
        [*command, "--verify-references", "--reference-file", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1, done.stderr
    assert "8 values of 4 cells" in done.stdout and "7 within their noise floor" in done.stdout
    assert f"{cell['instance']}" in done.stdout.split("beyond the noise floor:")[1]
    bad = subprocess.run(
        [*command, "--verify-references", "--optimizer", "random"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert bad.returncode == 2 and "no --optimizer" in bad.stderr
    # A file without the cells of some of the run's tasks: said, not passed over in silence.
    data["cells"] = [c for c in data["cells"] if "task" not in c or c["task"] == "hook"]
    cell["f_ref"] -= 2 * cell["noise_floor"]
    path.write_text(json.dumps(data))
    partial = subprocess.run(
        [*command, "--verify-references", "--reference-file", str(path), "--tasks", "all"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert partial.returncode == 0, partial.stderr
    assert "10 values of 5 cells" in partial.stdout
    assert "no cell for 2 of the run's cells (not checked)" in partial.stdout


def test_the_verdict_asks_identity_on_the_references_platform_and_a_share_elsewhere():
    from benchmarks.protocol.references import FOREIGN_BEYOND_SHARE, verify_verdict

    def table(beyond: int, n: int, same: bool | None, identical: bool = True) -> pd.DataFrame:
        frame = pd.DataFrame(
            {
                "within_floor": [k >= beyond for k in range(n)],
                "identical": [identical and k >= beyond for k in range(n)],
            }
        )
        frame.attrs["platform"] = None if same is None else "x86_64 somewhere"
        frame.attrs["same_platform"] = bool(same)
        return frame

    assert verify_verdict(table(0, 20, True))[0]
    assert not verify_verdict(table(1, 20, True))[0]
    assert not verify_verdict(table(1, 20, None))[0]  # no platform recorded: strict
    moved = verify_verdict(table(0, 20, True, identical=False))
    assert moved[0] and "not identical to the bit" in moved[1]
    allowed = int(FOREIGN_BEYOND_SHARE * 144)
    assert verify_verdict(table(allowed, 144, False))[0]
    passed, sentence = verify_verdict(table(allowed + 1, 144, False))
    assert not passed and "another platform" in sentence


def test_the_committed_full_references_cover_every_cell_of_quick_and_full():
    path = packaged_references("full")
    assert path is not None and path.name == "references-full.json"
    assert packaged_references("quick") == path
    for size in ("quick", "full"):
        for tasks in (None, ["all"]):  # push alone, and every task (issue 35's task axis)
            config = protocol_config(size, tasks=tasks)
            cells = load_references(path, config=config)  # plan, size, p^X and set must match
            assert all((i.label, d) in cells for i, d in config.cells()), (size, tasks)
    cells = load_references(path)
    assert len(cells) == 72 + 3 * 16  # push's 24 instances x 3 d, each task's 16 at d = 3
    for cell in cells.values():
        assert cell["f_ref"] < cell["f_straight"] and cell["noise_floor"] > 0
        assert min(cell["random_pool"]) >= cell["f_ref"] or "unstable_better" in cell


@pytest.mark.slow
def test_the_committed_full_references_evaluate_again_to_what_they_say():
    """Two evaluations a cell, 144 in all: the physics under them has not moved."""
    from benchmarks.protocol import verify_references
    from benchmarks.protocol.references import verify_verdict

    path = packaged_references("full")
    table = verify_references(path, protocol_config("full").replace(workers=2))
    passed, sentence = verify_verdict(table)
    if table.attrs["same_platform"]:
        assert table["identical"].all(), table[~table["identical"]]
        assert passed, sentence
    elif not passed:
        pytest.skip(f"another platform than the references': {sentence}")
