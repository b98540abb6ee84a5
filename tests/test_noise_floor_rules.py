"""The noise-floor rule of the reports: what a missing, NaN or negative floor means.

A variant whose floor was not measured (absent from the mapping, or NaN) gets no floor: its
pairs say so ("no floor") in the table and the text, rather than being silently called beyond
noise; a negative or infinite floor is refused. In the reproduction's claim (c), a NaN noise of
one row does not decide the comparison by the order of ``max``'s arguments.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from benchmarks.reports.comparison import _pairwise_markdown, make_report, pairwise_table
from benchmarks.reports.reproduction import _comparison_noise


def _frame() -> pd.DataFrame:
    """Two variants, optimizer b 5 worse than a in each, seeds tightly spread (p small)."""
    rows = []
    for variant in ("p20", "p50"):
        for optimizer, offset in (("a", 0.0), ("b", 5.0)):
            for seed in range(8):
                rows.append(
                    {
                        "variant": variant,
                        "optimizer": optimizer,
                        "seed": seed,
                        "iteration": 0,
                        "candidate": 0,
                        "eval_id": 0,
                        "free_energy": 100.0 + offset + 0.01 * seed,
                        "status": "ok",
                    }
                )
    return pd.DataFrame(rows)


@pytest.mark.parametrize("floors", [{"p20": 6.0}, {"p20": 6.0, "p50": math.nan}])
def test_a_variant_without_a_floor_says_no_floor(floors: dict[str, float]) -> None:
    table = pairwise_table(_frame(), noise_floor=floors)
    measured = table[table["variant"] == "p20"]
    missing = table[table["variant"] == "p50"]
    # p20: |5| < 6, within the floor: not beyond noise, not significant.
    assert (measured["beyond_noise"] == False).all()  # noqa: E712 (a nullable boolean)
    assert not measured["significant"].any()
    # p50: no floor measured: beyond_noise is missing, not True; significance is the tests'.
    assert missing["beyond_noise"].isna().all()
    assert missing["significant"].all()
    text = _pairwise_markdown(table, 0.05, floors)
    p50 = text[text.index("p50") :]
    assert "| no floor |" in p50
    assert "p50: not measured" in text
    assert "No noise floor was measured for p50: its pairs say 'no floor'" in text


def test_no_floor_at_all_says_so_for_every_pair() -> None:
    table = pairwise_table(_frame())
    assert table["beyond_noise"].isna().all()
    assert table["significant"].all()
    text = _pairwise_markdown(table, 0.05, None)
    assert "No noise floor was measured" in text
    assert text.count("| no floor |") == len(table)


def test_a_nan_floor_for_every_variant_is_no_floor() -> None:
    table = pairwise_table(_frame(), noise_floor=math.nan)
    assert table["beyond_noise"].isna().all()


@pytest.mark.parametrize(
    ("floors", "message"),
    [
        (-1.0, "noise_floor must be a finite number >= 0 (NaN: not measured), got -1.0"),
        (math.inf, "noise_floor must be a finite number >= 0 (NaN: not measured), got inf"),
        ({"p20": -0.5}, "noise_floor of variant 'p20' must be a finite number >= 0"),
        ({"p20": "6"}, "noise_floor of variant 'p20' must be a finite number >= 0"),
        ("6", "noise_floor must be a number, one per variant or None"),
    ],
)
def test_a_negative_or_infinite_floor_is_refused(floors: object, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        pairwise_table(_frame(), noise_floor=floors)  # type: ignore[arg-type]


def test_make_report_refuses_a_negative_floor_before_writing(tmp_path) -> None:  # noqa: ANN001
    with pytest.raises(ValueError, match="noise_floor must be a finite number >= 0"):
        make_report(tmp_path / "nothing-here", noise_floor=-1.0)
    assert not (tmp_path / "nothing-here").exists()


@pytest.mark.parametrize(
    ("pure", "other", "expected"),
    [
        (2.0, 3.0, (3.0, "")),
        (math.nan, 3.0, (3.0, "noise of pure confidence not measured")),
        (3.0, math.nan, (3.0, "noise of p20 not measured")),
        (math.nan, math.nan, (0.0, "noise not measured")),
    ],
)
def test_claim_c_noise_does_not_depend_on_the_order_of_a_nan(
    pure: float, other: float, expected: tuple[float, str]
) -> None:
    assert _comparison_noise(pure, other, "p20") == expected


def test_one_run_without_a_valid_design_does_not_hide_a_difference_beyond_the_floor():
    """The tests drop non-finite values; the difference of means must too (issue 4's audit)."""
    rows = [
        {
            "suite": "x",
            "variant": "",
            "optimizer": name,
            "seed": seed,
            "iteration": iteration,
            "candidate": 0,
            "free_energy": np.nan if broken else offset + 10.0 * seed - iteration,
            "status": "invalid" if broken else "ok",
        }
        for name, offset in (("a", 0.0), ("b", 100.0))
        for seed in range(6)
        for iteration in range(3)
        for broken in [name == "a" and seed == 0 and iteration == 0]
    ]
    table = pairwise_table(pd.DataFrame(rows), noise_floor=5.0)
    auc = table[table["metric"] == "auc"].iloc[0]
    assert np.isfinite(auc["mean_difference"]) and abs(auc["mean_difference"]) > 50
    assert bool(auc["beyond_noise"]) and bool(auc["significant"])
