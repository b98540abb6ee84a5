"""Weak target ladders, pooled blocks as instance clusters, aRT, held-out gap, d_z interval."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import t as student_t

from benchmarks.protocol.measures import bootstrap_ecdf, expected_running_time
from benchmarks.protocol.report import _ert_table
from benchmarks.protocol.statistics import (
    WEAK_LADDER_FRACTION,
    cluster_runs,
    held_out_gap,
    ladder_quality,
    paired_comparisons,
    rank_stability,
    weak_cell_sensitivity,
)

# --- weak ladders --------------------------------------------------------------------------------


def test_a_synthetic_references_table_flags_exactly_its_weak_cells():
    # (f_ref, random median, floor, F_random(budget)): span 1000 in every row.
    table = {
        ("i01", 3): (1000.0, 2000.0, 10.0, 1200.0),  # floor 1 % of the span: fine
        ("i02", 3): (1000.0, 2000.0, 300.0, 1400.0),  # floor 30 % of the span > 1/4: weak
        ("i03", 3): (1000.0, 2000.0, 50.0, 1040.0),  # random reaches F_ref + floor: weak
        ("i04", 3): (1000.0, 2000.0, 250.0, 1300.0),  # exactly 1/4: not above it, fine
    }
    flags = {cell: ladder_quality(*row) for cell, row in table.items()}
    assert [cell for cell, q in flags.items() if q["weak"]] == [("i02", 3), ("i03", 3)]
    assert flags[("i02", 3)]["floor_share"] == pytest.approx(0.3)
    assert flags[("i02", 3)]["floor_pct_ref"] == pytest.approx(30.0)
    assert WEAK_LADDER_FRACTION == 0.25
    # The review's i21 d = 8: floor 131 % of F_ref, 85 % of the span.
    i21 = ladder_quality(2920.5, 2920.5 + 4510.0, 3824.7, 3637.0)
    assert i21["weak"] and i21["floor_pct_ref"] == pytest.approx(131.0, abs=0.1)
    # A stricter fraction flags more.
    assert ladder_quality(1000.0, 2000.0, 10.0, 1200.0, fraction=0.005)["weak"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"f_ref": math.nan}, "f_ref must be a finite number"),
        ({"f_random_median": "x"}, "f_random_median must be a finite number"),
        ({"floor": 0.0}, "floor must be > 0"),
        ({"f_random_budget": math.inf}, "f_random_budget must be a finite number"),
        ({"fraction": 1.5}, "fraction must be a number in"),
    ],
)
def test_ladder_quality_refuses_bad_input(kwargs, match):
    args = {"f_ref": 1.0, "f_random_median": 2.0, "floor": 0.1, "f_random_budget": 1.5}
    fraction = kwargs.pop("fraction", WEAK_LADDER_FRACTION)
    with pytest.raises(ValueError, match=match):
        ladder_quality(**{**args, **kwargs}, fraction=fraction)


def _one_sided(instances: int, degrees=(3,), seeds=2) -> pd.DataFrame:
    """Optimizer a beats b on every instance and d (b's scores vary)."""
    rows = []
    for i in range(instances):
        for d in degrees:
            for s in range(seeds):
                base = 0.3 + 0.01 * i + 0.001 * s
                # Differences all distinct: tied ones send SciPy to a slow permutation test.
                rows.append(("a", f"i{i:02d}", d, 100 * s + d, base + 0.2 + 0.003 * i))
                rows.append(("b", f"i{i:02d}", d, 100 * s + d, base))
    return pd.DataFrame(rows, columns=["optimizer", "instance", "degree", "seed", "score"])


def test_leaving_weak_cells_out_can_change_a_verdict_and_says_so():
    scores = _one_sided(12)
    # 12 instances all one way: p = 2 / 2^12, significant; without 6, p = 2 / 2^6 is not.
    weak = [(f"i{i:02d}", 3) for i in range(6)]
    comparisons, ranking = weak_cell_sensitivity(scores, weak, alpha=0.01)
    row = comparisons[comparisons["d"] == "3"].iloc[0]
    assert bool(row["significant"]) and not bool(row["significant_without"])
    assert row["n"] == 12 and row["n_without"] == 6 and bool(row["changed"])
    assert ranking.set_index("d").loc["3", "ranking"] == "a > b"
    assert not ranking["changed"].any()
    # Two weak cells: 10 instances, p = 2 / 2^10 < 0.01 still: no change.
    comparisons, _ = weak_cell_sensitivity(scores, weak[:2], alpha=0.01)
    assert not comparisons["changed"].any()
    assert set(comparisons["d"]) == {"3", "all"}


def test_weak_cell_sensitivity_refuses_bad_input():
    scores = _one_sided(3)
    with pytest.raises(ValueError, match="a weak cell must be an .instance, d. pair"):
        weak_cell_sensitivity(scores, [("i00", "3")])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="lacks column 'degree'"):
        weak_cell_sensitivity(scores.drop(columns="degree"), [])
    with pytest.raises(ValueError, match="alpha must be"):
        weak_cell_sensitivity(scores, [], alpha=2.0)
    with pytest.raises(ValueError, match=r"weak must be a sequence of \(instance, d\) cells.*None"):
        weak_cell_sensitivity(scores, None)  # type: ignore[arg-type]


