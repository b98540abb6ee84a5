"""A tampered suite run folder is refused by resume, report and html, and nothing in it changes.

Design, box-path, retest and consolidated files are checksummed in the manifest
(``extra.file_sha256``) like the part files; the manifest's own fields and every design file are
checked for their form; a folder written before ``file_sha256`` existed still reads and resumes.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest

from benchmarks.cli import main
from benchmarks.reports.html import write_html_report
from benchmarks.reports.suite import make_suite_report
from benchmarks.storage import (
    DESIGNS_DIR,
    FILE_CHECKSUMS,
    PART_CHECKSUMS,
    ResultStore,
    ResumeError,
    file_sha256,
    read_designs,
    read_manifest,
    read_retests,
    retest_path,
    write_retest,
)
from benchmarks.storage.session import HEARTBEAT, RunSession
from benchmarks.suites import load_suite
from benchmarks.suites.runner import run_suite

TINY = (
    'name = "tiny"\n'
    "goal = [0.0, 1.5, 0.1]\n"
    "goal_precision = 20.0\n"
    "box_mass = 0.1\n"
    "batch_size = 3\n"
    "iterations = 2\n"
    "root_seed = 7\n"
    "n_seeds = 1\n"
    "test_robustness = true\n"
    "robustness_masses = [0.3]\n"
    "keep_paths = true\n"
    "figures = []\n"
    'executor = "serial"\n'
    '[[variants]]\nname = ""\n'
    '[[optimizers]]\nname = "random"\n'
)


@pytest.fixture(scope="module")
def config_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("config") / "tiny.toml"
    path.write_text(TINY, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def finished(config_file: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("finished") / "run"
    run_suite(load_suite(config_file), out, progress=False)
    make_suite_report(out, n_boot=50)
    return out


@pytest.fixture()
def run(finished: Path, tmp_path: Path) -> Path:
    """A fresh copy of the finished suite folder."""
    out = tmp_path / "run"
    shutil.copytree(finished, out)
    return out


def snapshot(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def design_file(folder: Path) -> Path:
    return next(p for p in (folder / DESIGNS_DIR).rglob("seed=*.json") if ".paths" not in p.name)


def edit_json(path: Path, edit: Callable[[dict], None]) -> None:
    data = json.loads(path.read_text(encoding="utf-8"))
    edit(data)
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")


def edit_manifest(folder: Path, edit: Callable[[dict], None]) -> None:
    edit_json(folder / "manifest.json", edit)


def resume(config_file: Path, folder: Path) -> None:
    run_suite(load_suite(config_file), folder, progress=False)


def refused_everywhere(config_file: Path, folder: Path, name: str) -> None:
    """Resume, report and html all refuse ``folder`` naming ``name``, and change nothing."""
    before = snapshot(folder)
    with pytest.raises(ResumeError, match=name):
        resume(config_file, folder)
    with pytest.raises(ValueError, match=name):
        make_suite_report(folder, n_boot=50)
    with pytest.raises(ValueError, match=name):
        write_html_report(folder)
    assert snapshot(folder) == before


# --- 1. design, box-path and retest files are checksummed ---------------------------------------


@pytest.mark.slow
def test_the_manifest_records_every_design_and_the_consolidated_file(finished: Path) -> None:
    recorded = read_manifest(finished)["extra"][FILE_CHECKSUMS]
    designs = sorted(p.relative_to(finished).as_posix() for p in finished.rglob("seed=*.json"))
    assert len(designs) == 2  # the design file and its box-path file
    assert sorted(recorded) == sorted([*designs, "evaluations.parquet"])
    for relative, digest in recorded.items():
        assert hashlib.sha256((finished / relative).read_bytes()).hexdigest() == digest


@pytest.mark.slow
@pytest.mark.parametrize(
    "edit",
    [
        lambda d: d.update(free_energy=-1e6),
        lambda d: d["coefficients"].__setitem__(0, 0.123),
    ],
    ids=["free_energy", "c1"],
)
def test_an_edited_design_file_is_refused(
    config_file: Path, run: Path, edit: Callable[[dict], None]
) -> None:
    path = design_file(run)
    edit_json(path, edit)
    refused_everywhere(config_file, run, "has changed since it was written")
    with pytest.raises(ValueError, match=path.name):
        read_designs(run)


def test_an_edited_or_removed_box_path_file_is_refused(config_file: Path, run: Path) -> None:
    paths = next((run / DESIGNS_DIR).rglob("*.paths.json"))
    paths.write_bytes(paths.read_bytes()[:-10])
    refused_everywhere(config_file, run, "paths.json has changed")
    paths.unlink()
    refused_everywhere(config_file, run, "paths.json is listed in the manifest but missing")


def test_the_cli_refuses_an_edited_design_file_in_one_line(
    config_file: Path, run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    edit_json(design_file(run), lambda d: d.update(free_energy=-1e6))
    for argv in (
        ["bench", "--config", str(config_file), "--out", str(run), "--no-progress"],
        ["report", str(run)],
        ["html", str(run)],
    ):
        with pytest.raises(SystemExit) as exit_info:
            main(argv)
        assert exit_info.value.code == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and len(err.strip().splitlines()) == 1
        assert "seed=" in err and "has changed since it was written" in err


@pytest.mark.slow
def test_an_edited_retest_file_is_refused(run: Path) -> None:
    target = retest_path(run, design_file(run))
    record = {"variant": "", "optimizer": "random", "seed": 1, "noise": [], "stress": []}
    metrics = {"goal_error": 0.0, "confidence": 1.0, "final_distance": 0.1}
    record["noise"] = [{"nudge": k, "free_energy": 1.0 + k, **metrics} for k in range(3)]
    write_retest(run, target, json.dumps(record))
    recorded = read_manifest(run)["extra"][FILE_CHECKSUMS]
    assert target.relative_to(run).as_posix() in recorded
    assert read_retests(run)[0]["noise"][1]["free_energy"] == 2.0
    make_suite_report(run, n_boot=50)  # the report reads it
    edit_json(target, lambda d: d["noise"][1].update(free_energy=-777))
    before = snapshot(run)
    with pytest.raises(ValueError, match="retest/.*has changed since it was written"):
        read_retests(run)
    with pytest.raises(ValueError, match="has changed since it was written"):
        make_suite_report(run, n_boot=50)
    assert snapshot(run) == before
    # Rewritten through write_retest (a retest with other settings), it is recorded again.
    write_retest(run, target, json.dumps(record))
    assert read_retests(run)[0]["noise"][1]["free_energy"] == 2.0


@pytest.mark.slow
def test_tooldesign_retest_records_its_files_and_refuses_edited_ones(run: Path, capsys) -> None:
    argv = ["retest", str(run), "--nudges", "2", "--repeats", "1", "--masses", "0.5"]
    assert main([*argv, "--frictions", "0.3", "--workers", "1"]) == 0
    target = retest_path(run, design_file(run))
    recorded = read_manifest(run)["extra"][FILE_CHECKSUMS]
    assert target.relative_to(run).as_posix() in recorded
    edit_json(target, lambda d: d["noise"][0].update(free_energy=-777))
    before = snapshot(run)
    for command in (argv, ["report", str(run)]):
        with pytest.raises(SystemExit) as exit_info:
            main(command)
        assert exit_info.value.code == 2
        assert "has changed since it was written" in capsys.readouterr().err
    assert snapshot(run) == before


def test_an_unrecorded_design_file_is_checked_and_recorded_on_resume(
    config_file: Path, run: Path
) -> None:
    """A design file written just before a kill, ahead of its manifest, is recorded on resume."""
    path = design_file(run)
    relative = path.relative_to(run).as_posix()
    edit_manifest(run, lambda m: m["extra"][FILE_CHECKSUMS].pop(relative))
    before = path.read_bytes()
    resume(config_file, run)
    assert path.read_bytes() == before
    assert relative in read_manifest(run)["extra"][FILE_CHECKSUMS]


# --- 2. report and html check the checksums resume checks ---------------------------------------


def test_an_edited_part_file_is_refused_by_report_and_html(config_file: Path, run: Path) -> None:
    part = sorted((run / "parts").rglob("iteration=*.csv"))[-1]
    frame = pd.read_csv(part)
    frame.loc[0, "free_energy"] = -5.0
    frame.to_csv(part, index=False)
    refused_everywhere(config_file, run, "iteration=000001.csv has changed")
    with pytest.raises(ValueError, match="has changed"):
        ResultStore(run).read()


@pytest.mark.slow
def test_an_edited_consolidated_file_is_refused_without_parts(run: Path) -> None:
    shutil.rmtree(run / "parts")
    make_suite_report(run, n_boot=50)  # a folder shared without its parts reads
    path = run / "evaluations.parquet"
    frame = pd.read_parquet(path)
    frame.loc[0, "free_energy"] = -9.0
    frame.to_parquet(path, index=False)
    before = snapshot(run)
    for read in (
        ResultStore(run).read,
        lambda: make_suite_report(run),
        lambda: write_html_report(run),
    ):
        with pytest.raises(ValueError, match="evaluations.parquet has changed"):
            read()
    assert snapshot(run) == before


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["truncate", "delete"])
def test_resume_rebuilds_a_damaged_consolidated_file_from_intact_parts(
    config_file: Path, run: Path, damage: str
) -> None:
    """Audit item 3: the table is derived from the checksummed parts; it must not block."""
    path = run / "evaluations.parquet"
    before = ResultStore(run).read()
    if damage == "truncate":
        path.write_bytes(path.read_bytes()[:100])
    else:
        path.unlink()
    designs = {p: p.read_bytes() for p in (run / DESIGNS_DIR).rglob("*.json")}
    with pytest.warns(RuntimeWarning, match=r"evaluations\.parquet .*; rebuilt as .* part files"):
        resume(config_file, run)
    pd.testing.assert_frame_equal(pd.read_parquet(path), before)
    assert read_manifest(run)["extra"][FILE_CHECKSUMS]["evaluations.parquet"] == file_sha256(path)
    assert {p: p.read_bytes() for p in designs} == designs  # original data left as it was


def test_resume_refuses_a_damaged_consolidated_file_that_is_the_only_copy(
    config_file: Path, run: Path
) -> None:
    """Without parts (a folder shared without them), the table is original data: refused."""
    shutil.rmtree(run / "parts")
    edit_manifest(run, lambda m: m["extra"].update({PART_CHECKSUMS: {}}))
    path = run / "evaluations.parquet"
    path.write_bytes(path.read_bytes()[:100])
    before = snapshot(run)
    with pytest.raises(ResumeError, match="evaluations.parquet has changed since it was written"):
        resume(config_file, run)
    assert snapshot(run) == before


def test_resume_refuses_a_damaged_design_file_although_the_table_is_rebuilt(
    config_file: Path, run: Path
) -> None:
    """A suite's design files are original data (a finished run is not run again)."""
    (run / "evaluations.parquet").unlink()
    design = design_file(run)
    design.write_bytes(design.read_bytes()[:-5])
    before = snapshot(run)
    with pytest.raises(ResumeError, match=f"{design.name} has changed"):
        resume(config_file, run)
    assert snapshot(run) == before


