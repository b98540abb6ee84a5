"""A statistic that is undefined reads "n/a" in the Markdown reports, never as a number.

A bootstrap interval of one seed is that value twice (``[x, x]``, which reads as certainty), the
range of a design's mean over one repeated scene is 0, and a relative noise over a base of 0
(the goal-error term at p^X = 0) is NaN: the pages say n/a with a note saying why. The CSV files
keep their documented numbers (the zero-width bounds, an empty cell for NaN).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from benchmarks.reports.comparison import (
    _summary_markdown,
    interval_bounds,
    percent_cell,
    summary_table,
)
from benchmarks.reports.reproduction import _floor_row, _paired_difference
from benchmarks.reports.retest import make_retest_report, stress_repeats
from benchmarks.reports.suite import (
    _by_precision_markdown,
    _table_one_markdown,
    robustness_by_precision,
    table_one,
)
from benchmarks.suites import SuiteConfig, Variant

N_BOOT = 100


def _log(seeds: int) -> pd.DataFrame:
    rows = [
        {
            "suite": "s",
            "variant": "",
            "optimizer": optimizer,
            "seed": seed,
            "iteration": iteration,
            "candidate": 0,
            "eval_id": iteration,
            "free_energy": 10.0 - iteration + offset + 0.5 * seed,
            "status": "ok",
        }
        for optimizer, offset in (("cmaes", 0.0), ("random", 1.0))
        for seed in range(seeds)
        for iteration in range(3)
    ]
    return pd.DataFrame(rows)


def _table_rows(markdown: str, first: str) -> list[list[str]]:
    return [
        [c.strip() for c in line.strip("|").split("|")]
        for line in markdown.splitlines()
        if line.startswith(f"| {first}")
    ]


# --- intervals from fewer than 2 seeds ----------------------------------------------------------


def test_a_one_seed_interval_is_na_in_summary_md_and_kept_in_the_csv() -> None:
    summary = summary_table(_log(1), n_boot=N_BOOT)
    # The CSV's numbers are as documented: the bootstrap of one value is that value.
    assert (summary["final_free_energy_low"] == summary["final_free_energy_high"]).all()
    text = _summary_markdown(summary, 0.95)
    cmaes = _table_rows(text, "cmaes")[0]
    assert cmaes[3] == "8 [n/a]" and cmaes[5] == "9 [n/a]"
    # The log stores no final distance: the success rate is unknown, never 0 %.
    assert cmaes[4] == "n/a (1 run(s) without a final distance)"
    assert "[8, 8]" not in text
    assert "fewer than 2 runs with a value" in text


def test_two_seeds_give_numbers_and_no_note() -> None:
    text = _summary_markdown(summary_table(_log(2), n_boot=N_BOOT), 0.95)
    assert "[n/a]" not in text and "fewer than 2" not in text
    low, high = _table_rows(text, "cmaes")[0][3].split("[")[1].rstrip("]").split(", ")
    assert float(low) < float(high)


@pytest.mark.parametrize(("n", "expected"), [(0, "[n/a]"), (1, "[n/a]"), (2, "[1, 2]")])
def test_interval_bounds_needs_two_values(n: int, expected: str) -> None:
    assert interval_bounds(1.0, 2.0, n) == expected


def _design(variant: str, precision: float, seed: int, robustness: float) -> dict[str, Any]:
    return {
        "suite": "s",
        "variant": variant,
        "label": "pure confidence" if precision == 0 else "free energy",
        "optimizer": "cmaes",
        "seed": seed,
        "task_index": seed,
        "goal": [0.5, 0.1, 0.0],
        "goal_precision": precision,
        "coefficients": None,
        "status": "ok",
        "test": {
            "robustness": robustness,
            "accuracy": -2.0 - seed,
            "control_deviation": 3.0 + seed,
            "squared_goal_error": 4.0 + seed,
            "nominal_final_distance": 0.1 * (seed + 1),
        },
    }


def test_table_one_and_robustness_by_precision_say_na_for_one_task() -> None:
    config = SuiteConfig(
        name="s",
        variants=(
            Variant(name="p0", label="pure confidence", goal_precision=0.0),
            Variant(name="p20", label="free energy", goal_precision=20.0),
        ),
    )
    # p0: two tasks (an interval); p20: one (none).
    designs = [_design("p0", 0.0, 0, -1.0), _design("p0", 0.0, 1, -3.0)]
    designs.append(_design("p20", 20.0, 0, -5.0))
    table = table_one(designs, config, n_boot=N_BOOT)
    text = _table_one_markdown(table)
    pure, free = _table_rows(text, "pure confidence")[0], _table_rows(text, "free energy")[0]
    assert "[n/a]" not in " ".join(pure) and all("[n/a]" in c for c in free[4:])
    assert "[-5, -5]" not in text and "fewer than 2 tasks with a value" in text

    per_precision, correlations = robustness_by_precision(designs, config, n_boot=N_BOOT)
    text = _by_precision_markdown(per_precision, correlations)
    (p20,) = [r for r in _table_rows(text, "20 ") if r[1] == "free energy"]
    assert all(cell.endswith("[n/a]") for cell in p20[3:6])
    assert "fewer than 2 tasks with a value" in text


def test_an_interval_is_na_when_fewer_than_two_tasks_have_a_value_not_fewer_rows() -> None:
    # Two tasks, but the final test of one kept no accuracy (and no goal error): one value.
    config = SuiteConfig(
        name="s", variants=(Variant(name="p0", label="pure confidence", goal_precision=0.0),)
    )
    designs = [_design("p0", 0.0, 0, -1.0), _design("p0", 0.0, 1, -3.0)]
    designs[1]["test"]["accuracy"] = None
    designs[1]["test"]["squared_goal_error"] = None
    table = table_one(designs, config, n_boot=N_BOOT)
    assert table.loc[0, "tasks"] == 2 and table.loc[0, "robustness_n"] == 2
    assert table.loc[0, "accuracy_n"] == 1
    text = _table_one_markdown(table)
    (row,) = _table_rows(text, "pure confidence")
    # -3 and -1: mean -2 +- t(0.975, 1) s / sqrt(2) = -2 +- 12.71 (the t interval of two values).
    assert row[3] == "**-2** [-14.71, 10.71]" and row[4] == "**-2** [n/a]", row
    assert "[-2, -2]" not in text and "fewer than 2 tasks with a value" in text

    per_precision, correlations = robustness_by_precision(designs, config, n_boot=N_BOOT)
    assert list(per_precision.loc[0, ["robustness_n", "squared_goal_error_n"]]) == [2, 1]
    text = _by_precision_markdown(per_precision, correlations)
    (row,) = _table_rows(text, "0 ")
    assert row[3] == "-2 [-14.71, 10.71]" and row[4] == "4 [n/a]", row  # the t interval, as above
    assert "fewer than 2 tasks with a value" in text


# numpy's range of a design's all-NaN accuracy over scenes warns; the noise is NaN as it should be.
def test_a_stress_interval_is_na_when_fewer_than_two_designs_have_a_value(tmp_path: Path) -> None:
    retests = [_retest(0, repeats=2), _retest(1, repeats=2)]
    for row in retests[1]["stress"]:
        row["accuracy"] = None  # one design without an accuracy: one value behind its interval
    make_retest_report(retests, tmp_path, n_boot=N_BOOT)
    # Table I; the success shares per mass follow it in a table of their own.
    text = (tmp_path / "stress.md").read_text(encoding="utf-8").split("\n## Success at")[0]
    (row,) = _table_rows(text, "p0")
    assert "[n/a]" not in row[3] and row[4].startswith("**-2.05** [n/a]"), row
    assert "fewer than 2 designs with a value" in text
    stress = pd.read_csv(tmp_path / "stress.csv")
    assert list(stress.loc[0, ["designs", "robustness_n", "accuracy_n"]]) == [2, 2, 1]


# --- the noise of one repeated scene, and a percentage of a zero base ---------------------------


def _retest(seed: int, repeats: int, precision: float = 0.0) -> dict[str, Any]:
    return {
        "variant": "p0",
        "optimizer": "cmaes",
        "seed": seed,
        "goal_precision": precision,
        "label": "",
        # At p^X = 0 the goal-error term is 0 in every scene: its relative noise has no base.
        "noise": [
            {
                "free_energy": -5.0 + 0.1 * k,
                "goal_error": 0.0,
                "confidence": 5.0 - 0.1 * k,
                "final_distance": 0.1 + 0.01 * k,
            }
            for k in range(3)
        ],
        "stress": [
            {
                "change": "mass",
                "value": value,
                "nudge": nudge,
                "robustness": -1.0 - seed - 0.1 * nudge - value,
                "accuracy": -2.0 - 0.1 * nudge,
                "control_deviation": 3.0 + 0.1 * nudge,
                "final_distance": 0.2 + 0.01 * nudge,
            }
            for nudge in range(repeats)
            for value in (0.3, 0.6)
        ],
    }


def test_the_stress_noise_of_one_repeat_is_na(tmp_path: Path) -> None:
    retests = [_retest(0, repeats=1), _retest(1, repeats=1)]
    assert stress_repeats(retests, "mass") == 1 and stress_repeats(retests, "friction") == 0
    make_retest_report(retests, tmp_path, n_boot=N_BOOT)
    # Table I; the success shares per mass follow it in a table of their own.
    text = (tmp_path / "stress.md").read_text(encoding="utf-8").split("\n## Success at")[0]
    (row,) = _table_rows(text, "p0")
    assert all(cell.endswith("(n/a)") for cell in row[3:]), row
    assert "(0)" not in text and "rolled out in 1 scene(s)" in text
    # The CSV keeps its number (the range over one scene is 0), as documented.
    stress = pd.read_csv(tmp_path / "stress.csv")
    assert (stress["robustness_noise"] == 0.0).all()


def test_the_stress_noise_of_two_repeats_is_a_number(tmp_path: Path) -> None:
    make_retest_report([_retest(0, repeats=2), _retest(1, repeats=2)], tmp_path, n_boot=N_BOOT)
    # Table I; the success shares per mass follow it in a table of their own.
    text = (tmp_path / "stress.md").read_text(encoding="utf-8").split("\n## Success at")[0]
    (row,) = _table_rows(text, "p0")
    assert row[3].endswith("(0.1)"), row
    assert "n/a" not in text


def test_a_relative_noise_over_a_zero_base_is_na_not_nan_percent(tmp_path: Path) -> None:
    make_retest_report([_retest(0, repeats=2), _retest(1, repeats=2)], tmp_path, n_boot=N_BOOT)
    text = (tmp_path / "noise.md").read_text(encoding="utf-8")
    assert "nan" not in text.lower()
    assert "goal error 0 (n/a)" in text and "the term's mean is 0 for every design" in text
    assert "confidence 0.2 (4.08 %)" in text


def test_percent_cell_and_the_reproduction_floor_row() -> None:
    assert percent_cell(0.0123) == "1.23 %"
    assert percent_cell(math.nan) == percent_cell(math.inf) == "n/a"
    floor = {
        "designs": 2.0,
        "free_energy": 0.2,
        "free_energy_relative": math.nan,
        "goal_error": 0.0,
        "confidence": 0.2,
        "confidence_relative": 0.05,
        "final_distance": 0.0,
    }
    row = _floor_row("robustness", floor)
    assert "nan" not in row and "0.2 (n/a)" in row and "(5.00 %)" in row


def _by_goal(values: dict[int, float], optimizer: str = "cmaes") -> pd.DataFrame:
    return pd.DataFrame(
        {"goal_key": list(values), "optimizer": optimizer, "robustness": list(values.values())}
    )


def test_a_difference_with_one_shared_goal_has_no_interval() -> None:
    diff, low, high, n = _paired_difference(
        _by_goal({1: 1.0}), _by_goal({1: 0.5, 2: 0.0, 3: 1.0}), "robustness"
    )
    assert (diff, n) == (pytest.approx(0.5), 1) and math.isnan(low) and math.isnan(high)
    diff, low, high, n = _paired_difference(
        _by_goal({1: 1.0, 2: 2.0}), _by_goal({1: 0.0, 2: 0.5}), "robustness"
    )
    assert n == 2 and low < diff < high


def test_the_difference_is_paired_by_goal() -> None:
    """Hard goals drag both objectives down alike: pairing removes that spread, and a goal
    that only one side has is left out of both (the audit's case: 10 goals against 9)."""
    goals = range(10)
    hard = {g: -10.0 * g for g in goals}  # a spread across goals far larger than the effect
    a = _by_goal({g: hard[g] + 1.0 + 0.01 * (g % 3) for g in goals})
    b = _by_goal({g: hard[g] for g in goals if g != 9})  # goal 9 (the hardest) failed in b
    diff, low, high, n = _paired_difference(a, b, "robustness")
    assert n == 9
    assert diff == pytest.approx(1.01, abs=0.01)
    assert 0.9 < low < diff < high < 1.1  # unpaired, the interval would span about +-60
    # A goal twice on a side (two variants with one label) enters with the mean of its designs.
    twice = pd.concat([a, _by_goal({g: hard[g] + 3.0 for g in goals})])
    diff, _, _, n = _paired_difference(twice, b, "robustness")
    assert n == 9 and diff == pytest.approx((1.01 + 3.0) / 2, abs=0.01)
    # Two optimizers on the same goals: each design is paired with its own optimizer's.
    both_a = pd.concat([a, _by_goal({g: hard[g] + 3.0 for g in goals}, "pso")])
    both_b = pd.concat([b, _by_goal({g: hard[g] for g in goals}, "pso")])
    diff, low, high, n = _paired_difference(both_a, both_b, "robustness")
    assert n == 19 and diff == pytest.approx((9 * 1.01 + 10 * 3.0) / 19, abs=0.01)
