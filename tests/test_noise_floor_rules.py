"""The noise-floor rule of the reports: what a missing, NaN or negative floor means.

A variant whose floor was not measured (absent from the mapping, or NaN) gets no floor: its
pairs say so ("no floor") in the table and the text, rather than being silently called beyond
noise; a negative or infinite floor is refused. In the reproduction's claim (c), a NaN noise of
one row does not decide the comparison by the order of ``max``'s arguments.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

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


def _stress_retests(missing: bool, repeats: int = 2) -> list[dict[str, object]]:
    """Three designs of two objectives, each in ``repeats`` scenes; with ``missing``, one
    free-energy design has no robustness in its second scene."""

    def rows(values: list[float | None]) -> list[dict[str, object]]:
        return [
            {
                "change": "mass",
                "nudge": k,
                "value": 1.0,
                "robustness": v,
                "accuracy": 1.0,
                "control_deviation": 1.0 + 0.1 * k,
                "final_distance": 0.1,
            }
            for k, v in enumerate(values)
        ]

    retests = []
    for label, precision in (("pure confidence", 0.0), ("free energy", 1.0)):
        for seed in range(3):
            values: list[float | None] = [-0.1 * seed - 0.1 - 0.02 * k for k in range(repeats)]
            if missing and label == "free energy" and seed == 0:
                values[1] = None
            retests.append(
                {
                    "variant": label.replace(" ", "-"),
                    "label": label,
                    "optimizer": "cmaes",
                    "seed": seed,
                    "goal": [0.1 * seed, 1.5, 0.1],
                    "goal_precision": precision,
                    "settings": {"masses": [1.0], "repeats": repeats},
                    "stress": rows(values),
                }
            )
    return retests


@pytest.mark.slow
def test_a_metric_missing_in_one_scene_of_one_design_keeps_the_others_noise() -> None:
    """The row's noise is the median over the designs whose range was measured, not NaN."""
    from benchmarks.reports.retest import stress_table

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nor a NumPy warning of a NaN median
        table = stress_table(_stress_retests(missing=True), "mass", n_boot=200)
    row = table.set_index("label").loc["free energy"]
    # The two designs with both scenes each have a range of 0.02.
    assert row["robustness_noise"] == pytest.approx(0.02)
    assert row["robustness_n"] == 3  # the design's mean over the scene it has still counts