# --- pooled blocks as instance clusters ----------------------------------------------------------


def test_the_pooled_test_pairs_instances_not_blocks():
    scores = _one_sided(6, degrees=(3, 5, 8))
    pooled = cluster_runs(scores)
    assert pooled["instance"].nunique() == 6 and (pooled["blocks"] == 3).all()
    table = paired_comparisons(pooled)
    assert table["n"].tolist() == [6]  # not 18 blocks
    assert table["p"].iloc[0] == pytest.approx(2 / 2**6)
    # An instance's score is the mean of its blocks (per seed).
    one = scores[(scores["instance"] == "i01") & (scores["optimizer"] == "a")]
    assert pooled[(pooled["instance"] == "i01") & (pooled["optimizer"] == "a")][
        "score"
    ].mean() == pytest.approx(one["score"].mean())


def test_the_ranking_resamples_an_instance_with_all_its_blocks():
    # On each instance a wins at d = 3 by 0.5 and loses at d = 5 by 0.4: a is better on the
    # mean of every instance. Blocks resampled apart would often draw more d = 5 blocks.
    rows = []
    for i in range(5):
        for s in range(2):
            rows += [
                ("a", f"i{i}", 3, s, 1.0), ("b", f"i{i}", 3, s, 0.5),
                ("a", f"i{i}", 5, s, 0.1), ("b", f"i{i}", 5, s, 0.5),
            ]  # fmt: skip
    scores = pd.DataFrame(rows, columns=["optimizer", "instance", "degree", "seed", "score"])
    clustered = rank_stability(cluster_runs(scores), resamples=300, rng=1)
    assert clustered.loc["a", "P(rank 1)"] == 1.0
    blocks = scores.assign(instance=scores["instance"] + "/d" + scores["degree"].astype(str))
    apart = rank_stability(blocks, resamples=300, rng=1)
    assert apart.loc["a", "P(rank 1)"] < 0.95


def test_the_pooled_auc_interval_runs_over_instances_not_blocks():
    from benchmarks.protocol.report import _auc_table
    from benchmarks.reports.stats import t_interval

    scores = _one_sided(4, degrees=(3, 5, 8)).assign(regret_1=0.5, success_1=True)
    scores["score"] += 0.05 * (scores["degree"] == 8)  # the blocks of an instance differ
    row = _auc_table(scores.assign(pooled="all"), "pooled").set_index("optimizer").loc["a"]
    mine = scores[scores["optimizer"] == "a"]
    per_instance = mine.groupby(["instance", "degree"])["score"].mean().groupby("instance").mean()
    expected = t_interval(per_instance.to_numpy(), 0.95)  # over 4 instances, not 12 blocks
    assert (row["95% low"], row["95% high"]) == pytest.approx((expected.low, expected.high))
    assert row["AUC"] == pytest.approx(mine["score"].mean())
    blocks = t_interval(mine.groupby(["instance", "degree"])["score"].mean().to_numpy(), 0.95)
    assert row["95% high"] - row["95% low"] > blocks.high - blocks.low


def test_cluster_runs_refuses_bad_input():
    scores = _one_sided(3, degrees=(3, 5))
    with pytest.raises(ValueError, match=r"lacks columns \['degree'\]"):
        cluster_runs(scores.drop(columns="degree"))
    with pytest.raises(ValueError, match="has 1 to 2 seeds in the blocks of instance"):
        cluster_runs(scores.iloc[1:])  # a's first block lost a seed
    with pytest.raises(ValueError, match="blocks must be a sequence"):
        cluster_runs(scores, blocks="degree")
    with pytest.raises(TypeError, match=r"cluster must be a column name \(str\), got \['i'\]"):
        cluster_runs(scores, cluster=["i"])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="cluster 'degree' cannot also be a block column"):
        cluster_runs(scores, cluster="degree")


