"""The stress tables give the share of designs that succeed at each altered mass and friction."""

from __future__ import annotations

import math

import pytest

from benchmarks.reports.retest import make_retest_report, stress_success_table


def _retest(variant: str, seed: int, distances: dict[tuple[str, float], list[float]]) -> dict:
    """A retest record: its stress rows' final distances per (change, value), one per nudge."""
    stress = [
        {
            "change": change,
            "value": value,
            "nudge": nudge,
            "final_distance": distance,
            "robustness": -1.0,
            "accuracy": -2.0,
            "control_deviation": 3.0,
        }
        for (change, value), row in distances.items()
        for nudge, distance in enumerate(row)
    ]
    return {
        "variant": variant,
        "label": "",
        "optimizer": "cmaes",
        "seed": seed,
        "goal_precision": 20.0 if variant == "p20" else 50.0,
        "noise": [{"free_energy": 1.0, "goal_error": 2.0, "confidence": 1.0,
                   "final_distance": 0.1}] * 2,
        "stress": stress,
    }


RETESTS = [
    # At 0.5 kg: the scene itself (the first nudge) decides, not a nudged one.
    _retest("p20", 1, {("mass", 0.5): [0.05, 0.5], ("mass", 0.9): [0.3, 0.3]}),
    _retest("p20", 2, {("mass", 0.5): [0.2, 0.05], ("mass", 0.9): [0.1, 0.3]}),
    _retest("p20", 3, {("mass", 0.5): [math.nan, 0.05], ("mass", 0.9): [0.08, 0.3]}),
    _retest("p50", 1, {("mass", 0.5): [0.01, 0.01], ("friction", 0.2): [0.5, 0.5]}),
]


def test_the_share_is_of_designs_within_the_tolerance_in_the_scene_itself():
    table = stress_success_table(RETESTS, "mass").set_index(["variant", "value"])
    row = table.loc[("p20", 0.5)]
    assert (row["successes"], row["designs"], row["unknown"]) == (1, 2, 1)  # NaN: unknown
    row = table.loc[("p20", 0.9)]
    assert (row["successes"], row["designs"]) == (2, 3)  # 0.1 m is within the tolerance
    assert row["success_rate"] == pytest.approx(2 / 3)
    assert 0 < row["success_low"] < 2 / 3 < row["success_high"] < 1
    assert table.loc[("p50", 0.5), "success_high"] == 1.0  # 1 of 1: Wilson, not a point
    assert list(stress_success_table(RETESTS, "friction")["successes"]) == [0]
    # Another task's tolerance.
    tight = stress_success_table(RETESTS, "mass", tolerance=0.03).set_index(["variant", "value"])
    assert tight.loc[("p20", 0.9), "successes"] == 0


@pytest.mark.slow  # draws the stress figures (seconds on a busy machine)
def test_the_stress_report_has_the_success_table(tmp_path):
    make_retest_report(RETESTS, tmp_path, n_boot=200, task="hook")
    text = (tmp_path / "stress.md").read_text()
    assert "## Success at each box mass" in text and "(the hook task's tolerance)" in text
    assert "| objective | p^X | 0.5 kg | 0.9 kg |" in text
    assert "| p20 | 20 | 50 % (1/2) [9 %, 91 %] (1 run(s) without a final distance) |" in text
    assert (tmp_path / "stress-success.csv").is_file()
    assert (tmp_path / "stress-friction-success.csv").is_file()
    assert "## Success at each box friction" in (tmp_path / "stress-friction-table.md").read_text()


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="change must be 'mass' or 'friction'"):
        stress_success_table(RETESTS, "size")
    with pytest.raises(ValueError, match="unknown task 'nope'"):
        make_retest_report(RETESTS, "unused", task="nope")  # type: ignore[arg-type]


def test_the_protocol_references_table_says_whether_f_ref_succeeds():
    import pandas as pd

    from benchmarks.protocol.report import REFERENCE_SUCCESS_NOTE, references_shown

    table = pd.DataFrame(
        {"d": [3, 3, 5], "F_ref": [1.0, 2.0, 3.0], "final distance (m)": [0.195, 0.1, math.nan],
         "F straight": [9.0, 9.0, 9.0]}
    )
    shown = references_shown(table, "push")
    assert list(shown.columns) == ["d", "F_ref", "final distance (m)", "F_ref succeeds",
                                   "F straight"]
    assert shown["F_ref succeeds"].tolist() == ["no", "yes", "n/a"]
    assert "F_ref succeeds" not in table.columns  # references.csv keeps its columns
    assert "their success is not stored" in REFERENCE_SUCCESS_NOTE
    with pytest.raises(ValueError, match="unknown task 'nope'"):
        references_shown(table, "nope")
