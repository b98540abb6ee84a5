"""A suite's report says when its run is incomplete, and never pools optimizers in Table I."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from benchmarks.reports.suite import make_suite_report
from benchmarks.storage import read_designs
from benchmarks.suites import load_suite
from benchmarks.suites.runner import run_suite

TWO_OPTIMIZERS = (
    'name = "two"\n'
    "goal = [0.0, 1.5, 0.1]\n"
    "batch_size = 2\n"
    "iterations = 1\n"
    "root_seed = 3\n"
    "n_seeds = 1\n"
    "test_robustness = true\n"
    "robustness_masses = [0.3]\n"
    'figures = ["robustness-table"]\n'
    'executor = "serial"\n'
    '[[variants]]\nname = "free"\nlabel = "free energy"\ngoal_precision = 20.0\n'
    '[[optimizers]]\nname = "random"\n'
    '[[optimizers]]\nname = "random"\nlabel = "random-b"\nsettings = {}\n'
)


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    config = tmp_path_factory.mktemp("config") / "two.toml"
    config.write_text(TWO_OPTIMIZERS, encoding="utf-8")
    out = tmp_path_factory.mktemp("suite") / "run"
    run_suite(load_suite(config), out, progress=False)
    return out


@pytest.mark.slow
def test_table_one_has_a_row_per_optimizer_when_there_are_several(finished: Path) -> None:
    make_suite_report(finished, n_boot=50)
    rows = (finished / "report" / "table1.csv").read_text(encoding="utf-8").splitlines()
    header = rows[0].split(",")
    assert header[:3] == ["variant", "label", "optimizer"]
    assert sorted(r.split(",")[2] for r in rows[1:]) == ["random", "random-b"]
    assert all(r.split(",")[header.index("tasks")] == "1" for r in rows[1:])
    markdown = (finished / "report" / "table1.md").read_text(encoding="utf-8")
    assert "| objective | optimizer | p^X | tasks |" in markdown


@pytest.mark.slow
def test_the_report_of_an_unfinished_run_says_so_on_every_page(
    finished: Path, tmp_path: Path
) -> None:
    complete = tmp_path / "complete"
    shutil.copytree(finished, complete)
    make_suite_report(complete, n_boot=50)
    pages = sorted((complete / "report").glob("*.md"))
    assert pages and not any("Incomplete run" in p.read_text() for p in pages)

    cut = tmp_path / "cut"
    shutil.copytree(finished, cut)
    manifest = json.loads((cut / "manifest.json").read_text())
    # what a run killed before its last run leaves: no end time, fewer designs than planned
    manifest["end_time"] = None
    manifest["extra"]["runs"] = len(read_designs(cut)) + 1
    (cut / "manifest.json").write_text(json.dumps(manifest))
    with pytest.warns(RuntimeWarning, match="2 of 3 runs finished"):
        written = make_suite_report(cut, n_boot=50)
    for page in (p for p in written if p.suffix == ".md"):
        assert page.read_text().startswith("> **Incomplete run.** 2 of 3 runs"), page.name


@pytest.mark.slow
def test_a_report_on_a_partial_retest_says_how_many_designs_it_covers(
    finished: Path, tmp_path: Path
) -> None:
    from benchmarks.execution import SerialExecutor
    from benchmarks.storage import update_file_checksums
    from benchmarks.suites.retest import RetestConfig, retest_suite

    folder = tmp_path / "retested"
    shutil.copytree(finished, folder)
    small = RetestConfig(nudges=2, repeats=1, masses=(0.5,), frictions=(0.3,))
    written = retest_suite(folder, small, executor=SerialExecutor())
    assert len(written) == 2
    make_suite_report(folder, n_boot=50)  # complete: no notice
    assert not any("Incomplete" in p.read_text() for p in (folder / "report").glob("*.md"))
    # as an interrupted retest leaves it: one design's file not written yet
    gone = written[0]
    update_file_checksums(folder, {gone.relative_to(folder).as_posix(): None})
    gone.unlink()
    with pytest.warns(RuntimeWarning, match="retest covers 1 of the 2 final designs"):
        pages = make_suite_report(folder, n_boot=50)
    assert all("retest covers 1 of the 2" in p.read_text() for p in pages if p.suffix == ".md")


@pytest.mark.slow
def test_no_table_pools_the_designs_of_several_optimizers(finished: Path, tmp_path: Path) -> None:
    """Table I, the stress tables and robustness-by-precision: a row per optimizer each."""
    from benchmarks.execution import SerialExecutor
    from benchmarks.suites.retest import RetestConfig, retest_suite

    folder = tmp_path / "all"
    shutil.copytree(finished, folder)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["config"]["figures"] = ["robustness-table", "robustness-scatter"]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    small = RetestConfig(nudges=2, repeats=1, masses=(0.5,), frictions=(0.3,))
    retest_suite(folder, small, executor=SerialExecutor())
    make_suite_report(folder, n_boot=50)
    for name in ("table1", "stress", "stress-friction-table", "robustness-by-precision"):
        rows = (folder / "report" / f"{name}.csv").read_text().splitlines()
        header = rows[0].split(",")
        assert "optimizer" in header, name
        column = header.index("optimizer")
        assert sorted(r.split(",")[column] for r in rows[1:]) == ["random", "random-b"], name


def _design_record(seed: int, status: str | None) -> dict[str, object]:
    """A suite's design file: an invalid design scores the env's finite penalty; a run whose
    every evaluation failed has no design (coefficients and status null)."""
    designed = status is not None
    return {
        "suite": "s",
        "variant": "p0",
        "label": "",
        "optimizer": "cmaes",
        "seed": seed,
        "task_index": seed,
        "goal": [0.5, 0.1, 0.0],
        "goal_precision": 0.0,
        "coefficients": [1.0, 2.0, 0.5] if designed else None,
        "free_energy": 1e5 if designed else None,
        "goal_error": 0.0 if designed else None,
        "confidence": -1e5 if designed else None,
        "final_distance": 0.3 if designed else None,
        "status": status,
        "test": {"error": "RuntimeError: the run has no valid design, so it was not tested"},
    }


@pytest.mark.parametrize(
    ("statuses", "shown"),
    [
        (["invalid", None], ["invalid", "failed"]),  # no valid design anywhere
        (["invalid", "invalid"], ["invalid", "invalid"]),
        (["ok", "invalid"], ["ok", "invalid"]),
        (["ok", "ok"], ["ok", "ok"]),  # the column is there whatever the statuses
    ],
)
def test_designs_md_always_has_a_status_column(
    statuses: list[str | None], shown: list[str]
) -> None:
    from benchmarks.reports.suite import _designs_markdown, designs_table

    table = designs_table([_design_record(seed, s) for seed, s in enumerate(statuses)])
    lines = _designs_markdown(table).splitlines()
    header = next(line for line in lines if line.startswith("| variant"))
    cells = [c.strip() for c in header.strip("|").split("|")]
    assert cells[:5] == ["variant", "optimizer", "seed", "status", "C"]
    rows = [line for line in lines if line.startswith("| p0 |")]
    assert [r.strip("|").split("|")[3].strip() for r in rows] == shown
