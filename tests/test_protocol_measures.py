"""The protocol's measures and statistics against values computed by hand."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
import pytest

from benchmarks.protocol.measures import (
    best_so_far,
    bootstrap_ecdf,
    ecdf,
    ecdf_area,
    expected_best_of_random,
    expected_running_time,
    normalized_regret,
    runtimes,
    target_ladder,
)
from benchmarks.protocol.statistics import (
    detectable_difference,
    instances_needed,
    min_instances,
    paired_comparisons,
    power_analysis,
    rank_stability,
)
from benchmarks.reports.stats import holm_bonferroni

# --- best so far, runtimes, ERT ------------------------------------------------------------------


def test_best_so_far_skips_failed_evaluations():
    assert best_so_far([5.0, np.nan, 3.0, 4.0, 1.0]).tolist() == [5, 5, 3, 3, 1]
    assert best_so_far([np.nan, 2.0]).tolist() == [math.inf, 2.0]


def test_runtimes_are_first_hits_and_censored_when_never_reached():
    # best so far: 10, 8, 8, 5, 5
    times = runtimes([10.0, 8.0, 9.0, 5.0, 7.0], [9.0, 8.0, 6.0, 4.0])
    assert times.tolist() == [2.0, 2.0, 4.0, math.inf]


def test_ert_with_censoring_by_hand():
    # Three runs of budget 10: two hit the target at 2 and 4, one never does.
    # ERT = (2 + 4 + 10) / 2 = 8.
    assert expected_running_time([2.0, 4.0, math.inf], 10) == 8.0
    # Per-run budgets: (3 + 20) / 1.
    assert expected_running_time([3.0, math.inf], [5, 20]) == 23.0
    assert expected_running_time([math.inf, math.inf], 10) == math.inf
    assert math.isnan(expected_running_time([], 10))
    with pytest.raises(ValueError, match="exceeds its run's budget"):
        expected_running_time([12.0], 10)


# --- ECDF and its area ---------------------------------------------------------------------------


def test_ecdf_by_hand():
    times = [1.0, 3.0, 3.0, math.inf]
    assert ecdf(times, [0, 1, 2, 3, 100]).tolist() == [0.0, 0.25, 0.25, 0.75, 0.75]
    assert np.isnan(ecdf([], [1.0])).all()


def test_ecdf_area_is_the_mean_of_the_ecdf_over_the_budget():
    times = [1.0, 3.0, math.inf]
    budget = 4
    # ECDF at t = 1..4: 1/3, 1/3, 2/3, 2/3 -> mean 0.5; by the formula (4 + 2 + 0) / (3 * 4).
    assert ecdf_area(times, budget) == pytest.approx(0.5)
    assert ecdf_area(times, budget) == pytest.approx(ecdf(times, np.arange(1, 5)).mean())
    assert ecdf_area([1.0, 1.0], 7) == 1.0
    assert ecdf_area([math.inf], 7) == 0.0


def test_bootstrap_band_contains_the_estimate_and_is_degenerate_for_equal_instances():
    groups = [[1.0, 2.0], [1.0, 2.0], [1.0, 2.0]]
    est, low, high = bootstrap_ecdf(groups, [0.5, 1.0, 2.0], resamples=50, rng=1)
    assert est.tolist() == [0.0, 0.5, 1.0]
    assert low.tolist() == est.tolist() == high.tolist()
    est, low, high = bootstrap_ecdf([[1.0], [5.0], [math.inf]], [1.0, 5.0], resamples=200, rng=2)
    assert np.all(low <= est) and np.all(est <= high)
    assert est.tolist() == pytest.approx([1 / 3, 2 / 3])


# --- random sampling, regret, targets ------------------------------------------------------------


def test_expected_best_of_random_matches_enumeration():
    pool = [5.0, 1.0, 3.0, 4.0, 2.0]
    for t in range(1, 6):
        combos = list(itertools.combinations(pool, t))
        exact = np.mean([min(c) for c in combos])
        assert expected_best_of_random(pool, np.array([t]))[0] == pytest.approx(exact)
    # t = 1 is the mean, t = N the minimum.
    assert expected_best_of_random(pool, np.array([1, 5])).tolist() == pytest.approx([3.0, 1.0])


def test_normalized_regret_by_hand():
    assert normalized_regret([110.0, 100.0, 90.0], 100.0, [200.0, 150.0, 120.0]).tolist() == (
        pytest.approx([0.1, 0.0, -0.5])
    )
    with pytest.raises(ValueError, match="above f_ref"):
        normalized_regret([1.0], 10.0, [10.0])


def test_target_ladder_spans_random_median_to_the_noise_floor():
    targets = target_ladder(100.0, 1100.0, 10.0, 3)
    # gap 1000, floor 10: 1000, 100, 10 above the reference.
    assert targets.tolist() == pytest.approx([1100.0, 200.0, 110.0])
    assert target_ladder(100.0, 105.0, 10.0).size == 0  # floor above the gap: no target
    assert np.all(np.diff(target_ladder(0.0, 50.0, 1.0, 10)) < 0)


# --- statistics ----------------------------------------------------------------------------------


def test_holm_by_hand():
    # m = 3: sorted 0.01, 0.02, 0.04 -> 0.03, 0.04, 0.04 (monotone).
    assert holm_bonferroni([0.04, 0.01, 0.02]).tolist() == pytest.approx([0.04, 0.03, 0.04])


@pytest.mark.slow
def test_power_formulas_by_hand():
    from scipy.stats import t

    # Above 50 pairs (SciPy's test is then approximate): t quantiles, n_eff = 3 n / pi.
    q = t.ppf(0.975, 63) + t.ppf(0.8, 63)
    assert detectable_difference(2.0, 64) == pytest.approx(q * 2.0 / math.sqrt(192 / math.pi))
    needed = instances_needed(4.0, 1.0)
    assert needed > 50
    for n, ok in ((needed, True), (needed - 1, False)):  # the smallest n that reaches 1.0
        q = t.ppf(0.975, n - 1) + t.ppf(0.8, n - 1)
        assert bool(q * 4.0 / math.sqrt(3 * n / math.pi) <= 1.0) is ok
    # Holm's first step with 6 tests is at alpha / 6.
    assert detectable_difference(1.0, 40, tests=6) > detectable_difference(1.0, 40)
    # Up to 50 pairs: the exact test's own power; more instances detect less.
    steps = [detectable_difference(1.0, n, alpha=0.01, tests=6) for n in (11, 18, 24, 50)]
    assert steps == sorted(steps, reverse=True)
    needed = instances_needed(1.0, 1.0, alpha=0.01, tests=6)
    assert detectable_difference(1.0, needed, alpha=0.01, tests=6) <= 1.0
    assert detectable_difference(1.0, needed - 1, alpha=0.01, tests=6) > 1.0


@pytest.mark.slow
def test_min_instances_is_where_the_real_wilcoxon_holm_procedure_can_first_reject():
    # alpha 0.01, 6 pairs: 2 / 2^n * 6 < 0.01 first at n = 11 (the reviewer's bound).
    assert min_instances(0.01, 6) == 11
    assert min_instances(0.05, 1) == 6
    for n, significant in ((10, False), (11, True)):
        # Four optimizers, every instance ordered the same way by a huge margin.
        rows = [
            {"instance": i, "optimizer": o, "seed": 0, "score": 10.0 * k + 0.01 * i}
            for i in range(n)
            for k, o in enumerate("abcd")
        ]
        table = paired_comparisons(pd.DataFrame(rows), alpha=0.01)
        assert bool(table["significant"].any()) is significant


def test_power_is_infinite_where_the_test_can_never_reject_and_sizes_never_go_below():
    rng = np.random.default_rng(0)
    rows = [
        {"instance": f"i{i:02d}", "optimizer": o, "seed": s, "score": shift + 0.01 * rng.normal()}
        for i in range(6)
        for o, shift in (("cmaes", 0.3), ("bo", 0.2), ("pso", 0.1), ("random", 0.0))
        for s in range(2)
    ]
    power = power_analysis(pd.DataFrame(rows), alpha=0.01)
    # Six instances, six pairs: no pair can be significant, whatever the effect (d_z ~ 10+).
    assert (power["detectable"] == math.inf).all()
    assert (~power["separable"]).all() and (power["min_n"] == 11).all()
    assert (power["instances_needed"] >= 11).all()
    assert (power["seeds_needed"] == math.inf).all()
    assert detectable_difference(1.0, 10, alpha=0.01, tests=6) == math.inf
    assert instances_needed(1e-9, 1.0, alpha=0.01, tests=6) == 11


def test_paired_interval_is_the_t_interval_of_the_differences():
    from scipy.stats import t

    table = paired_comparisons(_scores(0.5, n_instances=5), alpha=0.01)
    ab = table[(table["a"] == "a") & (table["b"] == "b")].iloc[0]
    frame = _scores(0.5, n_instances=5).groupby(["instance", "optimizer"])["score"].mean()
    diff = (frame.xs("a", level="optimizer") - frame.xs("b", level="optimizer")).to_numpy()
    half = t.ppf(0.975, 4) * diff.std(ddof=1) / math.sqrt(5)
    assert ab["ci_low"] == pytest.approx(diff.mean() - half)
    assert ab["ci_high"] == pytest.approx(diff.mean() + half)


def test_instance_ids_may_be_ints():
    scores = _scores(0.5)
    as_int = scores.assign(instance=scores["instance"].str[1:].astype(int))
    ranks = rank_stability(as_int, resamples=50)
    assert list(ranks.index) == ["a", "b", "c"]
    assert paired_comparisons(as_int)["significant"].all()


def _scores(effect: float, n_instances: int = 12, seeds: int = 3, noise: float = 0.05):
    rng = np.random.default_rng(0)
    rows = []
    for i in range(n_instances):
        base = rng.normal()
        for name, shift in (("a", effect), ("b", 0.0), ("c", -effect)):
            for s in range(seeds):
                rows.append(
                    {
                        "instance": f"i{i}",
                        "optimizer": name,
                        "seed": s,
                        "score": base + shift + noise * rng.normal(),
                    }
                )
    return pd.DataFrame(rows)


def test_paired_comparisons_find_a_clear_effect_and_not_a_null_one():
    table = paired_comparisons(_scores(0.5), alpha=0.01)
    assert table["significant"].all()
    ab = table[(table["a"] == "a") & (table["b"] == "b")].iloc[0]
    assert ab["mean_diff"] == pytest.approx(0.5, abs=0.05)
    assert ab["ci_low"] < 0.5 < ab["ci_high"]
    assert (table["p_holm"] >= table["p"]).all()
    null = paired_comparisons(_scores(0.0), alpha=0.01)
    assert not null["significant"].any()


def test_rank_stability_is_certain_for_a_clear_order():
    ranks = rank_stability(_scores(0.5), resamples=100)
    assert list(ranks.index) == ["a", "b", "c"]
    assert ranks.loc["a", "P(rank 1)"] == 1.0
    assert np.allclose(ranks.filter(like="P(rank").sum(axis=1), 1.0)


def test_power_analysis_splits_seed_and_instance_variance():
    power = power_analysis(_scores(0.5, noise=0.3), wanted=[0.5])
    row = power[(power["a"] == "a") & (power["b"] == "b")].iloc[0]
    # Seed SD 0.3 per optimizer, 3 seeds: the seed part of the paired SD is sqrt(2 * 0.09 / 3).
    assert row["sd_seed"] == pytest.approx(math.sqrt(2 * 0.09 / 3), rel=0.3)
    assert row["detectable"] < 0.5
    assert row["instances_needed"] <= 12
    one_seed = power_analysis(_scores(0.5, seeds=1))
    assert one_seed["sd_seed"].isna().all() and one_seed["seeds_needed"].isna().all()


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: target_ladder(0.0, 10.0, 0.0), "floor must be > 0"),
        (lambda: target_ladder(0.0, 10.0, 1.0, 1), "n must be an int >= 2"),
        (lambda: target_ladder(math.nan, 10.0, 1.0), "finite"),
        (lambda: expected_best_of_random([1.0, 2.0], np.array([3])), "pool size 2"),
        (lambda: expected_best_of_random([], np.array([1])), "at least one finite"),
        (lambda: ecdf_area([1.0], 0), "budget must be an int >= 1"),
        (lambda: bootstrap_ecdf([], [1.0]), "at least one instance"),
        (lambda: runtimes([[1.0]], [1.0]), "1-D"),
        (lambda: paired_comparisons(pd.DataFrame({"x": [1]})), "lacks columns"),
        (lambda: paired_comparisons("scores"), "must be a DataFrame"),
        (lambda: detectable_difference(1.0, 0), "n must be an int >= 1"),
        (lambda: detectable_difference(1.0, 5, power=1.0), "power must be a number in"),
        (lambda: instances_needed(1.0, 0.0), "difference must be"),
        (lambda: power_analysis([1, 2]), "must be a DataFrame"),
        (
            lambda: rank_stability(
                pd.DataFrame(columns=["instance", "optimizer", "seed", "score"])
            ),
            "holds no row",
        ),
        (lambda: rank_stability(_scores(0.1).iloc[3:]), "every optimizer must have runs"),
        (lambda: paired_comparisons(_scores(0.1), alpha=1.5), "alpha must be a number in"),
        (lambda: paired_comparisons(_scores(0.1), level=1.5), "level must be a number in"),
        (lambda: power_analysis(_scores(0.1), alpha=1.5), "alpha must be a number in"),
        (lambda: power_analysis(_scores(0.1), alpha=0.0), "alpha must be a number in"),
        (lambda: power_analysis(_scores(0.1), power=1.0), "power must be a number in"),
        (lambda: power_analysis(_scores(0.1), wanted=[math.inf]), "wanted differences must"),
        (lambda: power_analysis(_scores(0.1), wanted=[math.nan]), "wanted differences must"),
        (lambda: rank_stability(_scores(0.1), resamples=0), "resamples must be an int >= 1"),
        (lambda: rank_stability(_scores(0.1), resamples=-5), "resamples must be an int >= 1"),
        (
            lambda: paired_comparisons(
                _scores(0.1).assign(score=lambda f: f["score"].where(f.index != 0, math.inf))
            ),
            "scores must be finite numbers",
        ),
        (lambda: min_instances(0.0, 6), "alpha must be a number in"),
        (lambda: min_instances(0.01, 0), "tests must be an int >= 1"),
        (lambda: detectable_difference(math.nan, 20), "sd must be a finite number"),
        (lambda: expected_running_time([math.inf, 3.0], [math.nan, 10]), "budgets must be"),
        (lambda: expected_running_time([math.inf, 3.0], [0, 10]), "budgets must be"),
        (lambda: normalized_regret([1.0], math.inf, [2.0]), "must be finite"),
        (lambda: ecdf([1.0], [[1.0]]), "grid must be 1-D"),
    ],
)
def test_bad_input_is_refused_with_a_message(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call()


# --- the glue: runs and references to runtimes and scores ----------------------------------------


def _reference(f_ref=100.0, floor=10.0, pool=(1100.0,) * 5):
    return {
        "f_ref": f_ref,
        "noise_floor": floor,
        "random_pool": list(pool),
        "f_straight": 500.0,
        "final_distance": 0.1,
        "method": "by hand",
    }


def _run_rows(values, optimizer="a", instance="i01", degree=3, seed=0):
    return pd.DataFrame(
        {
            "optimizer": optimizer,
            "instance": instance,
            "set": "public",
            "degree": degree,
            "seed": seed,
            "evaluation": np.arange(1, len(values) + 1),
            "free_energy": values,
        }
    )


def test_measure_runs_by_hand():
    from benchmarks.protocol.report import measure_runs

    # Targets with 3 per cell: 1100, 200, 110 (gap 1000, floor 10). Budget 4.
    runs = _run_rows([1000.0, 150.0, np.nan, 105.0])
    times, scores = measure_runs(runs, {("i01", 3): _reference()}, {3: 4}, n_targets=3)
    assert times["target"].tolist() == pytest.approx([1100.0, 200.0, 110.0])
    assert times["runtime"].tolist() == [1.0, 2.0, 4.0]
    # AUC = mean over targets of (4 - t + 1) / 4 = (4 + 3 + 1) / 12.
    assert scores["score"].iloc[0] == pytest.approx(8 / 12)
    # Regret at the full budget: F_random(4) = 1100 from the pool; (105 - 100) / 1000.
    assert scores["regret_1"].iloc[0] == pytest.approx(0.005)
    assert scores["final_f"].iloc[0] == 105.0
    # Random sampling as good as the reference: regret has no scale and is NaN, not an error.
    flat = _reference(f_ref=100.0, pool=(100.0, 100.0, 100.0, 100.0, 1100.0))
    _, scores = measure_runs(runs, {("i01", 3): flat}, {3: 4}, n_targets=3)
    assert np.isnan(scores["regret_1"].iloc[0])


def test_measure_runs_refuses_a_missing_reference_and_a_small_pool():
    from benchmarks.protocol.report import measure_runs

    runs = _run_rows([1.0, 2.0])
    with pytest.raises(ValueError, match="no reference for instance i01 at d = 3"):
        measure_runs(runs, {}, {3: 2})
    with pytest.raises(ValueError, match="needs more than the run budget 5"):
        measure_runs(runs, {("i01", 3): _reference()}, {3: 5})


@pytest.mark.slow
def test_detectable_difference_has_its_power_through_the_real_wilcoxon_holm_step():
    """Simulated: normal paired differences shifted by the detectable difference reach p < alpha
    / m in about 80 % of draws through SciPy's test itself, also just above the minimum n."""
    from scipy.stats import wilcoxon

    rng = np.random.default_rng(5)
    for n in (11, 12, 24):  # near the minimum n the t approximation gave 55 % and 68 %
        shift = detectable_difference(1.0, n, alpha=0.01, tests=6)
        draws = rng.normal(shift, 1.0, size=(600, n))
        p = np.array([wilcoxon(d).pvalue for d in draws])
        power = float(np.mean(6 * p < 0.01))
        assert 0.72 <= power <= 0.88, (n, shift, power)