def test_cluster_runs_refuses_optimizers_with_different_blocks_in_a_cluster():
    # b lacks d = 5 at i01: a's mean would be over d = 3 and 5, b's over d = 3 alone.
    scores = _one_sided(3, degrees=(3, 5))
    gap = (scores["optimizer"] == "b") & (scores["instance"] == "i01") & (scores["degree"] == 5)
    with pytest.raises(
        ValueError, match=r"optimizer 'b' lacks blocks \[5\] of \('degree',\) in instance 'i01'"
    ):
        cluster_runs(scores[~gap])
    # Missing runs (NaN scores) count as missing blocks too.
    with pytest.raises(ValueError, match="optimizer 'b' lacks blocks"):
        cluster_runs(scores.assign(score=scores["score"].mask(gap)))


def test_a_non_default_cluster_keeps_the_instance_column_as_a_block():
    # Two tasks of two instances each at one d, 2 seeds: clustered by task, each task-seed is
    # the mean of its 2 instance blocks (not 4 "seeds" of 1 block each).
    scores = _one_sided(4, degrees=(3,)).assign(
        task=lambda f: np.where(f["instance"] < "i02", "t1", "t2")
    )
    out = cluster_runs(scores, cluster="task", blocks=("instance", "degree"))
    assert sorted(out["instance"].unique()) == ["t1", "t2"]
    assert (out["blocks"] == 2).all() and out["seed"].max() == 1
    assert len(out) == 2 * 2 * 2  # tasks x optimizers x seeds
    first = scores[(scores["task"] == "t1") & (scores["optimizer"] == "a")]
    assert out[(out["instance"] == "t1") & (out["optimizer"] == "a")]["score"].mean() == (
        pytest.approx(first["score"].mean())
    )


def test_a_cluster_bootstrap_keeps_an_instance_s_blocks_together():
    # Each instance has one block that hits every target at once and one that never does:
    # its pooled ECDF is 0.5 everywhere, so the clustered band has no width; resampling the
    # blocks apart gives a wide band.
    groups = [np.array([1.0, 1.0]), np.array([np.inf, np.inf])] * 4
    clusters = ["i1", "i1", "i2", "i2", "i3", "i3", "i4", "i4"]
    grid = np.array([1.0, 5.0])
    est, low, high = bootstrap_ecdf(groups, grid, resamples=200, clusters=clusters)
    assert est.tolist() == [0.5, 0.5] and low.tolist() == high.tolist() == [0.5, 0.5]
    _, low, high = bootstrap_ecdf(groups, grid, resamples=200)
    assert (high - low > 0.2).all()
    # Groups that are their own clusters give the unclustered band to the bit.
    rng = np.random.default_rng(3)
    many = [rng.integers(1, 10, size=4).astype(float) for _ in range(5)]
    plain = bootstrap_ecdf(many, grid, resamples=50, rng=7)
    own = bootstrap_ecdf(many, grid, resamples=50, rng=7, clusters=range(5))
    assert all(np.array_equal(x, y) for x, y in zip(plain, own, strict=True))
    with pytest.raises(ValueError, match="clusters must give one label per group .8., got 3"):
        bootstrap_ecdf(groups, grid, clusters=["i1", "i2", "i3"])


# --- aRT, held-out gap, d_z interval -------------------------------------------------------------


def test_pooled_art_is_coco_s_over_all_runs_of_all_instances():
    times = pd.DataFrame(
        {
            "degree": 3,
            "optimizer": "a",
            "instance": ["i1", "i1", "i2", "i2"],
            "target_index": 0,
            "runtime": [2.0, math.inf, 4.0, 6.0],
            "budget": 10,
        }
    )
    row = _ert_table(times).iloc[0]
    assert row["aRT target 1 (pooled)"] == pytest.approx((2 + 10 + 4 + 6) / 3)
    # Beside it, the median of the per-instance ERTs: (12 / 1, 10 / 2) -> 8.5.
    assert row["ERT target 1 (median)"] == pytest.approx(8.5)
    assert expected_running_time(times["runtime"], times["budget"]) == pytest.approx(22 / 3)