def test_two_unrecorded_parts_are_refused_by_report(run: Path) -> None:
    edit_manifest(run, lambda m: m["extra"].update({PART_CHECKSUMS: {}}))
    with pytest.raises(ValueError, match="does not record"):
        make_suite_report(run, n_boot=50)


# --- compatibility: a folder written before file_sha256 -----------------------------------------


@pytest.mark.slow
def test_a_folder_without_file_checksums_reads_and_resumes(config_file: Path, run: Path) -> None:
    edit_manifest(run, lambda m: m["extra"].pop(FILE_CHECKSUMS))
    assert len(read_designs(run)) == 1
    make_suite_report(run, n_boot=50)
    write_html_report(run)
    resume(config_file, run)  # the design files are recorded from now on
    recorded = read_manifest(run)["extra"][FILE_CHECKSUMS]
    assert design_file(run).relative_to(run).as_posix() in recorded
    assert "evaluations.parquet" in recorded


def test_the_committed_results_still_read() -> None:
    folder = Path(__file__).resolve().parents[1] / "docs" / "results" / "robust-design"
    ResultStore(folder).verify()
    assert read_designs(folder)
    assert read_retests(folder)
    assert len(ResultStore(folder).read())


# --- 3. a malformed manifest or heartbeat: one message naming the file and the field ------------