# ------------------------------------------------------------ a reference valid in every scene
def _fake_cell(monkeypatch, invalid_first: int):
    """compute_cell on made-up F values; the ``invalid_first`` best designs break when nudged."""
    import benchmarks.protocol.references as refs
    import benchmarks.suites.retest as retest
    from benchmarks.execution import make_executor
    from benchmarks.protocol.instances import load_instances
    from benchmarks.protocol.suite import protocol_config
    from benchmarks.storage.designs import INVALID_IN_SCENE

    def evaluate(pool, designs, task):
        # F of a design: 100 + the sum of its coefficients; the straight tool 150.
        return [
            {
                "status": "ok",
                "free_energy": 150.0 if not x.any() else 100.0 + float(x.sum()),
                "final_distance": 0.2,
            }
            for x in designs
        ]

    ranked = []

    def fake_retest(item):
        ranked.append(item.coeffs)
        if len(ranked) <= invalid_first:
            raise ValueError(f"{INVALID_IN_SCENE}: overlaps the box at the start of the sweep")
        f = 100.0 + sum(item.coeffs)
        return {"noise": [{"free_energy": f + k} for k in range(3)]}

    monkeypatch.setattr(refs, "_evaluate", evaluate)
    monkeypatch.setattr(retest, "retest_design", fake_retest)
    config = protocol_config("smoke")
    instance = next(i for i in load_instances() if i.id == config.instances[0])
    plan = refs.ReferencePlan(
        grid_points=0, restarts=0, pool_per_degree=4, nudges=3, floor_min_fraction=1e-6
    )
    with make_executor("serial") as pool:
        return refs.compute_cell(pool, config, instance, 3, plan), ranked


def test_the_reference_is_the_best_design_valid_in_every_nudged_scene(monkeypatch):
    cell, tried = _fake_cell(monkeypatch, invalid_first=2)
    assert len(tried) == 3  # the two best broke when nudged; the third is the reference
    sums = sorted(sum(c) for c in tried)
    assert tried[2] == tuple(cell["design"]) and sum(tried[2]) == sums[2]
    assert cell["f_ref"] == 100.0 + sum(tried[2])
    assert cell["unstable_better"] == [100.0 + sum(tried[0]), 100.0 + sum(tried[1])]
    assert cell["noise_range"] == 2.0


def test_a_cell_whose_best_design_is_stable_records_no_unstable_ones(monkeypatch):
    cell, tried = _fake_cell(monkeypatch, invalid_first=0)
    assert len(tried) == 1 and "unstable_better" not in cell


def test_a_cell_gives_up_after_max_reference_candidates(monkeypatch):
    import benchmarks.protocol.references as refs

    monkeypatch.setattr(refs, "MAX_REFERENCE_CANDIDATES", 2)
    with pytest.raises(RuntimeError, match="the 2 best designs are all invalid in a nudged scene"):
        _fake_cell(monkeypatch, invalid_first=5)