def test_held_out_gap_is_welch_over_instances_by_hand():
    public, held = [0.5, 0.6, 0.7], [0.2, 0.4]
    rows = [("a", f"p{k}", "public", s, v) for k, v in enumerate(public) for s in range(2)]
    rows += [("a", f"h{k}", "held-out", s, v) for k, v in enumerate(held) for s in range(2)]
    scores = pd.DataFrame(rows, columns=["optimizer", "instance", "set", "seed", "score"])
    row = held_out_gap(scores).iloc[0]
    vp, vh = np.var(public, ddof=1) / 3, np.var(held, ddof=1) / 2
    df = (vp + vh) ** 2 / (vp**2 / 2 + vh**2 / 1)
    half = student_t.ppf(0.975, df) * math.sqrt(vp + vh)
    assert row["gap"] == pytest.approx(0.3 - 0.6)
    assert (row["gap_low"], row["gap_high"]) == pytest.approx((-0.3 - half, -0.3 + half))
    assert (row["n_public"], row["n_held_out"]) == (3, 2)
    only_public = held_out_gap(scores[scores["set"] == "public"]).iloc[0]
    assert math.isnan(only_public["gap"]) and math.isnan(only_public["gap_low"])


def test_held_out_gap_refuses_bad_input():
    scores = pd.DataFrame(
        {"optimizer": "a", "instance": ["i1", "i2"], "set": ["public", "secret"], "score": 0.5}
    )
    with pytest.raises(ValueError, match="set must be 'public' or 'held-out', got 'secret'"):
        held_out_gap(scores)
    with pytest.raises(ValueError, match=r"lacks columns \['set'\]"):
        held_out_gap(scores.drop(columns="set"))
    both = scores.assign(set=["public", "held-out"], instance="i1")
    with pytest.raises(ValueError, match="instance 'i1' is in both sets"):
        held_out_gap(both)
    with pytest.raises(ValueError, match="level must be"):
        held_out_gap(scores.assign(set="public"), level=0.0)


def test_d_z_has_a_bootstrap_interval_around_it():
    rng = np.random.default_rng(5)
    rows = []
    for i in range(12):
        shift = rng.normal(0.1, 0.05)
        rows += [("a", i, 0, 0.5 + shift), ("b", i, 0, 0.5)]
    scores = pd.DataFrame(rows, columns=["optimizer", "instance", "seed", "score"])
    row = paired_comparisons(scores).iloc[0]
    assert row["d_z_low"] < row["d_z"] < row["d_z_high"]
    assert row["d_z_low"] > 0  # a clear effect: its interval is clear of 0
    again = paired_comparisons(scores).iloc[0]
    assert (again["d_z_low"], again["d_z_high"]) == (row["d_z_low"], row["d_z_high"])
    two = paired_comparisons(scores[scores["instance"] < 2]).iloc[0]
    assert math.isnan(two["d_z_low"]) and math.isnan(two["d_z_high"])
    with pytest.raises(ValueError, match="resamples must be an int >= 1"):
        paired_comparisons(scores, resamples=0)


def test_d_z_interval_stays_finite_when_instances_tie_at_zero():
    # Both optimizers reach no target on 2 of 6 instances: those differences are exactly 0,
    # so some resamples draw only them (SD 0, mean 0). Such a resample is d_z = 0, not NaN.
    from benchmarks.protocol.statistics import _d_z_interval

    diff = np.array([0.0, 0.0, 0.1, 0.2, 0.05, 0.3])
    generator = np.random.default_rng(0)
    drawn = diff[np.random.default_rng(0).integers(0, diff.size, size=(2000, diff.size))]
    assert (drawn == 0).all(axis=1).any()  # the case is really drawn
    low, high = _d_z_interval(diff, 0.95, 2000, generator)
    assert math.isfinite(low) and 0.0 <= low < high  # was (nan, nan)
    rows = [("a", i, 0, 0.5 + d) for i, d in enumerate(diff)]
    rows += [("b", i, 0, 0.5) for i in range(diff.size)]
    scores = pd.DataFrame(rows, columns=["optimizer", "instance", "seed", "score"])
    row = paired_comparisons(scores, resamples=2000).iloc[0]
    assert not math.isnan(row["d_z_low"]) and not math.isnan(row["d_z_high"])
    # All six tied: every resample is 0.
    assert _d_z_interval(np.zeros(6), 0.95, 200, np.random.default_rng(1)) == (0.0, 0.0)


