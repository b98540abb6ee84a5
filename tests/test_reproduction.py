"""docs/reproduction.md is what `tooldesign reproduce` writes from docs/results."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.cli import main
from benchmarks.reports.reproduction import reproduction_page

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"


def test_the_committed_page_is_made_from_the_committed_results() -> None:
    # The reports are rebuilt bit for bit by tests/test_suites.py; here the page from them.
    page = reproduction_page(RESULTS)
    assert page == (ROOT / "docs" / "reproduction.md").read_text(encoding="utf-8")
    assert "| (a) CMA-ES lowers F fastest |" in page and "noise floor" in page.lower()


def test_a_missing_results_folder_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_info:
        nothing, page = str(tmp_path / "nothing"), str(tmp_path / "page.md")
        main(["reproduce", "--results", nothing, "--out", page])
    assert exit_info.value.code == 2
    assert not (tmp_path / "page.md").exists()