def _set_session(field: str, value: object) -> Callable[[dict], None]:
    return lambda m: m["extra"]["sessions"][0].update({field: value})


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda m: m.pop("start_time"), "'start_time'"),
        (lambda m: m.update(start_time="garbage"), "'start_time'"),
        (lambda m: m.update(start_time=5), "'start_time'"),
        (lambda m: m["extra"].update(sessions="abc"), "'extra.sessions'"),
        (lambda m: m["extra"].update(sessions=["abc"]), r"'extra.sessions\[0\]'"),
        (_set_session("wall_time", "y"), r"'extra.sessions\[0\].wall_time'"),
        (_set_session("wall_time", -1e9), r"'extra.sessions\[0\].wall_time'"),
        (_set_session("wall_time", 1.7e308), r"'extra.sessions\[0\].wall_time'"),
        (_set_session("start_time", "x"), r"'extra.sessions\[0\].start_time'"),
        (lambda m: m["extra"].update({FILE_CHECKSUMS: [1]}), "'extra.file_sha256'"),
        (lambda m: m["extra"].update({FILE_CHECKSUMS: {"a": "0"}}), "'extra.file_sha256'"),
        (lambda m: m.update(config=None), "'config'"),
        (lambda m: m.update(config=[1, 2]), "'config'"),
        (lambda m: m.pop("config"), "'config'"),
        (lambda m: m.update(extra=5), "'extra'"),
    ],
    ids=[
        "start-missing",
        "start-garbage",
        "start-int",
        "sessions-str",
        "session-str",
        "wall-str",
        "wall-negative",
        "wall-huge",
        "session-start",
        "files-list",
        "files-bad-digest",
        "config-null",
        "config-list",
        "config-missing",
        "extra-int",
    ],
)
def test_a_malformed_manifest_is_refused_naming_the_field(
    config_file: Path, run: Path, edit: Callable[[dict], None], field: str
) -> None:
    edit_manifest(run, edit)
    before = snapshot(run)
    with pytest.raises(ResumeError, match=f"manifest.json: field {field} (must be|holds)"):
        resume(config_file, run)
    assert snapshot(run) == before


