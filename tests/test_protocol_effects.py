"""Effects beyond the noise floor (review 42 of issue 32, findings 2 and 3).

A pair of optimizers is told apart only when its Holm p of the ECDF area is below alpha AND the
t interval of its paired final-F difference lies wholly beyond +-the noise floor on one side;
each statistics section of the report opens with a verdict sentence built from its tables.
Synthetic tables, no simulation.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from benchmarks.protocol.effects import (
    EFFECT_COLUMNS,
    compare_with_floor,
    floor_effects,
    instance_floors,
    section_floor,
    separation_sentence,
    told_apart,
)
from benchmarks.protocol.statistics import cluster_runs


def _runs(offsets: dict[str, float], *, blocks: int = 6, noise: float = 5.0) -> pd.DataFrame:
    """Two seeds per (block, optimizer): final F = 1000 + offset + block effect + noise."""
    rng = np.random.default_rng(1)
    rows = []
    for i in range(blocks):
        base = 100.0 * i
        for optimizer, offset in offsets.items():
            for seed in range(2):
                rows.append(
                    {
                        "instance": f"i{i:02d}",
                        "optimizer": optimizer,
                        "seed": seed,
                        "final_f": 1000.0 + base + offset + rng.normal(0, noise),
                    }
                )
    return pd.DataFrame(rows)


def _floors(blocks: int = 6, floor: float = 30.0) -> dict[str, float]:
    return {f"i{i:02d}": floor + i for i in range(blocks)}  # median of 30..35: 32.5


def test_the_paired_f_difference_its_interval_and_the_median_floor() -> None:
    runs = _runs({"bo": 0.0, "cmaes": -200.0, "pso": -5.0})
    table = floor_effects(runs, _floors()).set_index(["a", "b"])
    assert list(table.columns) == list(EFFECT_COLUMNS)
    # a - b, seed means paired by block: cmaes ends 200 lower than bo, so bo - cmaes ~ +200.
    bo_cmaes = table.loc[("bo", "cmaes")]
    means = runs.groupby(["instance", "optimizer"])["final_f"].mean().unstack()
    diff = means["bo"] - means["cmaes"]
    assert bo_cmaes["f_diff"] == pytest.approx(diff.mean())
    half = bo_cmaes["f_diff_high"] - bo_cmaes["f_diff"]
    from scipy import stats

    assert half == pytest.approx(stats.t.ppf(0.975, 5) * diff.std(ddof=1) / math.sqrt(6))
    assert bo_cmaes["floor"] == 32.5 and bool(bo_cmaes["beyond_floor"])
    # cmaes - pso ~ -195: a (cmaes) ends lower, beyond the floor on the negative side.
    assert table.loc[("cmaes", "pso"), "f_diff"] < -150
    assert bool(table.loc[("cmaes", "pso"), "beyond_floor"])
    # bo - pso ~ +5: inside the floor.
    assert not bool(table.loc[("bo", "pso"), "beyond_floor"])


def test_beyond_floor_needs_the_whole_interval_beyond_the_floor() -> None:
    # A mean difference beyond the floor whose interval reaches into it is not beyond.
    rng = np.random.default_rng(3)
    rows = []
    for i, d in enumerate(rng.normal(45.0, 40.0, 6)):
        rows += [
            {"instance": f"i{i}", "optimizer": "a", "seed": 0, "final_f": 1000.0 + d},
            {"instance": f"i{i}", "optimizer": "b", "seed": 0, "final_f": 1000.0},
        ]
    row = floor_effects(pd.DataFrame(rows), {f"i{i}": 30.0 for i in range(6)}).iloc[0]
    assert row["f_diff"] > 30.0 and row["f_diff_low"] < 30.0
    assert not bool(row["beyond_floor"])


def test_a_run_without_a_valid_evaluation_is_left_out_and_one_block_has_no_interval() -> None:
    runs = _runs({"bo": 0.0, "cmaes": -200.0})
    runs.loc[0, "final_f"] = math.inf  # i00, bo, seed 0: its seed 1 alone is bo's mean there
    table = floor_effects(runs, _floors())
    assert np.isfinite(table["f_diff"]).all()
    one = floor_effects(runs[runs["instance"] == "i01"], {"i01": 30.0}).iloc[0]
    assert math.isnan(one["f_diff_low"]) and not bool(one["beyond_floor"])


def _comparisons(**overrides: object) -> pd.DataFrame:
    row = {
        "a": "cmaes",
        "b": "pso",
        "n": 24,
        "mean_diff": 0.05,  # cmaes sooner
        "p_holm": 0.001,
        "significant": True,
        "f_diff": -10.0,  # cmaes lower, by less than the floor
        "f_diff_low": -20.0,
        "f_diff_high": -1.0,
        "floor": 35.0,
        "beyond_floor": False,
    }
    row.update(overrides)
    return pd.DataFrame([row])


def _power(**overrides: object) -> pd.DataFrame:
    row = {
        "a": "cmaes",
        "b": "pso",
        "n": 24,
        "min_n": 11,
        "detectable": 120.0,
        "instances_needed": 90.0,
        "seeds_needed": 12.0,
    }
    row.update(overrides)
    return pd.DataFrame([row])


def test_a_significant_pair_within_the_floor_is_not_told_apart() -> None:
    within = _comparisons()
    assert not told_apart(within).iloc[0]
    sentence = separation_sentence(within, _power(), group="d = 5", alpha=0.01, unit="instances")
    assert "Told apart: none." in sentence
    assert "a property of the problem" in sentence and "cmaes ~ pso (p_holm 0.001" in sentence
    assert "a property of the run's size" not in sentence


def test_significant_and_beyond_the_floor_the_same_way_is_told_apart() -> None:
    beyond = _comparisons(f_diff=-120.0, f_diff_low=-160.0, f_diff_high=-80.0, beyond_floor=True)
    assert told_apart(beyond).iloc[0]
    sentence = separation_sentence(beyond, _power(), group="pooled", alpha=0.01)
    assert "Told apart: cmaes better than pso (p_holm 0.001; F difference -120 [-160, -80], " in (
        sentence
    )
    assert "-3.4 floors of 35" in sentence and "Not told apart" not in sentence
    # Beyond the floor but not significant: not told apart, and the run's size is why.
    quiet = beyond.assign(significant=False, p_holm=0.2)
    assert not told_apart(quiet).iloc[0]
    sentence = separation_sentence(quiet, _power(), group="d = 3", alpha=0.01, unit="instances")
    assert "a property of the run's size" in sentence
    assert "detects >= 120 (3.4 floors)" in sentence
    assert "the observed 120 would need 90 instances or 12 seeds" in sentence
    # Significant in score one way, beyond the floor the other way in F: not told apart.
    opposite = beyond.assign(f_diff=120.0, f_diff_low=80.0, f_diff_high=160.0)
    assert not told_apart(opposite).iloc[0]
    assert "disagree in sign" in separation_sentence(opposite, _power(), group="g", alpha=0.01)


def test_a_run_too_small_for_any_pair_says_so_once() -> None:
    wide = _comparisons(significant=False, p_holm=1.0, f_diff_low=-90.0, f_diff_high=70.0)
    power = _power(n=6, detectable=math.inf, seeds_needed=math.inf)
    sentence = separation_sentence(wide, power, group="d = 8", alpha=0.01, unit="instances")
    assert "with fewer than 11 instances the test detects no difference at all" in sentence
    assert "the observed 10 would need 90 instances; mean within the floor" in sentence


def test_bad_input_is_refused_with_a_message() -> None:
    runs = _runs({"bo": 0.0, "cmaes": -200.0})
    with pytest.raises(TypeError, match="runs must be a DataFrame"):
        floor_effects(runs.to_dict(), _floors())
    with pytest.raises(ValueError, match=r"runs lacks columns \['final_f'\]"):
        floor_effects(runs.drop(columns="final_f"), _floors())
    with pytest.raises(ValueError, match="runs holds no row"):
        floor_effects(runs.iloc[:0], _floors())
    with pytest.raises(ValueError, match="'final_f' must hold numbers"):
        floor_effects(runs.assign(final_f="low"), _floors())
    with pytest.raises(ValueError, match="no noise floor for block 'i05'"):
        floor_effects(runs, {f"i{i:02d}": 30.0 for i in range(5)})
    for bad in (0.0, -1.0, math.nan, math.inf, "30", True):
        with pytest.raises(ValueError, match="must be a finite F > 0"):
            floor_effects(runs, {**_floors(), "i00": bad})  # type: ignore[dict-item]
    with pytest.raises(TypeError, match="floors must map a block"):
        floor_effects(runs, [30.0] * 6)  # type: ignore[arg-type]
    for level in (0, 1, 1.5, "0.95", True):
        with pytest.raises(ValueError, match="level must be a number in"):
            floor_effects(runs, _floors(), level=level)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"comparisons lacks columns \['beyond_floor'\]"):
        told_apart(_comparisons().drop(columns="beyond_floor"))
    with pytest.raises(TypeError, match="comparisons must be a DataFrame"):
        told_apart([])
    with pytest.raises(ValueError, match=r"power lacks columns \['detectable'\]"):
        separation_sentence(
            _comparisons(), _power().drop(columns="detectable"), group="g", alpha=0.01
        )
    with pytest.raises(ValueError, match=r"comparisons lacks columns \['floor'\]"):
        separation_sentence(_comparisons().drop(columns="floor"), _power(), group="g", alpha=0.01)
    with pytest.raises(TypeError, match="power must be a DataFrame"):
        separation_sentence(_comparisons(), None, group="g", alpha=0.01)


# Cells' floors whose median (20) differs from the median of the instances' means (30):
# i00 (10 + 50) / 2 = 30, i01 (20 + 20) / 2 = 20, i02 (100 + 12) / 2 = 56.
_CELL_FLOORS = {("i00", 3): 10.0, ("i00", 5): 50.0, ("i01", 3): 20.0, ("i01", 5): 20.0,
                ("i02", 3): 100.0, ("i02", 5): 12.0}  # fmt: skip


def _references() -> pd.DataFrame:
    return pd.DataFrame(
        [{"instance": i, "d": d, "noise floor": f} for (i, d), f in _CELL_FLOORS.items()]
    )


def _pooled_runs() -> pd.DataFrame:
    """Runs at d = 3 and 5 on the three instances of :data:`_CELL_FLOORS`, 2 seeds each."""
    rows = []
    for (i, d), _ in _CELL_FLOORS.items():
        for optimizer, offset in (("bo", 0.0), ("cmaes", -200.0)):
            for seed in range(2):
                final = 1000.0 + 100.0 * int(i[1:]) + 10.0 * d + offset + 3.0 * seed
                rows.append({"instance": i, "degree": d, "optimizer": optimizer,
                             "seed": 10 * seed + d, "final_f": final,
                             "score": 0.5 - final / 1e5})  # fmt: skip
    return pd.DataFrame(rows)


def test_the_pooled_floor_is_the_median_of_the_instances_mean_floors() -> None:
    from benchmarks.protocol.task_report import _floors

    floors = _floors(_references())
    assert floors == {"i00": 30.0, "i01": 20.0, "i02": 56.0}
    assert instance_floors(_references()) == floors
    assert section_floor(floors) == 30.0  # not the cells' median, 20
    assert float(np.median(list(_CELL_FLOORS.values()))) == 20.0
    assert section_floor(floors, ["i00", "i01"]) == 25.0
    assert math.isnan(section_floor(floors, []))
    pooled = cluster_runs(_pooled_runs())
    table, in_f = compare_with_floor(pooled, floors, alpha=0.01)
    assert table["floor"].tolist() == [30.0]  # the rule's floor is the section's one floor
    assert table["n"].tolist() == [3] and len(in_f) == 1  # 3 instances; F-unit power too
    with pytest.raises(ValueError, match=r"references lacks columns \['instance'\]"):
        instance_floors(_references().drop(columns="instance"))
    with pytest.raises(TypeError, match="references must be a DataFrame, got list"):
        instance_floors([])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="no noise floor for block 'i09'"):
        section_floor(floors, ["i09"])
    with pytest.raises(TypeError, match="floors must map a block"):
        section_floor([30.0])  # type: ignore[arg-type]


def test_the_task_axis_sections_carry_the_same_columns_and_sentence() -> None:
    from benchmarks.protocol.report import _md_table
    from benchmarks.protocol.task_report import _floors, _statistics

    # The instance-unit design: an instance's d blocks averaged, its floor their mean.
    frame = cluster_runs(_pooled_runs())
    lines, (table, _, _) = _statistics(
        frame, "hook", "instances (d blocks averaged)", 0.01, _md_table, _floors(_references())
    )
    assert {*EFFECT_COLUMNS, "told_apart"} <= set(table.columns)
    assert table["floor"].tolist() == [30.0]
    assert any(line.startswith("**Verdict, hook**") for line in lines)
    assert not table["told_apart"].any()  # 3 instances: nothing is significant
