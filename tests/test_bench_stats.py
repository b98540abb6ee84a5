"""Tests of benchmarks.reports.stats against hand-computed values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import mannwhitneyu

from benchmarks.reports.stats import (
    PAIRWISE_COLUMNS,
    BootstrapCI,
    Interval,
    area_under_curve,
    best_so_far_curves,
    bootstrap_ci,
    finite_values,
    holm_bonferroni,
    mann_whitney_holm,
    mean_interval,
    run_metrics,
    t_interval,
    vargha_delaney_a12,
)

# --- the t interval of a mean --------------------------------------------------------------------


def test_t_interval_by_hand() -> None:
    # 1, 2, 3, 4: mean 2.5, s = sqrt(5/3), t(0.975, 3) = 3.182446305284263.
    ci = t_interval([1.0, 2.0, 3.0, 4.0, np.nan])
    half = 3.182446305284263 * np.sqrt(5.0 / 3.0) / 2.0
    assert (ci.estimate, ci.n, ci.n_excluded) == (2.5, 4, 1)
    assert ci.low == pytest.approx(2.5 - half) and ci.high == pytest.approx(2.5 + half)
    assert isinstance(ci, Interval) and BootstrapCI is Interval  # the former name still works


def test_t_interval_edge_cases() -> None:
    assert tuple(t_interval([7.0])) == (7.0, 7.0, 7.0)  # one value: a point, as the bootstrap
    assert all(np.isnan(v) for v in t_interval([np.nan]))
    assert tuple(t_interval([3.0, 3.0, 3.0])) == (3.0, 3.0, 3.0)  # no spread
    with pytest.raises(ValueError, match="level must be in"):
        t_interval([1.0, 2.0], level=1.0)


def test_mean_interval_picks_the_interval_and_names_a_bad_one() -> None:
    values = [1.0, 2.0, 4.0]
    assert mean_interval(values) == t_interval(values)
    boot = mean_interval(values, interval="bootstrap", n_boot=500, rng=3)
    assert boot == bootstrap_ci(values, n_boot=500, rng=3)
    # Three values: the bootstrap cannot reach past them, the t interval does.
    assert 1.0 <= boot.low and boot.high <= 4.0
    assert t_interval(values).low < 1.0 and t_interval(values).high > 4.0
    with pytest.raises(ValueError, match=r"interval must be one of \('t', 'bootstrap'\), got 'z'"):
        mean_interval(values, interval="z")


# --- Vargha-Delaney A12 -------------------------------------------------------------------------


def test_a12_of_separated_samples() -> None:
    assert vargha_delaney_a12([1, 2, 3], [4, 5, 6]) == 0.0
    assert vargha_delaney_a12([4, 5, 6], [1, 2, 3]) == 1.0


def test_a12_counts_ties_half() -> None:
    # Pairs: (1,2) <, (1,3) <, (2,2) tie, (2,3) <  ->  (0 + 0 + 0.5 + 0) / 4.
    assert vargha_delaney_a12([1, 2], [2, 3]) == 0.125
    assert vargha_delaney_a12([7, 7, 7], [7, 7]) == 0.5


def test_a12_excludes_non_finite_values_and_is_nan_when_empty() -> None:
    assert vargha_delaney_a12([1, np.nan, 2], [3, np.inf]) == 0.0
    assert np.isnan(vargha_delaney_a12([], [1.0]))
    assert np.isnan(vargha_delaney_a12([np.nan], [1.0]))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(-5, 5), min_size=1, max_size=8),
    st.lists(st.integers(-5, 5), min_size=1, max_size=8),
)
def test_a12_equals_brute_force_pair_count(a: list[int], b: list[int]) -> None:
    wins = sum((x > y) + 0.5 * (x == y) for x in a for y in b)
    assert vargha_delaney_a12(a, b) == pytest.approx(wins / (len(a) * len(b)), abs=1e-12)
    assert vargha_delaney_a12(a, b) + vargha_delaney_a12(b, a) == pytest.approx(1.0)


# --- Holm-Bonferroni ----------------------------------------------------------------------------


def test_holm_on_a_hand_example() -> None:
    # Sorted: 0.005*4 = 0.02, 0.01*3 = 0.03, 0.03*2 = 0.06, 0.04*1 = 0.04 -> running max 0.06.
    adjusted = holm_bonferroni([0.01, 0.04, 0.03, 0.005])
    np.testing.assert_allclose(adjusted, [0.03, 0.06, 0.06, 0.02], rtol=1e-12)


def test_holm_caps_at_one_and_leaves_untested_nan() -> None:
    adjusted = holm_bonferroni([0.5, np.nan, 0.2])
    # m = 2 tests: 0.2*2 = 0.4, max(0.4, 0.5*1) = 0.5.
    np.testing.assert_allclose(adjusted, [0.5, np.nan, 0.4])
    np.testing.assert_array_equal(holm_bonferroni([0.9, 0.8]), [1.0, 1.0])
    assert holm_bonferroni([]).shape == (0,)


def test_holm_rejects_values_outside_unit_interval() -> None:
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        holm_bonferroni([0.5, 1.5])
    with pytest.raises(ValueError, match="1-D"):
        holm_bonferroni([[0.1]])


# --- Mann-Whitney with Holm ---------------------------------------------------------------------


def test_pairwise_table_on_three_separated_groups() -> None:
    table = mann_whitney_holm({"a": [1, 2, 3], "b": [4, 5, 6], "c": [7, 8, 9]})
    assert tuple(table.columns) == PAIRWISE_COLUMNS
    assert list(zip(table["a"], table["b"], strict=True)) == [("a", "b"), ("a", "c"), ("b", "c")]
    # Exact two-sided test with n = 3 vs 3 and U = 0: p = 2 / C(6, 3) = 0.1 for every pair.
    np.testing.assert_allclose(table["p"], [0.1, 0.1, 0.1])
    np.testing.assert_array_equal(table["U"], [0.0, 0.0, 0.0])
    # Holm: 3 * 0.1, then max(0.3, 2 * 0.1), then max(0.3, 0.1).
    np.testing.assert_allclose(table["p_holm"], [0.3, 0.3, 0.3])
    np.testing.assert_array_equal(table["a12"], [0.0, 0.0, 0.0])
    assert not table["significant"].any()
    assert table["note"].eq("").all()


def test_pairwise_u_matches_scipy_and_a12() -> None:
    rng = np.random.default_rng(5)
    a, b = rng.normal(0, 1, 12), rng.normal(1, 1, 9)
    row = mann_whitney_holm({"a": a, "b": b}, alternative="less").iloc[0]
    expected = mannwhitneyu(a, b, alternative="less")
    assert row["U"] == expected.statistic and row["p"] == expected.pvalue
    assert row["p_holm"] == expected.pvalue  # a family of one
    assert row["a12"] == pytest.approx(expected.statistic / (12 * 9))
    assert row["significant"] == (expected.pvalue < 0.05)


def test_pairwise_with_too_few_values_gives_nan_and_a_note() -> None:
    table = mann_whitney_holm({"cmaes": [1.0, np.nan], "bo": [2.0, 3.0, 4.0]})
    row = table.iloc[0]
    assert np.isnan(row["U"]) and np.isnan(row["p"]) and np.isnan(row["p_holm"])
    assert not row["significant"]
    assert "1 non-finite value(s) of cmaes excluded" in row["note"]
    assert "cmaes has 1 finite value(s), fewer than 2" in row["note"]
    assert (row["n_a"], row["n_b"]) == (1, 3)


def test_pairwise_with_identical_samples_is_not_significant() -> None:
    row = mann_whitney_holm({"x": [2.0, 2.0, 2.0], "y": [2.0, 2.0, 2.0]}).iloc[0]
    assert row["p"] == 1.0 and row["a12"] == 0.5 and not row["significant"]
    assert "identical" in row["note"]


def test_pairwise_excludes_untested_pairs_from_the_holm_family() -> None:
    table = mann_whitney_holm({"a": [1, 2, 3], "b": [4, 5, 6], "c": [1.0]})
    np.testing.assert_allclose(table["p_holm"], [0.1, np.nan, np.nan])


def test_pairwise_with_one_group_is_an_empty_table() -> None:
    table = mann_whitney_holm({"only": [1, 2, 3]})
    assert table.empty and tuple(table.columns) == PAIRWISE_COLUMNS


def test_pairwise_bad_input_is_named() -> None:
    with pytest.raises(TypeError, match="groups must be a mapping"):
        mann_whitney_holm([[1, 2], [3, 4]])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="alternative must be"):
        mann_whitney_holm({"a": [1], "b": [2]}, alternative="smaller")
    with pytest.raises(TypeError, match=r"groups\['a'\] must be numbers"):
        mann_whitney_holm({"a": ["x", "y"], "b": [1, 2]})
    with pytest.raises(ValueError, match="alpha"):
        mann_whitney_holm({"a": [1], "b": [2]}, alpha=0)


# --- bootstrap ----------------------------------------------------------------------------------


def test_bootstrap_interval_of_two_points_is_hand_computable() -> None:
    # Resampled means of [0, 1] are 0, 0.5, 1 with probability 1/4, 1/2, 1/4, so the 2.5% and
    # 97.5% quantiles of 10 000 resamples are 0 and 1.
    estimate, low, high = bootstrap_ci([0.0, 1.0], rng=1)
    assert (estimate, low, high) == (0.5, 0.0, 1.0)


def test_bootstrap_contains_the_mean_and_is_reproducible_by_seed() -> None:
    values = np.random.default_rng(0).normal(3.0, 1.0, 20)
    ci = bootstrap_ci(values, rng=42)
    assert ci.low < values.mean() < ci.high
    assert ci.estimate == values.mean()
    assert ci == bootstrap_ci(values, rng=42)
    assert ci == bootstrap_ci(values, rng=np.random.default_rng(42))
    assert ci != bootstrap_ci(values, rng=43)
    # A 50% interval is inside the 95% one.
    narrow = bootstrap_ci(values, level=0.5, rng=42)
    assert ci.low <= narrow.low <= narrow.high <= ci.high


def test_bootstrap_excludes_non_finite_values_with_a_count() -> None:
    ci = bootstrap_ci([1.0, np.nan, 3.0, np.inf], n_boot=500, rng=0)
    assert (ci.estimate, ci.n, ci.n_excluded) == (2.0, 2, 2)
    assert isinstance(ci, BootstrapCI)


def test_bootstrap_edge_cases() -> None:
    empty = bootstrap_ci([np.nan], rng=0)
    assert np.isnan(empty.estimate) and np.isnan(empty.low) and empty.n_excluded == 1
    assert tuple(bootstrap_ci([4.0], rng=0)) == (4.0, 4.0, 4.0)
    assert tuple(bootstrap_ci([2.5] * 7, rng=0)) == (2.5, 2.5, 2.5)


def test_bootstrap_accepts_any_statistic() -> None:
    values = [1.0, 2.0, 3.0, 10.0]
    with_axis = bootstrap_ci(values, np.median, n_boot=300, rng=3)
    assert with_axis.estimate == 2.5
    row_by_row = bootstrap_ci(values, lambda v: float(np.median(v)), n_boot=300, rng=3)
    assert tuple(row_by_row) == tuple(with_axis)


def test_bootstrap_bad_input_is_named() -> None:
    with pytest.raises(TypeError, match="rng must be"):
        bootstrap_ci([1.0], rng=None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="n_boot"):
        bootstrap_ci([1.0], n_boot=0, rng=0)
    with pytest.raises(ValueError, match="level"):
        bootstrap_ci([1.0], level=95, rng=0)
    with pytest.raises(ValueError, match="1-D"):
        bootstrap_ci([[1.0, 2.0]], rng=0)
    with pytest.raises(TypeError, match="values must be numbers"):
        bootstrap_ci(["a"], rng=0)


def test_finite_values() -> None:
    kept, dropped = finite_values([1, np.nan, -np.inf, 2])
    np.testing.assert_array_equal(kept, [1.0, 2.0])
    assert dropped == 2


# --- curves and AUC -----------------------------------------------------------------------------


def evaluation_log() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "suite": "s",
            "optimizer": ["x"] * 6 + ["y"] * 2,
            "seed": [0, 0, 0, 0, 0, 0, 1, 1],
            "iteration": [0, 0, 1, 1, 2, 2, 0, 1],
            "free_energy": [np.nan, np.nan, 5.0, 3.0, 4.0, np.inf, 2.0, 1.0],
            "status": ["failed", "failed", "ok", "ok", "ok", "ok", "ok", "invalid"],
        }
    )


def test_best_so_far_curves_by_hand() -> None:
    curves = best_so_far_curves(evaluation_log().sample(frac=1.0, random_state=3))
    assert list(curves.columns) == [
        "suite",
        "optimizer",
        "seed",
        "iteration",
        "evaluations",
        "best_so_far",
    ]
    np.testing.assert_array_equal(curves["iteration"], [0, 1, 2, 0, 1])
    np.testing.assert_array_equal(curves["evaluations"], [2, 4, 6, 1, 2])
    # x/0: nothing finite, then min(5, 3), then 3 again (4 is worse, inf does not count);
    # y/1: 2, then 2 again because the 1.0 was invalid.
    np.testing.assert_array_equal(curves["best_so_far"], [np.nan, 3.0, 3.0, 2.0, 2.0])


def test_run_metrics_by_hand() -> None:
    metrics = run_metrics(best_so_far_curves(evaluation_log()))
    assert metrics["iterations"].tolist() == [3, 2]
    assert metrics["final_free_energy"].tolist() == [3.0, 2.0]
    # The first iteration had no finite F: it counts as the worst best-so-far of the suite's
    # runs (3.0, x's own here), not as a NaN that would drop the run from the comparison.
    assert metrics["auc"].iloc[0] == 3.0
    assert metrics["auc"].iloc[1] == 2.0


def test_area_under_curve_by_hand() -> None:
    # Trapezoids (3+2)/2 + (2+1)/2 = 4 over a width of 2.
    assert area_under_curve([3.0, 2.0, 1.0]) == 2.0
    # Widths 1 and 2: (2.5*1 + 1.5*2) / 3.
    assert area_under_curve([3.0, 2.0, 1.0], x=[0, 1, 3]) == pytest.approx(5.5 / 3)
    assert area_under_curve(pd.Series([4.0])) == 4.0
    assert np.isnan(area_under_curve([]))
    assert np.isnan(area_under_curve([np.nan, 1.0]))
    assert area_under_curve([5.0, 5.0, 5.0, 5.0]) == 5.0


def test_area_under_curve_bad_input() -> None:
    with pytest.raises(ValueError, match="strictly increasing"):
        area_under_curve([1.0, 2.0], x=[1, 1])
    with pytest.raises(ValueError, match="shape"):
        area_under_curve([1.0, 2.0], x=[0, 1, 2])
    with pytest.raises(ValueError, match="1-D"):
        area_under_curve([[1.0]])
    with pytest.raises(TypeError, match="curve must be numbers"):
        area_under_curve(["a"])


def test_curves_bad_input_is_named() -> None:
    with pytest.raises(ValueError, match=r"missing columns \['free_energy'\]"):
        best_so_far_curves(evaluation_log().drop(columns="free_energy"))
    with pytest.raises(TypeError, match="'free_energy' must be numeric"):
        best_so_far_curves(evaluation_log().assign(free_energy="x"))
    with pytest.raises(TypeError, match="must be a pandas DataFrame"):
        best_so_far_curves({"a": 1})  # type: ignore[arg-type]
