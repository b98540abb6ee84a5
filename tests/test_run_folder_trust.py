"""A run folder received from someone else is data: readers stay inside it (issue 33).

``tooldesign report``, ``html``, ``retest`` and a resumed run read only regular files inside the
folder (no symbolic link followed, no ``..``, no FIFO opened, no file past the size limit), check
every file they use against the manifest's checksums (the consolidated table too), write only
inside the folder and never through a link, and ``html`` refuses a folder of no known kind and a
page it did not write. Each case also checks that nothing outside the folder changed.
"""

from __future__ import annotations

import json
import os
import shutil
import string
import tempfile
import warnings
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.cli import main
from benchmarks.reports.html import REPORT_FILE, write_html_report
from benchmarks.reports.reproduction import _claim_a
from benchmarks.reports.suite import make_suite_report
from benchmarks.reports.verdicts import read_report_tables
from benchmarks.storage import (
    DESIGNS_DIR,
    FILE_CHECKSUMS,
    PART_CHECKSUMS,
    REPORT_CHECKSUMS,
    ResultStore,
    ResumeError,
    UnsafeRunFileError,
    check_write_folder,
    file_sha256,
    list_run_files,
    read_designs,
    read_run_file,
    run_file_path,
)
from benchmarks.storage.runfolder import RUN_KINDS, read_report_file, run_folder_kind
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
    "test_robustness = false\n"
    "keep_paths = true\n"
    "figures = []\n"
    'executor = "serial"\n'
    '[[variants]]\nname = ""\n'
    '[[optimizers]]\nname = "random"\n'
)
SECRET = "root:x:0:0:a local secret that must never reach a report\n"