def test_a_design_folder_without_a_config_is_not_called_a_folder_of_another_kind(
    tmp_path: Path,
) -> None:
    """Audit item 8: "X is a design run folder (...), not a design run folder"."""
    out = tmp_path / "run"
    RunSession(out, kind="design", config={"seed": 0}, resume=False).finish(None)
    edit_manifest(out, lambda m: m.update(config=None))
    before = snapshot(out)
    with pytest.raises(ResumeError) as caught:
        RunSession(out, kind="design", config={"seed": 0}, resume=True)
    message = str(caught.value)
    assert "manifest.json: field 'config' must be a JSON object" in message
    assert "got null" in message
    assert "not a design run folder" not in message
    assert snapshot(out) == before


def test_a_manifest_that_is_not_utf8_is_refused_naming_it(config_file: Path, run: Path) -> None:
    (run / "manifest.json").write_bytes(b"\xff\xfe{}")
    for call in (lambda: resume(config_file, run), lambda: make_suite_report(run)):
        with pytest.raises(ValueError, match="manifest.json is not UTF-8 text"):
            call()


def test_a_heartbeat_of_an_impossible_wall_time_is_left_out(config_file: Path, run: Path) -> None:
    start = read_manifest(run)["extra"]["sessions"][0]["start_time"]
    (run / HEARTBEAT).write_text(json.dumps({"start_time": start, "wall_time": 1.79e308}))
    with pytest.warns(RuntimeWarning, match="heartbeat.json cannot be read.*'wall_time'"):
        resume(config_file, run)
    assert read_manifest(run)["wall_time"] < 1e6