@pytest.mark.slow
def test_claim_c_says_why_a_noise_is_not_measured(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two scenes per design: an n/a noise is a metric missing, never '--repeats 1'."""
    import benchmarks.reports.reproduction as reproduction
    from benchmarks.reports.retest import MISSING_METRIC_NOTE

    retests = _stress_retests(missing=True)
    for retest in retests:  # no design of free energy has robustness in its second scene
        if retest["label"] == "free energy":
            retest["stress"][1]["robustness"] = None  # type: ignore[index]
    monkeypatch.setattr(reproduction, "read_retests", lambda folder: retests)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        lines = reproduction._claim_c(Path("unused"), None)[2]
    text = "\n".join(lines)
    assert MISSING_METRIC_NOTE in text
    assert "--repeats 1" not in text
    # One scene per design: the note says so.
    monkeypatch.setattr(reproduction, "read_retests", lambda folder: _stress_retests(False, 1))
    lines = reproduction._claim_c(Path("unused"), None)[2]
    assert "rolled out in one scene only" in "\n".join(lines)


def _noise_retest(variant: str, seed: int, free_energy: list[float], error: str = ""):
    rows = [
        {"free_energy": f, "goal_error": 1.0, "confidence": 1.0, "final_distance": 0.1}
        for f in free_energy
    ]
    return {"variant": variant, "optimizer": "cmaes", "seed": seed, "error": error, "noise": rows}


@pytest.mark.slow
def test_a_design_invalid_in_a_nudged_scene_counts_as_the_largest_range_not_as_none() -> None:
    """Dropping it lowered the floor by dropping the noisiest design (audit: p20 26.2 -> 26.9)."""
    from benchmarks.reports.retest import noise_floor

    measured = [_noise_retest("p20", s, [100.0, 100.0 + r]) for s, r in enumerate((1, 2, 3, 4))]
    from benchmarks.storage import INVALID_IN_SCENE

    failed = _noise_retest("p20", 9, [], error=f"ValueError: {INVALID_IN_SCENE}: overlaps the box")
    assert noise_floor(measured)["free_energy"] == pytest.approx(2.5)
    floor = noise_floor([*measured, failed])
    assert floor["free_energy"] == pytest.approx(3.0)  # the median of 1, 2, 3, 4 and inf
    assert (floor["designs"], floor["unmeasured"], floor["nudges"]) == (5, 1, 2)
    # A nudge without a finite value is the same: not a NaN floor for the whole variant.
    nan_nudge = _noise_retest("p20", 8, [100.0, math.nan])
    assert noise_floor([*measured, nan_nudge])["free_energy"] == pytest.approx(3.0)
    # Half of the designs or more unmeasured: the floor itself is not measured.
    assert math.isnan(noise_floor([*measured[:2], failed, nan_nudge])["free_energy"])


@pytest.mark.slow
def test_a_run_that_starts_without_a_valid_design_keeps_its_auc() -> None:
    """Its first iterations count as the group's worst best-so-far, not as a dropped run."""
    from benchmarks.reports.stats import best_so_far_curves, run_metrics

    rows = []
    for name, values in (("x", [math.nan, 9000.0, 8000.0, 8000.0]), ("y", [8500.0] * 4)):
        for iteration, value in enumerate(values):
            rows.append(
                {
                    "optimizer": name,
                    "seed": 0,
                    "iteration": iteration,
                    "free_energy": value,
                    "status": "invalid" if math.isnan(value) else "ok",
                }
            )
    metrics = run_metrics(best_so_far_curves(pd.DataFrame(rows))).set_index("optimizer")
    # x: 9000 (the worst best-so-far of the group) at iteration 0, then 9000, 8000, 8000.
    assert metrics.loc["x", "auc"] == pytest.approx((9000 + 8500 + 8000) / 3)
    assert metrics.loc["y", "auc"] == pytest.approx(8500.0)
    assert metrics.loc["x", "final_free_energy"] == 8000.0


@pytest.mark.slow
def test_claim_a_without_any_auc_says_na(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import benchmarks.reports.reproduction as reproduction

    report = tmp_path / "report"
    report.mkdir()
    summary = pd.DataFrame(
        {
            "optimizer": ["cmaes", "random"],
            "runs": [2, 2],
            **{
                f"{m}{suffix}": [math.nan, math.nan]
                for m in ("final_free_energy", "auc")
                for suffix in ("", "_low", "_high")
            },
            "final_free_energy_excluded": [2, 2],
            "auc_excluded": [2, 2],
        }
    )
    summary.to_csv(report / "summary.csv", index=False)
    monkeypatch.setattr(reproduction, "read_retests", lambda folder: [])
    cell = reproduction._claim_a(tmp_path)[0]  # raised "Encountered all NA values"
    assert "n/a" in cell


@pytest.mark.slow
def test_a_retest_that_broke_says_nothing_of_the_design_and_is_left_out() -> None:
    from benchmarks.reports.retest import noise_floor

    measured = [_noise_retest("p20", s, [100.0, 100.0 + r]) for s, r in enumerate((1, 2, 3, 4))]
    died = _noise_retest("p20", 9, [], error="WorkerDied: the worker running it died 2 times")
    floor = noise_floor([*measured, died])
    assert floor["free_energy"] == pytest.approx(2.5)  # as without it, not raised to 3
    assert (floor["designs"], floor["unmeasured"], floor["failed"]) == (4, 0, 1)