@pytest.fixture(scope="module")
def config_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("config") / "tiny.toml"
    path.write_text(TINY, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def finished(config_file: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("finished") / "run"
    run_suite(load_suite(config_file), out, progress=False)
    make_suite_report(out, n_boot=20)
    return out


@pytest.fixture()
def place(finished: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A fresh copy of the finished run, and a folder outside it holding a local secret."""
    run = tmp_path / "run"
    shutil.copytree(finished, run)
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.txt").write_text(SECRET)
    (outside / "summary.md").write_text("the user's own file\n")
    return run, outside


def snapshot(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def edit_manifest(run: Path, edit) -> None:  # type: ignore[no-untyped-def]
    path = run / "manifest.json"
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")


def resume(config_file: Path, run: Path) -> None:
    run_suite(load_suite(config_file), run, progress=False)


def test_the_run_kinds_are_the_commands_kinds() -> None:
    from benchmarks.design.config import DESIGN_SUITE
    from benchmarks.rl.suite import RL_SUITE_KIND
    from benchmarks.suites.config import SUITE_KIND

    assert set(RUN_KINDS) == {DESIGN_SUITE, SUITE_KIND, RL_SUITE_KIND}


# --- links inside the folder ---------------------------------------------------------------------
def test_a_linked_file_is_not_embedded_in_the_page(place: tuple[Path, Path]) -> None:
    run, outside = place
    (run / "notes.txt").symlink_to(outside / "secret.txt")
    (run / "report" / "leak.md").symlink_to(outside / "secret.txt")
    with pytest.warns(RuntimeWarning, match="notes.txt is left out of the page: it is a symbolic"):
        page = write_html_report(run)
    text = page.read_text()
    assert "a local secret" not in text and "notes.txt" not in text and "leak.md" not in text
    assert (outside / "secret.txt").read_text() == SECRET


def test_a_linked_report_folder_is_not_written_through(place: tuple[Path, Path]) -> None:
    run, outside = place
    shutil.rmtree(run / "report")
    (run / "report").symlink_to(outside, target_is_directory=True)
    before = snapshot(outside)
    with pytest.raises(UnsafeRunFileError, match="report is a symbolic link; nothing is written"):
        make_suite_report(run, n_boot=20)
    with pytest.raises(SystemExit) as exit_info:
        main(["report", str(run)])
    assert exit_info.value.code == 2
    assert snapshot(outside) == before
    # The user's own choice of folder is theirs: --out elsewhere still works.
    assert make_suite_report(run, out_dir=run.parent / "elsewhere", n_boot=20)


@pytest.mark.parametrize("linked", ["design", "part", "parts dir", "manifest"])
def test_a_linked_file_the_readers_use_is_refused(
    config_file: Path, place: tuple[Path, Path], linked: str
) -> None:
    run, outside = place
    if linked == "design":
        path = next((run / DESIGNS_DIR).rglob("seed=*.json"))
    elif linked == "part":
        path = sorted((run / "parts").rglob("*.csv"))[0]
    elif linked == "parts dir":
        path = run / "parts"
    else:
        path = run / "manifest.json"
    copy = outside / "copy"
    if path.is_dir():
        shutil.copytree(path, copy)
        shutil.rmtree(path)
    else:
        shutil.copy(path, copy)  # the same bytes: only the link is wrong
        path.unlink()
    path.symlink_to(copy)
    before, outside_before = snapshot(run), snapshot(outside)
    for read in (
        lambda: make_suite_report(run, n_boot=20),
        lambda: write_html_report(run),
        lambda: resume(config_file, run),
    ):
        with pytest.raises(ValueError, match="symbolic link"):
            read()
    assert snapshot(run) == before and snapshot(outside) == outside_before


def test_the_folder_named_may_be_a_link_and_is_read_where_it_points(
    place: tuple[Path, Path], tmp_path: Path
) -> None:
    run, outside = place
    link = tmp_path / "latest"
    link.symlink_to(run, target_is_directory=True)
    outside_before = snapshot(outside)
    assert make_suite_report(link, n_boot=20)
    assert write_html_report(link) == link / REPORT_FILE
    assert (run / REPORT_FILE).is_file() and link.is_symlink()
    assert snapshot(outside) == outside_before


# --- the manifest's entries ----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("entry", "words"),
    [
        ("../outside/secret.txt", "goes up with '..', outside the run folder"),
        ("/etc/passwd", "is absolute, outside the run folder"),
        ("designs//x.json", "has an empty or '.' part"),
        ("designs\\x.json", "backslash"),
    ],
)
def test_a_manifest_entry_outside_the_folder_is_refused_in_words(
    config_file: Path, place: tuple[Path, Path], entry: str, words: str
) -> None:
    run, outside = place
    digest = file_sha256(outside / "secret.txt")
    edit_manifest(run, lambda m: m["extra"][FILE_CHECKSUMS].update({entry: digest}))
    before = snapshot(run)
    for read in (
        lambda: make_suite_report(run, n_boot=20),
        lambda: write_html_report(run),
        ResultStore(run).read,
    ):
        with pytest.raises(ValueError, match="which is refused") as info:
            read()
        message = str(info.value)
        assert f"lists {entry!r}" in message and words in message, message
        assert "bad checksum entry" not in message
    with pytest.raises(ResumeError, match="outside the run folder|empty or|backslash"):
        resume(config_file, run)
    assert snapshot(run) == before


# --- the consolidated table ----------------------------------------------------------------------
def test_an_edited_consolidated_table_beside_its_parts_is_warned_about_and_not_shown(
    place: tuple[Path, Path],
) -> None:
    """Issue 33, case 4: one digit of F edited, the checksummed parts intact."""
    run, _ = place
    ResultStore(run).consolidate("csv")  # the evaluations.csv
    summary = (run / "report" / "summary.csv").read_bytes()
    path = run / "evaluations.csv"
    text = path.read_text()
    f = str(pd.read_csv(path)["free_energy"].iloc[0])
    edited = text.replace(f, "1" + f[1:] if f[0] != "1" else "2" + f[1:], 1)
    assert edited != text
    path.write_text(edited)
    with pytest.warns(RuntimeWarning, match="evaluations.csv has changed since it was written"):
        make_suite_report(run, n_boot=20)
    with pytest.warns(RuntimeWarning, match="evaluations.csv is left out of the page"):
        page = write_html_report(run)
    assert "evaluations.csv" not in page.read_text()
    assert (run / "report" / "summary.csv").read_bytes() == summary  # from the parts alone


def test_an_unlisted_table_beside_the_recorded_one_is_never_read(place: tuple[Path, Path]) -> None:
    run, _ = place
    shutil.rmtree(run / "parts")
    edit_manifest(run, lambda m: m["extra"].update({PART_CHECKSUMS: {}}))
    recorded = ResultStore(run).read()
    (run / "evaluations.csv").write_text("free_energy\n1\n")  # not in the manifest
    with pytest.warns(RuntimeWarning, match="evaluations.csv is left out of the page"):
        write_html_report(run)
    pd.testing.assert_frame_equal(ResultStore(run).read(), recorded)  # the parquet, checked


# --- pages the command did not write ----------------------------------------------------------
def test_html_refuses_a_folder_that_is_not_a_run(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    folder = tmp_path / "documents"
    folder.mkdir()
    (folder / "notes.txt").write_text("private")
    (folder / "manifest.json").write_text('{"extra": {"kind": "photos"}}')
    with pytest.raises(SystemExit) as exit_info:
        main(["html", str(folder)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "names no run of a known kind" in err and err.count("\n") == 1
    (folder / "manifest.json").unlink()
    with pytest.raises(ValueError, match="is not a run folder"):
        run_folder_kind(folder)
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]


def test_html_never_overwrites_a_page_it_did_not_write(
    place: tuple[Path, Path], tmp_path: Path
) -> None:
    run, outside = place
    own = run / REPORT_FILE
    own.write_text("<html>the user's own report</html>")
    with pytest.raises(UnsafeRunFileError, match="was not written by tooldesign html"):
        write_html_report(run)
    assert own.read_text() == "<html>the user's own report</html>"
    # Nor as --out, nor through a link.
    with pytest.raises(UnsafeRunFileError, match="was not written by tooldesign html"):
        write_html_report(run, out=outside / "summary.md")
    own.unlink()
    own.symlink_to(outside / "secret.txt")
    with pytest.raises(UnsafeRunFileError, match="is a symbolic link"):
        write_html_report(run)
    assert (outside / "secret.txt").read_text() == SECRET
    own.unlink()
    first = write_html_report(run)  # its own page it rewrites
    assert write_html_report(run) == first


# --- FIFOs, huge files, hard links ---------------------------------------------------------------
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_never_opened_for_reading(config_file: Path, place: tuple[Path, Path]) -> None:
    run, _ = place
    os.mkfifo(run / "notes.txt")  # opening it to read would block forever
    with pytest.warns(RuntimeWarning, match="notes.txt is left out of the page: it is a FIFO"):
        write_html_report(run)
    design = next((run / DESIGNS_DIR).rglob("seed=*.json"))
    design.unlink()
    os.mkfifo(design)
    with pytest.raises(ValueError, match="is a FIFO"):
        read_designs(run)
    with pytest.raises(ResumeError, match="is a FIFO"):
        resume(config_file, run)


def test_a_huge_file_is_refused_before_it_is_read(place: tuple[Path, Path]) -> None:
    run, _ = place
    shutil.rmtree(run / "parts")
    edit_manifest(run, lambda m: m["extra"].update({PART_CHECKSUMS: {}}))
    table = run / "evaluations.parquet"
    with open(table, "r+b") as handle:
        handle.truncate(3 << 30)  # sparse: 3 GiB that take no room
    with pytest.raises(UnsafeRunFileError, match="more than the .* a run file may have"):
        ResultStore(run).read()
    with open(run / "report" / "big.png", "wb") as handle:
        handle.truncate(100 << 20)
    table.unlink()
    edit_manifest(run, lambda m: m["extra"][FILE_CHECKSUMS].pop("evaluations.parquet"))
    with pytest.warns(RuntimeWarning, match="big.png is left out of the page: it is 104857600"):
        page = write_html_report(run)
    assert page.stat().st_size < 50 << 20


def test_a_hard_link_is_read_for_its_bytes_and_never_written_through(
    place: tuple[Path, Path],
) -> None:
    run, outside = place
    summary = run / "report" / "summary.md"
    summary.unlink()
    os.link(outside / "summary.md", summary)  # the same file under two names
    make_suite_report(run, n_boot=20)  # rewrites report/summary.md
    assert (outside / "summary.md").read_text() == "the user's own file\n"
    assert summary.read_text() != "the user's own file\n"


# --- property-based: no path and no edit gets past the readers ---------------------------------
_PATH_TEXT = st.text(alphabet=string.ascii_letters + "./\\\x00:~ -_", max_size=24)


@settings(max_examples=300, deadline=None)
@given(relative=_PATH_TEXT)
def test_no_relative_path_leads_outside_the_folder(tmp_path_factory, relative: str) -> None:  # type: ignore[no-untyped-def]
    folder = Path("/nonexistent/run")
    try:
        path = run_file_path(folder, relative)
    except UnsafeRunFileError:
        return
    resolved = Path(os.path.normpath(path))
    assert folder in resolved.parents, (relative, path)


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_any_edit_of_a_recorded_file_is_refused_or_left_out(
    finished: Path, tmp_path: Path, data: st.DataObject
) -> None:
    run = tmp_path / f"run{len(list(tmp_path.iterdir()))}"
    shutil.copytree(finished, run)
    manifest = json.loads((run / "manifest.json").read_text())["extra"]
    recorded = sorted({**manifest[PART_CHECKSUMS], **manifest[FILE_CHECKSUMS]})
    relative = data.draw(st.sampled_from(recorded), label="file")
    path = run / relative
    raw = bytearray(path.read_bytes())
    kind = data.draw(st.sampled_from(["flip", "truncate", "append", "link", "delete"]))
    if kind == "flip":
        at = data.draw(st.integers(0, len(raw) - 1), label="byte")
        raw[at] ^= data.draw(st.integers(1, 255), label="xor")
        path.write_bytes(bytes(raw))
    elif kind == "truncate":
        path.write_bytes(bytes(raw[: data.draw(st.integers(0, len(raw) - 1))]))
    elif kind == "append":
        path.write_bytes(bytes(raw) + b"0")
    elif kind == "link":
        copy = tmp_path / f"copy-{run.name}"
        copy.write_bytes(bytes(raw))
        path.unlink()
        path.symlink_to(copy)
    else:
        path.unlink()
    before = snapshot(run)
    table = relative.startswith("evaluations.")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            untrusted = ResultStore(run).verify()
        except ValueError:
            refused = True
        else:
            refused = False
    if table and kind != "delete":
        # A copy beside the parts: not used, and said so.
        assert not refused and relative in untrusted
        assert any(relative in str(w.message) for w in caught)
    elif table:
        assert not refused  # a table deleted beside its parts: the parts are read
    else:
        assert refused
        with pytest.raises(ValueError):
            write_html_report(run)
    assert snapshot(run) == before


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    command=st.sampled_from(["html", "report"]),
    argument=st.text(
        alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
        max_size=30,
    ),
)
def test_any_folder_argument_is_one_line_or_a_page(
    command: str, argument: str, capsys: pytest.CaptureFixture[str]
) -> None:
    if argument.startswith("-") or not argument.strip():
        return  # argparse's own handling of options
    capsys.readouterr()
    here = os.getcwd()
    os.chdir(tempfile.mkdtemp())  # an argument such as "." names an empty folder, not the repo
    try:
        code = main([command, argument])
    except SystemExit as exit_info:
        code = exit_info.code
    finally:
        os.chdir(here)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, (argument, err)


def test_list_run_files_never_descends_a_link(tmp_path: Path) -> None:
    run = tmp_path / "run"
    (run / "a").mkdir(parents=True)
    (run / "a" / "x.json").write_text("{}")
    (run / "b").symlink_to(tmp_path, target_is_directory=True)
    (run / "c.txt").symlink_to(run / "a" / "x.json")
    files, left_out = list_run_files(run)
    assert files == ["a/x.json"]
    assert left_out == {"b": "a symbolic link", "c.txt": "a symbolic link"}
    assert read_run_file(run, "a/x.json") == b"{}"
    with pytest.raises(UnsafeRunFileError, match="symbolic link"):
        read_run_file(run, "c.txt")
    with pytest.raises(UnsafeRunFileError, match="symbolic link"):
        read_run_file(run, "b/run/a/x.json")


def test_a_resume_writes_nothing_through_a_linked_folder(
    config_file: Path, place: tuple[Path, Path]
) -> None:
    run, outside = place
    empty = outside / "elsewhere"
    empty.mkdir()
    shutil.rmtree(run / DESIGNS_DIR)  # the suite would write its design files again
    (run / DESIGNS_DIR).symlink_to(empty, target_is_directory=True)
    edit_manifest(
        run,
        lambda m: m["extra"].update(
            {
                FILE_CHECKSUMS: {
                    k: v for k, v in m["extra"][FILE_CHECKSUMS].items() if "designs/" not in k
                }
            }
        ),
    )
    before = snapshot(outside)
    with pytest.raises(ResumeError, match="designs is a symbolic link; a run folder holds regular"):
        resume(config_file, run)
    assert snapshot(outside) == before and not list(empty.iterdir())


def test_report_keeps_a_report_html_of_the_users_own(place: tuple[Path, Path], capsys) -> None:  # type: ignore[no-untyped-def]
    run, _ = place
    (run / REPORT_FILE).write_text("<p>mine</p>")
    assert main(["report", str(run)]) == 0
    assert "left as it is" in capsys.readouterr().out
    assert (run / REPORT_FILE).read_text() == "<p>mine</p>"


# --- where a command writes ----------------------------------------------------------------------
def test_an_out_folder_named_through_dotdot_is_where_it_leads(
    place: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``run/../outdir`` is ``outdir``, as its absolute path is: accepted, written there."""
    run, _ = place
    monkeypatch.chdir(run.parent)
    assert main(["report", "run", "--out", "run/../outdir"]) == 0
    assert (run.parent / "outdir" / "summary.csv").is_file()
    # Back into the run folder through '..' is inside it: still checked, link and all.
    shutil.rmtree(run / "report")
    (run / "report").symlink_to(run.parent / "outdir", target_is_directory=True)
    before = snapshot(run.parent / "outdir")
    for out in ("run/../run/report", str(run / ".." / "run" / "report")):
        with pytest.raises(UnsafeRunFileError, match="report is a symbolic link"):
            check_write_folder(run, out)
    # Nor through a link of the run folder reached by '..' after it.
    with pytest.raises(UnsafeRunFileError, match="report is a symbolic link"):
        check_write_folder(run, "run/report/../x")
    # The user's own link outside the run folder is followed, part by part.
    (run.parent / "latest").symlink_to(run, target_is_directory=True)
    with pytest.raises(UnsafeRunFileError, match="report is a symbolic link"):
        check_write_folder(run, "latest/report")
    (run.parent / "shortcut").symlink_to(run / "report", target_is_directory=True)
    with pytest.raises(UnsafeRunFileError, match="report is a symbolic link"):
        check_write_folder(run, run.parent / "shortcut")
    assert check_write_folder("latest", "latest/designs") == Path("latest/designs")
    assert snapshot(run.parent / "outdir") == before


# --- report files: recorded when written, checked when read (M1) --------------------------------
def _edit_summary_f(run: Path) -> str:
    """Change one digit of a final F in report/summary.csv; the edited number, as text."""
    path = run / "report" / "summary.csv"
    frame = pd.read_csv(path)
    edited = "123456.789"
    text = path.read_text()
    value = repr(float(frame["final_free_energy"].iloc[0]))
    assert value in text or str(frame["final_free_energy"].iloc[0]) in text
    old = value if value in text else str(frame["final_free_energy"].iloc[0])
    path.write_text(text.replace(old, edited, 1))
    return edited


def test_the_report_files_are_recorded_when_written(finished: Path) -> None:
    extra = json.loads((finished / "manifest.json").read_text())["extra"]
    recorded = extra[REPORT_CHECKSUMS]
    on_disk = sorted(p.relative_to(finished).as_posix() for p in (finished / "report").iterdir())
    assert sorted(recorded) == on_disk and "report/summary.csv" in recorded
    for relative, digest in recorded.items():
        assert file_sha256(finished / relative) == digest


def test_an_edited_report_table_is_left_out_of_the_page_and_of_reproduce(
    place: tuple[Path, Path],
) -> None:
    run, _ = place
    edited = _edit_summary_f(run)
    with pytest.warns(RuntimeWarning, match="summary.csv is left out of the page: it differs"):
        page = write_html_report(run).read_text()
    assert edited not in page and "report/summary.md" in page
    # What reproduce and equivalence verdicts read: left out, said so.
    with pytest.warns(RuntimeWarning, match="summary.csv has changed since its report was"):
        assert read_report_file(run, "report/summary.csv") is None
    with pytest.warns(RuntimeWarning, match="summary.csv has changed"):
        assert "summary.csv" not in read_report_tables(run)
    with (
        pytest.warns(RuntimeWarning, match="summary.csv has changed"),
        pytest.raises(ValueError, match="summary.csv is not as tooldesign report wrote it"),
    ):
        _claim_a(run)  # the claims of reproduce: refused, not made from the edited number
    # A table the report never wrote is not shown either.
    (run / "report" / "extra.csv").write_text("optimizer,final_free_energy\nrandom,1.0\n")
    with pytest.warns(RuntimeWarning, match="extra.csv is left out of the page: its manifest"):
        assert "extra.csv" not in write_html_report(run).read_text()
    with pytest.warns(RuntimeWarning, match="extra.csv is left out: its manifest does not"):
        assert read_report_file(run, "report/extra.csv") is None
    # tooldesign report writes it again, and records it: shown again, as written.
    (run / "report" / "extra.csv").unlink()
    assert main(["report", str(run)]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        page = write_html_report(run).read_text()
        assert read_report_file(run, "report/summary.csv") is not None
    assert (
        edited not in page
        and "report/summary.csv" in page
        and '<span class="unchecked"' not in page
    )


def test_a_report_written_elsewhere_is_not_recorded(place: tuple[Path, Path]) -> None:
    run, outside = place
    before = json.loads((run / "manifest.json").read_text())["extra"][REPORT_CHECKSUMS]
    make_suite_report(run, out_dir=outside / "report", n_boot=20)
    after = json.loads((run / "manifest.json").read_text())["extra"][REPORT_CHECKSUMS]
    assert after == before


def test_an_older_folder_shows_its_report_files_marked_unchecked(place: tuple[Path, Path]) -> None:
    """A manifest without report records (written before them): shown, visibly unchecked."""
    run, _ = place
    edit_manifest(run, lambda data: data["extra"].pop(REPORT_CHECKSUMS))
    with pytest.warns(RuntimeWarning, match="files of .* are shown unchecked"):
        page = write_html_report(run).read_text()
    assert "files below are unchecked" in page
    assert 'report/summary.md <span class="unchecked"' in page
    with pytest.warns(RuntimeWarning, match="summary.csv is read unchecked"):
        assert read_report_file(run, "report/summary.csv") is not None
    # The design files the manifest records are checked: no mark.
    assert "seed=" not in page.split("files below are unchecked")[1].split("</p>")[0]


# --- equivalence verdicts reads through the gate (L3) --------------------------------------------
def test_equivalence_verdicts_never_follows_a_link_nor_opens_a_fifo(
    place: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    run, outside = place
    (outside / "pairwise.csv").write_text("a,b,metric,significant\nx,y,auc,True\n")
    (run / "report" / "pairwise.csv").unlink()
    os.mkfifo(run / "report" / "pairwise.csv")  # opened for reading, it would block for ever
    (run / "report" / "leak.csv").symlink_to(outside / "pairwise.csv")
    with pytest.warns(RuntimeWarning, match="pairwise.csv is left out: it is a FIFO"):
        tables = read_report_tables(run)
    assert "pairwise.csv" not in tables and "leak.csv" not in tables and "summary.csv" in tables
    # A linked report/ is refused in one line.
    shutil.rmtree(run / "report")
    (run / "report").symlink_to(outside, target_is_directory=True)
    with pytest.raises(SystemExit) as exit_info:
        main(["equivalence", "verdicts", str(run), str(run)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "symbolic link" in err
