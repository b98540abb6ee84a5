"""docs/rl.md's results blocks are what the committed run folders render to (issue 36).

``python -m benchmarks.cli.rl_page`` writes three blocks of the page from ``docs/results/rl``
(the rl suite at today's defaults) and ``docs/results/breakeven`` (the break-even study): their
tables, the verdict in words, or a "pending" paragraph while a folder is not committed. Here:
the committed page against the committed folders; the blocks of real smoke runs parsed back
and compared with the report's CSV files; the verdict's words following an edited table; the
renderer on the square section's committed run against the numbers the page quotes by hand;
bad folders and arguments refused in one line.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks.cli import rl_page
from benchmarks.cli.rl_page import (
    BLOCKS,
    BREAKEVEN_FOLDER,
    PAGE,
    SUITE_FOLDER,
    current_block,
    markers,
    render_blocks,
    render_breakeven_block,
    render_not_done_block,
    render_suite_block,
    replace_block,
)

ROOT = Path(__file__).resolve().parents[1]
SQUARE = ROOT / "docs" / "results" / "square" / "rl"


def _root(tmp_path: Path, *, suite: Path | None = None, breakeven: Path | None = None) -> Path:
    """A repository with the committed page and copies of the given run folders in place."""
    root = tmp_path / "repo"
    (root / PAGE).parent.mkdir(parents=True)
    shutil.copy2(ROOT / PAGE, root / PAGE)
    for source, target in ((suite, SUITE_FOLDER), (breakeven, BREAKEVEN_FOLDER)):
        if source is not None:
            # Committed folders keep no parts/: render as from the committed files.
            shutil.copytree(source, root / target, ignore=shutil.ignore_patterns("parts"))
    return root


def _table(block: str, header_start: str) -> list[list[str]]:
    """The rows of the Markdown table whose header starts with ``header_start``."""
    lines = block.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {header_start}"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split(" | ")])
    return rows


def _between(text: str, start: str, end: str) -> str:
    return text.split(start, 1)[1].split(end, 1)[0]


# --- the committed page ---------------------------------------------------------------------


@pytest.mark.slow  # reads the committed folders' reports (about 3 s; CI runs the slow tier)
def test_the_committed_page_holds_what_the_committed_folders_render_to() -> None:
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    rendered = render_blocks(ROOT)
    assert set(rendered) == set(BLOCKS)
    for name, block in rendered.items():
        assert current_block(page, name) == block, (
            f"docs/rl.md's {name} block is stale: run `python -m benchmarks.cli.rl_page`"
        )


def test_the_page_says_pending_exactly_for_the_folders_not_committed() -> None:
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    for name, folder in (("rl-suite", SUITE_FOLDER), ("breakeven", BREAKEVEN_FOLDER)):
        block = current_block(page, name)
        assert ("**Pending:**" in block) is not (ROOT / folder).exists(), name
    not_done = current_block(page, "rl-not-done")
    assert ("rerun at today's defaults" in not_done) is not (ROOT / SUITE_FOLDER).exists()
    assert ("break-even study's `full` run" in not_done) is not (ROOT / BREAKEVEN_FOLDER).exists()


@pytest.mark.slow  # renders the committed folders twice (about 3 s)
def test_the_check_mode_passes_on_the_committed_page_and_fails_on_a_stale_block(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert rl_page.main(["--root", str(ROOT), "--check"]) == 0
    # The committed folders beside the committed page, so that only the edited block is stale.
    committed = {
        name: ROOT / folder if (ROOT / folder).is_dir() else None
        for name, folder in (("suite", SUITE_FOLDER), ("breakeven", BREAKEVEN_FOLDER))
    }
    root = _root(tmp_path, **committed)
    page = root / PAGE
    page.write_text(replace_block(page.read_text(), "breakeven", "old numbers\n"))
    capsys.readouterr()
    assert rl_page.main(["--root", str(root), "--check"]) == 1
    assert "stale blocks breakeven" in capsys.readouterr().out
    assert rl_page.main(["--root", str(root)]) == 0
    assert rl_page.main(["--root", str(root), "--check"]) == 0


@pytest.mark.slow
@pytest.mark.parametrize(
    ("folder", "suite"),
    [(SUITE_FOLDER, True), (BREAKEVEN_FOLDER, False), (SQUARE.relative_to(ROOT), True)],
    ids=["rl", "breakeven", "square-rl"],
)
def test_the_committed_numbers_are_what_the_stored_evaluations_give(
    folder: Path, suite: bool, tmp_path: Path
) -> None:
    """The blocks' numbers come from report files: rebuilt from the evaluations, they agree.

    The square section's run is rendered too: the page quotes its tables by hand (checked
    against its report below), so its report must be its evaluations'.
    """
    if not (ROOT / folder).exists():
        pytest.skip(f"{folder} is not committed yet")
    from benchmarks.reports.breakeven import make_breakeven_report
    from benchmarks.reports.rl import make_rl_report

    out = tmp_path / "report"
    (make_rl_report if suite else make_breakeven_report)(ROOT / folder, out_dir=out)
    render = render_suite_block if suite else render_breakeven_block
    committed = render(ROOT / folder, page=ROOT / PAGE, root=ROOT)
    rebuilt = render(ROOT / folder, page=ROOT / PAGE, root=ROOT, tables=out)
    assert "read from its `report/`" in committed
    assert "read from its report rebuilt from its stored evaluations" in rebuilt
    # The first paragraph says where the numbers were read; everything after it is numbers.
    assert committed.split("\n\n", 1)[1] == rebuilt.split("\n\n", 1)[1]


# --- the square section's run, rendered, against the numbers the page quotes by hand ----------


def test_the_square_sections_tables_on_the_page_are_its_committed_report() -> None:
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    hand = _between(page, "## Results with the square section", "## Saved policies")
    block = render_suite_block(SQUARE, page=ROOT / PAGE, root=ROOT)
    assert "made with the square section and the 13-link arm (commit a327f7f" in block
    # The fixed goal's two tables, row by row.
    for header in ("episodes | random sampling", "episodes | CMA-ES"):
        assert _table(hand, header) == _table(block, header), header
    # The held-out tables: every column the page quotes (the block adds the success, column 6).
    task, mass = hand.split("### Held-out goals and box masses", 1)
    for quoted, rendered in ((task, block), (mass, block.split("(`mass` part)", 1)[1])):
        mine = [row[:5] + row[6:] for row in _table(rendered, "approach")]
        assert _table(quoted, "approach") == mine


# --- rendering real smoke runs --------------------------------------------------------------


@pytest.mark.slow
def test_the_rl_block_quotes_the_reports_numbers(rl_smoke: Path, tmp_path: Path) -> None:
    root = _root(tmp_path, suite=rl_smoke)
    # A smoke run is not the committed run the page quotes: the page refuses it ...
    with pytest.raises(ValueError, match="size 'smoke', expected 'full'"):
        render_blocks(root)
    # ... and its block, rendered alone, is what a full run's would be.
    block = render_suite_block(root / SUITE_FOLDER, page=root / PAGE, root=root)
    report = root / SUITE_FOLDER / "report"
    assert "**Pending:**" not in block
    assert "made with the round section and the merged hand" in block
    from benchmarks.cli.rl_page import round_section_floors

    project, protocol = round_section_floors()
    assert "the square section's floor is kept as a conservative bound" in block
    assert f"the project's median relative floor, {100 * project:.2f} % of |F|" in block
    assert max(protocol.values()) < 0.015
    fixed = pd.read_csv(report / "fixed-goal.csv")
    methods = {"random sampling": "random", "CMA-ES": "cmaes", "PPO": "ppo", "SAC": "sac"}
    header = next(line for line in block.splitlines() if line.startswith("| episodes | random"))
    names = [methods[c.strip()] for c in header.strip("|").split(" | ")[1:]]
    rows = _table(block, "episodes | random")
    assert rows
    for row in rows:
        episodes = int(row[0])
        for method, cell in zip(names, row[1:], strict=True):
            r = fixed[(fixed["method"] == method) & (fixed["episodes"] == episodes)].iloc[0]
            assert cell.startswith(f"{r['median_best_F']:.0f}"), (method, cell)
            if isinstance(r["verdict"], str) and r["verdict"]:
                found = re.search(r"([+-]\d+\.\d)%", cell)
                assert found is not None, cell
                change = float(found.group(1)) / 100
                assert change == pytest.approx(r["relative_to_random"], abs=5e-4)
                assert ("**" in cell) is (r["verdict"] == "better")
                assert cell.endswith(", noise") is (r["verdict"] == "within the noise floor")
    summary = json.loads((report / "summary.json").read_text())
    parts = (("task", "held-out", "(`task` part)"), ("mass", "held-out-mass", "(`mass` part)"))
    for part, stem, title in parts:
        table = pd.read_csv(report / f"{stem}.csv").set_index("approach")
        rows = _table(block.split(title, 1)[1], "approach")
        assert len(rows) == len(table)
        equal = summary[part]["equal_budget"]
        for row, (approach, r) in zip(rows, table.iterrows(), strict=True):
            assert row[2] == f"{r['median_F']:.0f}", approach
            assert row[3] == f"{r['median_F_over_straight']:.2f}", approach
            assert row[4] == f"{r['better_than_straight']} of {r['tasks']}", approach
            vs = r.get(f"vs_cmaes_{equal}")
            assert row[7] == ("" if not isinstance(vs, str) else vs), approach
    for figure in ("fixed-goal.png", "held-out.png", "held-out-mass.png"):
        link = f"](results/rl/report/{figure})"
        assert link in block
        assert (root / "docs" / "results" / "rl" / "report" / figure).is_file()


@pytest.mark.slow
def test_the_breakeven_block_quotes_the_reports_numbers(
    breakeven_smoke: Path, tmp_path: Path
) -> None:
    root = _root(tmp_path, breakeven=breakeven_smoke)
    block = render_breakeven_block(root / BREAKEVEN_FOLDER, page=root / PAGE, root=root)
    report = root / BREAKEVEN_FOLDER / "report"
    assert "**Pending:**" not in block
    # The regret table: mean [95 % interval] per method and budget, as regret.csv holds them.
    regret = pd.read_csv(report / "regret.csv")
    rows = _table(block, "method | 1")
    assert [r[0] for r in rows] == list(dict.fromkeys(regret["method"]))
    budgets = sorted(set(regret["budget"]))
    for row in rows:
        for budget, cell in zip(budgets, row[1:], strict=True):
            r = regret[(regret["method"] == row[0]) & (regret["budget"] == budget)].iloc[0]
            numbers = [float(v) for v in re.findall(r"-?\d+\.\d+", cell)]
            assert numbers[0] == pytest.approx(r["mean"], abs=5e-4), (row[0], budget)
            if len(numbers) == 3:
                assert numbers[1:] == pytest.approx([r["ci_low"], r["ci_high"]], abs=5e-4)
            else:
                assert r["ci_low"] == r["ci_high"] or not math.isfinite(r["ci_low"])
    # The verdict table: one row per warm-started method and budget, its Holm p and decision.
    verdict = pd.read_csv(report / "warm_vs_cold.csv")
    rows = _table(block, "budget | warm-started")
    assert len(rows) == len(verdict)
    for row in rows:
        r = verdict[(verdict["method"] == row[1]) & (verdict["budget"] == int(row[0]))].iloc[0]
        assert row[2] == f"{r['pairs']} ({r['tasks']})"
        assert float(row[3]) == pytest.approx(r["mean_floors"], abs=5e-3)
        assert row[6] == (
            f"{r['replicates_beyond']} / {r['replicates_worse']} of {r['replicates']}"
        )
        assert float(row[7]) == pytest.approx(r["p_holm"], rel=1e-2)
        assert float(row[8]) == pytest.approx(r["p_worse_holm"], rel=1e-2)
        assert row[9] == ("yes" if r["beats_cold"] else "no")
        assert row[10] == ("yes" if r["worse_than_cold"] else "no")
    # One wording: the block's verdict, its table and its test's description are the report's.
    from benchmarks.reports.breakeven import (
        amortization_sentence,
        verdict_markdown,
        verdict_sentence,
        verdict_test_text,
    )

    config = json.loads((root / BREAKEVEN_FOLDER / "manifest.json").read_text())["config"]
    popsize = int(config["size"]["popsize"])
    sentence = verdict_sentence(
        verdict, budgets=config["size"]["budgets"], methods=config["methods"], popsize=popsize
    )
    report_page = (report / "breakeven.md").read_text()
    amortization = pd.read_csv(report / "amortization.csv")
    for text in (
        sentence,
        *verdict_markdown(verdict),
        verdict_test_text(1, len(verdict), popsize=popsize),
        amortization_sentence(amortization, popsize=popsize),
    ):
        assert text in block and text in report_page, text
    # Amortization: goals until the training pays, or never, per method and budget B (one
    # replicate: no range across training seeds).
    rows = _table(block, "method | training episodes")
    header = next(line for line in block.splitlines() if "| training episodes |" in line)
    references = [int(c.split("= ")[1]) for c in header.strip("|").split(" | ")[2:]]
    for row in rows:
        for budget, cell in zip(references, row[2:], strict=True):
            r = amortization[
                (amortization["method"] == row[0]) & (amortization["reference_budget"] == budget)
            ].iloc[0]
            if math.isfinite(r["breakeven_goals"]):
                assert (
                    cell == f"{r['breakeven_goals']:.0f} goals ({r['budget_needed']:.0f} per goal)"
                )
            else:
                assert cell.startswith("never")
    # The noise floors' median and the failures, as the report's files have them.
    floors = pd.read_csv(report / "noise_floors.csv")
    assert f"median {np.median(floors['floor']):.1f} over the {len(floors)} tasks" in block
    assert "No evaluation failed." in block
    for figure in ("regret.png", "amortization.png"):
        assert f"](results/breakeven/report/{figure})" in block


def _verdict_edited(report: Path, wins: dict[tuple[str, int], float]) -> pd.DataFrame:
    """warm_vs_cold.csv with the given (method, budget) rows set to that Holm p."""
    table = pd.read_csv(report / "warm_vs_cold.csv")
    for (method, budget), p in wins.items():
        row = (table["method"] == method) & (table["budget"] == budget)
        assert row.sum() == 1
        table.loc[row, "p_holm"] = p
        table.loc[row, "beats_cold"] = p < 0.05
    table.to_csv(report / "warm_vs_cold.csv", index=False)
    return table


@pytest.mark.slow
def test_the_verdict_words_follow_the_table(breakeven_smoke: Path, tmp_path: Path) -> None:
    root = _root(tmp_path, breakeven=breakeven_smoke)
    folder, report = root / BREAKEVEN_FOLDER, root / BREAKEVEN_FOLDER / "report"

    def verdict() -> str:
        block = render_breakeven_block(folder, page=root / PAGE, root=root)
        return next(line for line in block.splitlines() if line.startswith("**Verdict:**"))

    # The smoke study: 2 tasks, 1 replicate: 9 tests made, none can pass.
    assert verdict().startswith(
        "**Verdict:** no warm-started designer beats cold CMA-ES beyond the noise floor at any "
        "budget tested (1, 2 and 4): Holm p >= 0.05 in all 9 tests"
    )
    none_worse = (
        "No warm-started designer is worse than cold CMA-ES beyond the noise floor at any budget "
        "tested (the mirror test: Holm p >= 0.05 in all 9 tests)"
    )
    assert none_worse in verdict()
    table = _verdict_edited(report, {("warm-contextual", 2): 0.01})
    seeds = table.set_index(["method", "budget"]).loc[("warm-contextual", 2), "replicates_beyond"]
    # The smoke study's CMA-ES population is 4 (its manifest's): every budget is before cold
    # CMA-ES's first update.
    assert verdict().startswith(
        "**Verdict:** warm-started CMA-ES beats cold CMA-ES beyond the noise floor (Holm p < 0.05,"
        " over the tasks, for the study's trained designers) before cold CMA-ES's first update "
        f"(its first generation of 4 draws), at budget 2 (at 2: warm-contextual, with {seeds} of "
        "1 training seeds beyond the floor), while at budgets 1 and 4 none of the designers "
        f"tested does. {none_worse}"
    )
    assert "after cold CMA-ES adapts" not in verdict()
    _verdict_edited(report, {("warm-sac", 4): 0.001, ("warm-contextual", 4): 0.02})
    assert "at budgets 2 and 4 (at 2: warm-contextual, with " in verdict()
    assert "; at 4: warm-contextual and warm-sac, " in verdict()
    assert ", while at budget 1 none of the designers tested does. No warm-started" in verdict()
    _verdict_edited(report, {("warm-ppo", 1): 0.04})
    assert "(at 1, where the warm run is its zero-shot design: warm-ppo, with " in verdict()
    assert "; that is every budget of the study. No warm-started" in verdict()
    # The manifest's population size, not a constant: with 2, budget 4 is after the first update.
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["config"]["size"]["popsize"] = 2
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert "(its first generation of 2 draws), at budgets 1 and 2 (" in verdict()
    assert "; after cold CMA-ES adapts, at budget 4 (at 4: warm-contextual and warm-sac, " in (
        verdict()
    )
    # The mirror test: a row worse beyond the floor is named, with its mean and seeds.
    table = pd.read_csv(report / "warm_vs_cold.csv")
    row = (table["method"] == "warm-ppo") & (table["budget"] == 2)
    table.loc[row, ["p_worse_holm", "worse_than_cold"]] = [0.01, True]
    table.loc[row, ["mean_floors", "replicates_worse"]] = [3.25, 1]
    table.to_csv(report / "warm_vs_cold.csv", index=False)
    assert verdict().endswith(
        "Warm-started CMA-ES is worse than cold CMA-ES beyond the noise floor (the mirror test, "
        "Holm p < 0.05): warm-ppo at 2 (+3.25 floors; 1 of 1 training seeds worse beyond the "
        "floor)."
    )
    # A row without a p (fewer than 2 tasks) is not a test: named apart, not counted.
    table = pd.read_csv(report / "warm_vs_cold.csv")
    table[["beats_cold", "worse_than_cold"]] = False
    table.loc[table["budget"] == 4, ["p", "p_holm", "p_worse", "p_worse_holm"]] = math.nan
    table.to_csv(report / "warm_vs_cold.csv", index=False)
    assert verdict().startswith(
        "**Verdict:** no warm-started designer beats cold CMA-ES beyond the noise floor at any "
        "budget tested (1 and 2): Holm p >= 0.05 in all 6 tests"
    )
    assert (
        "; not tested (fewer than 2 tasks with both runs): warm-contextual at 4; warm-ppo at 4; "
        "warm-sac at 4. No warm-started designer is worse than cold CMA-ES beyond the noise "
        "floor at any budget tested (the mirror test: Holm p >= 0.05 in all 6 tests)"
    ) in verdict()
    table[["p", "p_holm", "p_worse", "p_worse_holm"]] = math.nan
    table.to_csv(report / "warm_vs_cold.csv", index=False)
    assert verdict().startswith("**Verdict:** no test was made")
    assert "Holm p >= 0.05 in all" not in verdict()
    # A table with a value that is not a decision is refused, an empty cell too.
    for column in ("beats_cold", "worse_than_cold"):
        for bad, shown in (("maybe", "'maybe'"), (math.nan, "nan")):
            edited = table.assign(**{column: bad})
            edited.to_csv(report / "warm_vs_cold.csv", index=False)
            with pytest.raises(ValueError, match=f"{column} must be True or False, got {shown}"):
                render_breakeven_block(folder, page=root / PAGE, root=root)


@pytest.mark.slow
def test_the_amortization_words_follow_the_table(breakeven_smoke: Path, tmp_path: Path) -> None:
    root = _root(tmp_path, breakeven=breakeven_smoke)
    folder, report = root / BREAKEVEN_FOLDER, root / BREAKEVEN_FOLDER / "report"
    table = pd.read_csv(report / "amortization.csv")
    table["breakeven_goals"] = math.inf
    table.to_csv(report / "amortization.csv", index=False)
    block = render_breakeven_block(folder, page=root / PAGE, root=root)
    # The smoke study's budgets B (2 and 4) are all up to its CMA-ES population (4).
    assert (
        "pays for itself, against cold CMA-ES after it adapts (B > 4, its population size): no "
        "budget of the study is that large; no learned method pays for itself at any budget."
    ) in block
    contextual = table["method"] == "contextual"
    budgets = sorted(table.loc[contextual, "reference_budget"])
    # Fewer goals at the largest budget B: the words must name that one, as before cold
    # CMA-ES's first update.
    table.loc[contextual, "breakeven_goals"] = [70.0 - 10 * i for i in range(len(budgets))]
    table.loc[contextual, "budget_needed"] = 1.0
    table.to_csv(report / "amortization.csv", index=False)
    block = render_breakeven_block(folder, page=root / PAGE, root=root)
    goals = 70 - 10 * (len(budgets) - 1)
    assert (
        "only against cold CMA-ES before its first update (B <= 4, its first generation of "
        f"draws): contextual after {goals} goals (1 per goal) at B = {budgets[-1]};"
    ) in block
    assert "never at any budget: warm-contextual, ppo, warm-ppo, sac and warm-sac." in block
    # With a population of 1 in the manifest, every B is after cold CMA-ES adapts.
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["config"]["size"]["popsize"] = 1
    (folder / "manifest.json").write_text(json.dumps(manifest))
    block = render_breakeven_block(folder, page=root / PAGE, root=root)
    assert (
        "after it adapts (B > 1, its population size): contextual after "
        f"{goals} goals (1 per goal) at B = {budgets[-1]}; never at any budget:"
    ) in block
    # Five training seeds: the table's cells and the words give the range across them.
    table["replicates"] = 5
    table.loc[contextual, ["budget_needed_min", "budget_needed_max"]] = [1.0, 3.0]
    table.loc[contextual, ["goals_min", "goals_max"]] = [[40.0, math.inf], [30.0, 90.0]]
    table.to_csv(report / "amortization.csv", index=False)
    block = render_breakeven_block(folder, page=root / PAGE, root=root)
    cell = f"{goals} goals (1 per goal; across the 5 training seeds: 30-90 goals, 1-3 per goal)"
    assert f"contextual after {cell} at B = {budgets[-1]}" in block
    assert _table(block, "method | training episodes")[0][-1] == cell
    del manifest["config"]["size"]["popsize"]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match=r"no CMA-ES population size \(size.popsize\)"):
        render_breakeven_block(folder, page=root / PAGE, root=root)


@pytest.mark.slow
def test_a_folder_without_its_report_gets_one_rebuilt_not_simulated(
    breakeven_smoke: Path, rl_smoke: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    whole = _root(tmp_path / "whole", suite=rl_smoke, breakeven=breakeven_smoke)
    bare = _root(tmp_path / "bare", suite=rl_smoke, breakeven=breakeven_smoke)
    for folder in (SUITE_FOLDER, BREAKEVEN_FOLDER):
        shutil.rmtree(bare / folder / "report")

    def blocks(root: Path) -> dict[str, str]:
        page = root / PAGE
        return {
            "rl-suite": render_suite_block(root / SUITE_FOLDER, page=page, root=root),
            "breakeven": render_breakeven_block(root / BREAKEVEN_FOLDER, page=page, root=root),
        }

    # The rebuilt reports go to a temporary folder that is gone once the block is rendered.
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    before, after = blocks(whole), blocks(bare)
    assert list(scratch.iterdir()) == []
    for name in ("rl-suite", "breakeven"):
        assert "It has no `report/`" in after[name] and "![" not in after[name]
        # The same numbers; only the links to the missing report and figures are left out.
        kept = [line for line in before[name].splitlines() if not line.startswith("![")]
        assert [line for line in kept if line.startswith("|")] == [
            line for line in after[name].splitlines() if line.startswith("|")
        ]
    assert not (bare / SUITE_FOLDER / "report").exists()
    assert not (bare / BREAKEVEN_FOLDER / "report").exists()


# --- pending, and bad input -----------------------------------------------------------------


def test_a_missing_folder_gets_the_pending_text_without_numbers(tmp_path: Path) -> None:
    root = _root(tmp_path)
    blocks = render_blocks(root)
    for name in ("rl-suite", "breakeven"):
        assert blocks[name].lstrip().startswith("**Pending:**"), name
        assert not re.search(r"\d", blocks[name]), blocks[name]
    assert "the square section's results are below" in blocks["rl-suite"]
    assert "is not committed yet (its folder: `docs/results/breakeven/`)" in blocks["breakeven"]
    assert "computing" not in blocks["breakeven"] + blocks["rl-suite"]
    not_done = blocks["rl-not-done"]
    assert not_done.count("\n- ") == 2 and "docs/results/rl/" in not_done
    # A full run at today's defaults takes its item off the list.
    rl_folder = root / SUITE_FOLDER
    rl_folder.mkdir(parents=True)
    config = {"size": {"name": "full"}, "section_shape": "round", "merge_fixed_links": True}
    manifest = {"extra": {"kind": "rl-suite"}, "config": config}
    (rl_folder / "manifest.json").write_text(json.dumps(manifest))
    not_done = render_not_done_block(rl_folder, root / BREAKEVEN_FOLDER, root=root)
    assert "docs/results/rl/" not in not_done and "docs/results/breakeven/" in not_done


@pytest.mark.parametrize("kind", ["empty", "file", "other-kind", "not-json"])
def test_a_folder_that_is_not_the_run_folder_is_refused_by_name(kind: str, tmp_path: Path) -> None:
    root = _root(tmp_path)
    folder = root / BREAKEVEN_FOLDER
    folder.parent.mkdir(parents=True, exist_ok=True)
    if kind == "file":
        folder.write_text("not a folder")
    else:
        folder.mkdir()
    if kind == "other-kind":
        (folder / "manifest.json").write_text('{"extra": {"kind": "rl-suite"}, "config": {}}')
    if kind == "not-json":
        (folder / "manifest.json").write_text("{")
    with pytest.raises(ValueError) as excinfo:
        render_blocks(root)
    message = str(excinfo.value)
    assert "\n" not in message and str(folder) in message, message
    if kind == "other-kind":
        assert "is not a break-even run folder" in message and "'rl-breakeven'" in message


def test_the_command_refuses_bad_input_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as excinfo:
        rl_page.main(["--root", str(tmp_path)])
    assert excinfo.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "holds no docs/rl.md" in err[-1] and str(tmp_path) in err[-1]
    root = _root(tmp_path)
    (root / SUITE_FOLDER).mkdir(parents=True)
    assert rl_page.main(["--root", str(root)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is not an rl suite run folder" in err[0], err
    # The page is left as it was.
    assert (root / PAGE).read_bytes() == (ROOT / PAGE).read_bytes()


def test_markers_round_trip_and_refuse_what_is_not_one_block() -> None:
    start, end = markers("breakeven")
    text = f"a\n{start}\nold\n{end}\nb\n"
    new = replace_block(text, "breakeven", "new\n")
    assert new == f"a\n{start}\nnew\n{end}\nb\n" and current_block(new, "breakeven") == "new\n"
    for bad in ("no markers", f"{end}{start}", f"{start}{start}{end}"):
        with pytest.raises(ValueError):
            replace_block(bad, "breakeven", "x")
    with pytest.raises(ValueError, match="unknown block 'results'"):
        markers("results")


@pytest.mark.slow  # imports the studies (seconds)
def test_the_kinds_and_old_defaults_are_the_studies_own() -> None:
    from benchmarks.rl.breakeven import BREAKEVEN_KIND
    from benchmarks.rl.suite import ADDED_FIELDS, RL_SUITE_KIND

    assert rl_page.SUITE_KIND == RL_SUITE_KIND
    assert rl_page.BREAKEVEN_KIND == BREAKEVEN_KIND
    assert rl_page.ADDED_FIELDS == ADDED_FIELDS


@pytest.mark.parametrize(
    ("folder", "kind", "config", "differs"),
    [
        (
            BREAKEVEN_FOLDER,
            "rl-breakeven",
            {"size": {"name": "smoke"}},
            "size 'smoke', expected 'full'",
        ),
        (
            SUITE_FOLDER,
            "rl-suite",
            {"size": {"name": "full"}, "section_shape": "square"},
            "section_shape 'square', expected 'round'",
        ),
        (
            SUITE_FOLDER,
            "rl-suite",
            {"size": {"name": "full"}, "section_shape": "round", "merge_fixed_links": False},
            "merge_fixed_links False, expected True",
        ),
        # A folder from before the fields reads as the square section and the 13-link arm.
        (SUITE_FOLDER, "rl-suite", {"size": {"name": "full"}}, "section_shape 'square'"),
    ],
    ids=["smoke-size", "square-section", "13-link-arm", "old-config"],
)
def test_only_a_full_run_at_todays_defaults_counts_as_committed(
    folder: Path,
    kind: str,
    config: dict[str, object],
    differs: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    root = _root(tmp_path)
    target = root / folder
    target.mkdir(parents=True)
    (target / "manifest.json").write_text(json.dumps({"extra": {"kind": kind}, "config": config}))
    # Neither the blocks nor the "not done" list take it for the committed run.
    for render in (
        lambda: render_blocks(root),
        lambda: render_not_done_block(root / SUITE_FOLDER, root / BREAKEVEN_FOLDER, root=root),
    ):
        with pytest.raises(ValueError) as excinfo:
            render()
        message = str(excinfo.value)
        assert "\n" not in message and str(target) in message and differs in message, message
    assert rl_page.main(["--root", str(root)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and differs in err[0], err
    assert (root / PAGE).read_bytes() == (ROOT / PAGE).read_bytes()


def test_a_page_that_is_not_utf8_or_lacks_a_marker_is_one_line_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    root = _root(tmp_path)
    page = root / PAGE
    page.write_bytes(b"\xff\xfe not UTF-8")
    assert rl_page.main(["--root", str(root)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{page} is not UTF-8 text" in err[0], err
    start, _ = markers("breakeven")
    page.write_text((ROOT / PAGE).read_text(encoding="utf-8").replace(start, ""))
    for argv in (["--root", str(root)], ["--root", str(root), "--check"]):
        assert rl_page.main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{page}: expected exactly one {start}" in err[0], err


@pytest.mark.slow  # loads the protocol's references (seconds)
def test_the_pages_round_section_floors_are_the_measured_ones() -> None:
    from benchmarks.cli.rl_page import round_section_floors
    from benchmarks.rl.suite import NOISE_FLOOR

    page = " ".join((ROOT / PAGE).read_text(encoding="utf-8").split())
    project, protocol = round_section_floors()
    assert "1.5 % of F" in page and NOISE_FLOOR == 0.015
    assert f"the project's median relative floor, {100 * project:.2f} % of |F|" in page
    medians = ", ".join(f"{100 * v:.2f} %" for v in list(protocol.values())[:-1])
    last = f"{100 * list(protocol.values())[-1]:.2f} %"
    degrees = list(protocol)
    assert (
        f"the full protocol references' median floors, {medians} and {last} of F_ref at d = "
        f"{', '.join(map(str, degrees[:-1]))} and {degrees[-1]}" in page
    )
    # The square section's floor is the larger: it is a conservative bound at the round one.
    assert max(project, *protocol.values()) < NOISE_FLOOR