# --- 4. a malformed design file: one message naming the file ------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"[1, 2]", "must hold a JSON object, got list"),
        (b"{}", "field 'variant' must be a string"),
        (b"null", "must hold a JSON object, got null"),
        (b"\xff\xfe", "not UTF-8 text"),
        (b'{"free_energy": NaN}', "NaN"),
        (b'{"variant": "", "optimizer": "random", "seed": 5}', "which belongs in"),
    ],
    ids=["list", "empty", "null", "not-utf8", "nan", "other-run"],
)
def test_a_malformed_design_file_is_refused_naming_it(
    config_file: Path, run: Path, content: bytes, message: str
) -> None:
    path = design_file(run)
    # As in a folder written before design files were checksummed: only the form is checked.
    edit_manifest(run, lambda m: m["extra"].pop(FILE_CHECKSUMS))
    path.write_bytes(content)
    before = snapshot(run)
    with pytest.raises(ResumeError, match=f"{path.name}.*{message}"):
        resume(config_file, run)
    with pytest.raises(ValueError, match=f"{path.name}.*{message}"):
        make_suite_report(run, n_boot=50)
    assert snapshot(run) == before


def test_a_truncated_box_path_file_is_named(run: Path) -> None:
    edit_manifest(run, lambda m: m["extra"].pop(FILE_CHECKSUMS))
    paths = next((run / DESIGNS_DIR).rglob("*.paths.json"))
    paths.write_bytes(paths.read_bytes()[:50])
    with pytest.raises(ValueError, match=r"\.paths\.json: not a valid box-path file"):
        read_designs(run)


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_consolidating_a_finished_folder_in_the_other_format_keeps_it_readable(
    config_file: Path, run: Path, fmt: str
) -> None:
    """The documented way to get CSV (results-format.md) must not orphan the manifest's entry."""
    before = ResultStore(run).read()
    target = ResultStore(run).consolidate(format=fmt)
    recorded = read_manifest(run)["extra"][FILE_CHECKSUMS]
    names = {k for k in recorded if k.startswith("evaluations.")}
    assert names == {target.name}
    assert recorded[target.name] == file_sha256(target)
    pd.testing.assert_frame_equal(ResultStore(run).read(), before)
    make_suite_report(run, n_boot=50)
    resume(config_file, run)  # a later session accepts the folder too
    pd.testing.assert_frame_equal(ResultStore(run).read(), before)


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_a_consolidation_interrupted_at_the_manifest_leaves_the_folder_readable(
    run: Path, fmt: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C between writing the new consolidated file and the manifest (issue 4's audit)."""
    import benchmarks.storage.table as table

    before = ResultStore(run).read()

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(table, "update_file_checksums", interrupted)
    with pytest.raises(KeyboardInterrupt):
        ResultStore(run).consolidate(format=fmt)
    monkeypatch.undo()
    pd.testing.assert_frame_equal(ResultStore(run).read(), before)
    make_suite_report(run, n_boot=50)
    ResultStore(run).consolidate(format=fmt)  # and it can be done again
    pd.testing.assert_frame_equal(ResultStore(run).read(), before)