def test_the_report_s_ladder_part_lists_weak_cells_and_says_which_verdict_changes():
    from benchmarks.protocol.report import _ladder_section

    scores = _one_sided(12)
    references = pd.DataFrame(
        {
            "d": 3,
            "instance": [f"i{i:02d}" for i in range(12)],
            "F_ref": 1000.0,
            "noise floor": [300.0] * 6 + [10.0] * 6,
            "floor % of F_ref": [30.0] * 6 + [1.0] * 6,
            "floor / span": [0.3] * 6 + [0.01] * 6,
            "F random median": 2000.0,
            "F_random(budget)": 1200.0,
            "weak ladder": [True] * 6 + [False] * 6,
        }
    )
    text = "\n".join(_ladder_section(scores, references, 0.01))
    assert "6 of 12 cells are weak" in text
    assert "a vs b at d = 3 (significant -> not significant)" in text
    assert "no ranking does" in text
    calm = "\n".join(_ladder_section(scores, references.assign(**{"weak ladder": False}), 0.01))
    assert "No weak cell among the 12 of this run." in calm


# --- the opt-in reference rule: the lowest median F over the nudges ------------------------------


def _cell_by_rule(monkeypatch, rule: str):
    """compute_cell on made-up F (100 + sum of the coefficients); the best design is chaotic."""
    import benchmarks.protocol.references as refs
    import benchmarks.suites.retest as retest
    from benchmarks.execution import make_executor
    from benchmarks.protocol.instances import load_instances
    from benchmarks.protocol.suite import protocol_config

    def evaluate(pool, designs, task):
        return [
            {"status": "ok", "free_energy": 100.0 + float(x.sum()), "final_distance": 0.2}
            for x in designs
        ]

    tried = []

    def fake_retest(item):
        tried.append(item.coeffs)
        f = 100.0 + sum(item.coeffs)
        spread = 1000.0 if len(tried) == 1 else 1.0  # the lowest F is a lucky low
        return {"noise": [{"free_energy": f + k * spread} for k in range(3)]}

    monkeypatch.setattr(refs, "_evaluate", evaluate)
    monkeypatch.setattr(retest, "retest_design", fake_retest)
    config = protocol_config("smoke")
    instance = next(i for i in load_instances() if i.id == config.instances[0])
    plan = refs.ReferencePlan(
        grid_points=0, restarts=0, pool_per_degree=4, nudges=3, floor_min_fraction=1e-6, rule=rule
    )
    with make_executor("serial") as pool:
        return refs.compute_cell(pool, config, instance, 3, plan), tried


def test_the_median_rule_passes_over_a_chaotic_lowest_design(monkeypatch):
    import benchmarks.protocol.references as refs

    lowest, tried = _cell_by_rule(monkeypatch, "lowest")
    assert len(tried) == 1 and lowest["noise_range"] == 2000.0  # the default: as before
    median, tried = _cell_by_rule(monkeypatch, "median")
    designs = lowest["evaluations"] - 3  # every design of the cell has a finite F here
    assert len(tried) == min(refs.MAX_REFERENCE_CANDIDATES, designs) > 1
    assert tuple(median["design"]) == tried[1]  # the second lowest F, the lowest median
    assert median["f_ref"] > lowest["f_ref"] and median["noise_range"] == 2.0
    assert "lowest median F over the nudges" in median["method"]
    assert median["evaluations"] == lowest["evaluations"] + 3 * (len(tried) - 1)


def test_the_rule_is_checked_where_a_computation_resumes_and_refused_when_unknown():
    import benchmarks.protocol.references as refs
    from benchmarks.protocol.suite import protocol_config

    with pytest.raises(ValueError, match="ReferencePlan.rule must be one of lowest, median"):
        refs.ReferencePlan(rule="mean")
    config = protocol_config("smoke")
    plan = refs.reference_plan("smoke")
    header = {
        "size": "smoke",
        "instance_version": config.instance_version,
        "goal_precision": config.goal_precision,
        "plan": refs._plan_fields(plan),  # no rule: a file from before the rule existed
    }
    refs.check_references_match(header, config, "F.json", plan=plan)
    median = refs.ReferencePlan(**{**refs._plan_fields(plan), "rule": "median"})
    with pytest.raises(ValueError, match="computed with plan rule = 'lowest', this plan has"):
        refs.check_references_match(header, config, "F.json", plan=median)
    # A report (no plan given) takes references of either rule.
    header["plan"] = {**header["plan"], "rule": "median"}
    refs.check_references_match(header, config, "F.json")
