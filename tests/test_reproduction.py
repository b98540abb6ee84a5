"""docs/reproduction.md is what `tooldesign reproduce` writes from docs/results."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.cli import main
from benchmarks.reports.reproduction import reproduction_page

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"


@pytest.mark.slow
def test_the_committed_page_is_made_from_the_committed_results() -> None:
    # The reports are rebuilt bit for bit by tests/test_suites.py; here the page from them.
    page = reproduction_page(RESULTS)
    assert page == (ROOT / "docs" / "reproduction.md").read_text(encoding="utf-8")
    assert "| (a) CMA-ES lowers F fastest |" in page and "noise floor" in page.lower()


@pytest.mark.slow
def test_a_missing_results_folder_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_info:
        nothing, page = str(tmp_path / "nothing"), str(tmp_path / "page.md")
        main(["reproduce", "--results", nothing, "--out", page])
    assert exit_info.value.code == 2
    assert not (tmp_path / "page.md").exists()


def test_suites_run_with_the_square_section_get_a_section_of_their_own(tmp_path: Path) -> None:
    from benchmarks.reports.reproduction import _square_section

    assert _square_section(tmp_path) == []
    (tmp_path / "square").mkdir()
    (tmp_path / "square" / "optimizers").symlink_to(RESULTS / "square" / "optimizers")
    lines = _square_section(tmp_path)
    text = "\n".join(lines)
    assert lines[0] == "## With the paper's square section"
    assert "| optimizers | square | 13 links | contact | free-energy | 10 |" in text
    assert "| (a) CMA-ES lowers F fastest |" in text
    assert "docs/results/square/optimizers/report/summary.md" in text
    assert "(c) pure confidence" not in text  # no square robustness folder here
    # The suites' own claims keep their level-2 headings; these are one level down.
    assert "\n### (a) CMA-ES lowers F fastest" in text


def test_the_page_names_the_arm_each_suite_ran_with() -> None:
    # Folders stored before the hand was merged by default record no value: 13 links.
    from benchmarks.reports.reproduction import _arm
    from benchmarks.suites import SuiteConfig

    assert _arm({}) == _arm({"scene": {"box_yaw": 0.1}}) == "13 links"
    assert _arm(SuiteConfig(name="s").to_json()) == "hand merged"
    unmerged = SuiteConfig(name="s", scene={"merge_fixed_links": False})
    assert _arm(unmerged.to_json()) == "13 links"


def test_a_results_folder_without_a_needed_suite_is_named(tmp_path, capsys):
    from benchmarks.cli import main

    (tmp_path / "results").mkdir()
    out = tmp_path / "page.md"
    with pytest.raises(SystemExit) as info:
        main(
            [
                "reproduce",
                "--results",
                str(tmp_path / "results"),
                "--out",
                str(out),
                "--skip-reports",
            ]
        )
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert (
        "holds no results of the 'optimizers' suite" in err and len(err.strip().splitlines()) == 1
    )
    assert not out.exists()
