"""The break-even study (issue 36): its tasks, sizes, run folder, loader, report and score row.

The regret, interval and amortization arithmetic is checked on a hand-made log; the ``smoke``
size runs end to end (slow: about 80 evaluations and two SB3 trainings), is resumed, reported,
and a user's callable is scored against it from the command line.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from benchmarks.cli import main
from benchmarks.reports.breakeven import (
    TESTED,
    WARM_COLD_COLUMNS,
    amortization_table,
    comparison_table,
    make_breakeven_report,
    regret_curves,
    regret_table,
    score_row,
)
from benchmarks.rl.breakeven import (
    BREAKEVEN_COLUMNS,
    FAILURES_DIR,
    FLOOR_METHOD,
    FRESH_TASK_SEED,
    FRESH_TASKS,
    breakeven_config,
    breakeven_tasks,
    estimate_text,
    load_breakeven,
    noise_floors,
    run_breakeven,
)

# --- tasks and sizes ---------------------------------------------------------------------


def test_the_tasks_are_the_held_out_instances_then_the_committed_fresh_draw() -> None:
    from benchmarks.protocol.instances import draw_instances, load_instances

    tasks = breakeven_tasks()
    assert len(tasks) == 20
    held = [i for i in load_instances() if i.set == "held-out"]
    assert [t.id for t in tasks[:8]] == [i.id for i in held]
    assert [t.goal for t in tasks[:8]] == [i.goal for i in held]
    assert [t.box_mass for t in tasks[:8]] == [i.box_mass for i in held]
    assert [t.box_friction for t in tasks[:8]] == [i.box_friction for i in held]
    assert {t.set for t in tasks[8:]} == {"fresh"}
    # The committed fresh tasks are the draw they claim to be (same distribution, same code).
    drawn = draw_instances(FRESH_TASK_SEED, 12)
    assert FRESH_TASKS == tuple((i.goal, i.box_mass, i.box_friction) for i in drawn)
    assert len({t.goal for t in tasks}) == 20


def test_the_full_size_is_the_issues_and_its_estimate_is_printed() -> None:
    config = breakeven_config("full")
    assert config.size.tasks == 20 and config.size.replicates == 5
    assert config.size.budgets == (1, 4, 8, 16, 32, 64)
    counts = config.planned_evaluations()
    # 5 x 3 trainings of 1,024; 3 x 5 x 20 zero-shot; (2 cold + 3 warm) x 5 x 20 x 64; a
    # noise floor of 16 scenes per task.
    assert counts == {
        "train": 15_360,
        "zero-shot": 300,
        "cold": 12_800,
        "floor": 320,
        "warm": 19_200,
        "total": 47_980,
    }
    text = estimate_text(config)
    assert "47,980 evaluations" in text and "1.00 core-hours" in text


def test_the_pages_size_and_estimate_are_the_commands() -> None:
    page = (Path(__file__).resolve().parents[1] / "docs" / "rl.md").read_text()
    assert estimate_text(breakeven_config("full")) in page
    smoke = breakeven_config("smoke").planned_evaluations()["total"]
    assert f"CI: about {smoke} evaluations" in page


def test_the_page_describes_the_reports_measures_as_the_code_draws_them() -> None:
    import inspect

    from benchmarks.reports import breakeven as report

    page = " ".join((Path(__file__).resolve().parents[1] / "docs" / "rl.md").read_text().split())
    # The amortization figure has one panel per budget B (not one for B = 64).
    assert "One panel per budget B" in inspect.getdoc(report._amortization_figure)
    assert "in one panel per budget B" in page and "for B = 64" not in page
    # The verdict and the secondary table are the report's sections.
    assert "**The verdict: does warm-started CMA-ES beat cold CMA-ES beyond the noise floor?**" in (
        page
    )
    assert "Holm-corrected over every warm-started method at every budget together" in page
    assert "one-sided" in (inspect.getdoc(report.warm_cold_table) or "")
    assert "The test is of the claim itself, one-sided" in page
    assert "**The noise floor of each task** is measured" in page


def test_bad_study_settings_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match="size must be one of smoke, full"):
        breakeven_config("huge")
    with pytest.raises(ValueError, match="learned must be"):
        breakeven_config("smoke", learned=["dqn"])
    with pytest.raises(ValueError, match="executor must be 'process' or 'dask'"):
        breakeven_config("smoke", executor="threads")
    with pytest.raises(ValueError, match="needs executor='dask'"):
        breakeven_config("smoke", scheduler="tcp://x:1")
    with pytest.raises(ValueError, match="workers must be an int >= 1"):
        breakeven_config("smoke", workers=0)
    from dataclasses import replace

    from benchmarks.rl.breakeven import BREAKEVEN_SIZES

    bad: tuple[object, ...] = (1, 101, True, 4.0)
    for scenes in bad:
        size = replace(BREAKEVEN_SIZES["smoke"], floor_scenes=scenes)  # type: ignore[arg-type]
        with pytest.raises(
            ValueError, match=rf"floor_scenes must be an int from 2 to 100, got {scenes!r}"
        ):
            breakeven_config(size)


def test_noise_floors_refuses_a_frame_that_is_not_the_study_log() -> None:
    missing = r"lacks the columns \['c1', 'c2', 'c3', 'evaluation', 'status', 'variant'\]"
    with pytest.raises(ValueError, match=missing):
        noise_floors(pd.DataFrame({"task": ["a"], "free_energy": [1.0]}))


def test_the_command_prints_the_plan_and_refuses_bad_input(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["rl", "breakeven", "--size", "full", "--plan"]) == 0
    assert "47,980 evaluations" in capsys.readouterr().out
    for argv, message in (
        (["--size", "nope", "--plan"], "size must be one of"),
        (["--size", "smoke"], "--out DIR is needed"),
        (["--learned", "a2c", "--plan"], "learned must be"),
    ):
        with pytest.raises(SystemExit) as excinfo:
            main(["rl", "breakeven", *argv])
        assert excinfo.value.code == 2
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err


def test_the_report_and_its_measures_refuse_bad_input(tmp_path: Path) -> None:
    from benchmarks.reports.breakeven import expected_best_of_random
    from benchmarks.rl.scoring import score_policy

    with pytest.raises(ValueError, match="at least one F"):
        expected_best_of_random([], np.array([1]))
    with pytest.raises(ValueError, match="budgets must be ints from 1 to the pool size 2"):
        expected_best_of_random([1.0, 2.0], np.array([3]))
    with pytest.raises(FileNotFoundError):
        make_breakeven_report(tmp_path / "missing")
    with pytest.raises(ValueError, match="seconds_per_evaluation must be"):
        estimate_text(breakeven_config("smoke"), seconds_per_evaluation=0)
    with pytest.raises(ValueError, match="executor must be one of"):
        score_policy("x:y", tmp_path, executor="threads")
    with pytest.raises(TypeError, match="refine must be True or False"):
        score_policy("x:y", tmp_path, refine="yes")  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError, match="no break-even study"):
        score_policy("x:y", tmp_path)
    with pytest.raises(ValueError, match="size must be one of"):
        run_breakeven("huge", tmp_path / "run")  # type: ignore[arg-type]
    assert not (tmp_path / "run").exists()


def test_the_loader_refuses_what_is_not_a_study(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="path must be"):
        load_breakeven(3)  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError, match="no break-even run folder"):
        load_breakeven(tmp_path / "missing")


# --- the report's arithmetic on a hand-made log ------------------------------------------


def _log() -> pd.DataFrame:
    """One task t, one replicate: random [10, 20], CMA-ES [15, 9], contextual 8, warm [8, 6]."""
    rows = []

    def add(variant: str, method: str, values: list[float], task: str = "t") -> None:
        for k, f in enumerate(values):
            rows.append(
                {
                    "variant": variant,
                    "method": method,
                    "replicate": 0,
                    "task": task,
                    "evaluation": 1 if variant == "zero-shot" else k + 1,
                    "free_energy": f,
                }
            )

    add("cold", "random", [10.0, 20.0])
    add("cold", "cmaes", [15.0, 9.0])
    add("zero-shot", "contextual", [8.0])
    add("warm", "warm-contextual", [8.0, 6.0])
    add("train", "contextual", [1.0] * 100, task="")
    return pd.DataFrame(rows)


def test_the_restated_formulas_equal_the_protocols() -> None:
    from benchmarks.protocol.measures import expected_best_of_random as protocol_best
    from benchmarks.protocol.statistics import paired_comparisons
    from benchmarks.reports.breakeven import expected_best_of_random, paired_table

    rng = np.random.default_rng(0)
    pool = rng.normal(100, 10, 30)
    budgets = np.array([1, 2, 7, 30])
    assert expected_best_of_random(pool, budgets).tolist() == protocol_best(pool, budgets).tolist()
    scores = pd.DataFrame(
        {
            "instance": np.repeat([f"t{i}" for i in range(12)], 6),
            "optimizer": np.tile(np.repeat(["a", "b", "c"], 2), 12),
            "seed": np.tile([0, 1], 36),
            "score": rng.normal(0, 1, 72),
        }
    )
    means = scores.groupby(["instance", "optimizer"])["score"].mean().unstack("optimizer")
    mine = paired_table(means, alpha=0.05)
    theirs = paired_comparisons(scores, alpha=0.05)
    # The protocol's table has more columns since (d_z's bootstrap interval): the restated
    # ones must equal its columns of the same names.
    assert set(mine.columns) <= set(theirs.columns)
    pd.testing.assert_frame_equal(mine, theirs[list(mine.columns)])


def test_normalized_regret_against_hand_computed_values() -> None:
    curves = regret_curves(_log())
    # F_ref = 6 (the warm run's best); F_random(1) = 15, F_random(2) = 10 (pool 10, 20).
    got = curves.set_index(["method", "evaluation"])["regret"]
    expected = {
        ("random", 1): 4 / 9,
        ("random", 2): 1.0,
        ("cmaes", 1): 1.0,
        ("cmaes", 2): 0.75,
        ("contextual", 1): 2 / 9,
        ("contextual", 2): 0.5,  # one evaluation: the same F at budget 2
        ("warm-contextual", 1): 2 / 9,
        ("warm-contextual", 2): 0.0,
    }
    for key, value in expected.items():
        assert got[key] == pytest.approx(value), key


def test_the_amortization_counts_goals_until_the_training_pays() -> None:
    log = _log()
    curves = regret_curves(log)
    table = amortization_table(curves, log, [1, 2]).set_index("method")
    # Cold CMA-ES reaches 0.75 with 2 per goal; the contextual design does better with 1:
    # 100 training episodes are paid back after 100 goals (1 episode saved per goal).
    assert table.loc["contextual", "target_regret"] == pytest.approx(0.75)
    assert table.loc["contextual", "budget_needed"] == 1
    assert table.loc["contextual", "breakeven_goals"] == 100
    assert table.loc["warm-contextual", "breakeven_goals"] == 100


def _rows(
    variant: str, method: str, values: list[float], task: str = "t", replicate: int = 0
) -> list[dict]:
    return [
        {
            "variant": variant,
            "method": method,
            "replicate": replicate,
            "task": task,
            "evaluation": 1 if variant == "zero-shot" else k + 1,
            "free_energy": f,
        }
        for k, f in enumerate(values)
    ]


def _worse_zero_shot_log() -> pd.DataFrame:
    """The reviewer's case: random pool 0..100, cold CMA-ES F = 8 throughout, zero-shot 30."""
    return pd.DataFrame(
        _rows("cold", "random", [float(v) for v in range(101)])
        + _rows("cold", "cmaes", [8.0] * 64)
        + _rows("zero-shot", "contextual", [30.0])
        + _rows("warm", "warm-contextual", [30.0] * 10 + [4.0] * 54)
        + _rows("train", "contextual", [1.0] * 100, task="")
    )


def test_a_worse_zero_shot_design_never_reaches_cold_cmaes() -> None:
    log = _worse_zero_shot_log()
    curves = regret_curves(log)
    budgets = [1, 4, 8, 16, 32, 64]
    table = amortization_table(curves, log, budgets).set_index(["method", "reference_budget"])
    # An F of 30 never reaches cold CMA-ES's 8, whatever budget B it is judged at: the
    # regret of 30 at b = 1 (30 / 50) is below 8's at B = 64 on their own scales, but both are
    # read on B's scale here.
    for budget in budgets[1:]:
        row = table.loc[("contextual", budget)]
        assert np.isnan(row["budget_needed"]) and row["breakeven_goals"] == np.inf, budget
    # The warm start reaches 4 < 8 at its 11th evaluation: it pays where B - 11 > 0.
    warm = table.loc["warm-contextual"]
    assert warm.loc[[4, 8], "breakeven_goals"].tolist() == [np.inf, np.inf]
    assert warm.loc[[16, 32, 64], "budget_needed"].tolist() == [11, 11, 11]
    assert warm.loc[[16, 32, 64], "breakeven_goals"].tolist() == [20, 5, 2]
    # The target is cold CMA-ES's own regret at B: (8 - 0) / (F_random(B) - 0).
    from benchmarks.reports.breakeven import expected_best_of_random

    pool = np.arange(101.0)
    expected = 8.0 / expected_best_of_random(pool, np.array([64]))[0]
    assert table.loc[("contextual", 64), "target_regret"] == pytest.approx(expected)


def _disagreeing_seeds_log() -> pd.DataFrame:
    """Three training seeds that disagree: random pool 0..100, cold CMA-ES F = 8 throughout.

    Warm-contextual's replicates reach F = 4 at their 11th, 41st and 60th evaluations (30
    before); their mean over replicates is below 8 only from the 60th. The zero-shot designs:
    4 for replicate 0, 30 for the others (mean 21.3, never below 8). 100 training episodes each.
    """
    rows = _rows("cold", "random", [float(v) for v in range(101)])
    for r, reach in enumerate((11, 41, 60)):
        rows += _rows("cold", "cmaes", [8.0] * 64, replicate=r)
        rows += _rows("zero-shot", "contextual", [4.0 if r == 0 else 30.0], replicate=r)
        warm = [30.0] * (reach - 1) + [4.0] * (65 - reach)
        rows += _rows("warm", "warm-contextual", warm, replicate=r)
        rows += _rows("train", "contextual", [1.0] * 100, task="", replicate=r)
    return pd.DataFrame(rows)


def test_the_amortization_gives_the_range_across_training_seeds() -> None:
    from benchmarks.reports.breakeven import (
        AMORTIZATION_COLUMNS,
        amortization_cell,
        amortization_sentence,
    )

    log = _disagreeing_seeds_log()
    budgets = [1, 4, 8, 16, 32, 64]
    table = amortization_table(regret_curves(log), log, budgets)
    assert list(table.columns) == list(AMORTIZATION_COLUMNS)
    rows = table.set_index(["method", "reference_budget"])
    warm = rows.loc["warm-contextual"]
    assert (warm["replicates"] == 3).all()
    # Pooled: the mean over the replicates reaches 8 at 60, so it pays only where B > 60:
    # ceil(100 / 4) = 25 goals at B = 64. Each seed: 11, 41 and 60 per goal, so at B = 64
    # ceil(100 / 53) = 2 to 25 goals; at 32 only seed 0 pays (ceil(100 / 21) = 5); at 16 it
    # pays after ceil(100 / 5) = 20; at 8 each seed needs more than 8 per goal: never.
    assert warm.loc[64, ["budget_needed", "breakeven_goals"]].tolist() == [60, 25]
    assert warm.loc[64, ["budget_needed_min", "budget_needed_max"]].tolist() == [11, 60]
    assert warm.loc[64, ["goals_min", "goals_max"]].tolist() == [2, 25]
    assert warm.loc[32, ["budget_needed", "breakeven_goals"]].tolist() == [60, np.inf]
    assert warm.loc[32, ["goals_min", "goals_max"]].tolist() == [5, np.inf]
    assert warm.loc[16, ["goals_min", "goals_max"]].tolist() == [20, np.inf]
    assert warm.loc[8, ["budget_needed_min", "budget_needed_max"]].tolist() == [11, 60]
    assert warm.loc[8, ["goals_min", "goals_max"]].tolist() == [np.inf, np.inf]
    # The zero-shot designs: the pooled mean never reaches cold CMA-ES's 8, seed 0's does at
    # 1 per goal; the others never: the largest needed budget is "not reached" (NaN).
    zero = rows.loc[("contextual", 64)]
    assert np.isnan(zero["budget_needed"]) and zero["breakeven_goals"] == np.inf
    assert zero["budget_needed_min"] == 1 and np.isnan(zero["budget_needed_max"])
    assert [zero["goals_min"], zero["goals_max"]] == [2, np.inf]  # ceil(100 / 63)
    # In words: the pooled number, then the range across the seeds.
    assert amortization_cell(warm.loc[64].to_dict()) == (
        "25 goals (60 per goal; across the 3 training seeds: 2-25 goals, 11-60 per goal)"
    )
    assert amortization_cell(zero.to_dict()) == (
        "never (quality not reached; across the 3 training seeds: 2 goals or never, 1 per goal "
        "or not reached)"
    )
    assert amortization_cell(rows.loc[("warm-contextual", 8)].to_dict()) == (
        "never (60 per goal; across the 3 training seeds: never, 11-60 per goal)"
    )
    nobody = zero.to_dict() | {"budget_needed_min": math.nan, "goals_min": math.inf}
    assert amortization_cell(nobody) == (
        "never (quality not reached; not reached by any of the 3 training seeds)"
    )
    # One seed: no range (it is the pooled number).
    one = rows.loc[("warm-contextual", 64)].to_dict() | {"replicates": 1}
    assert amortization_cell(one) == "25 goals (60 per goal)"
    # The sentence: against cold CMA-ES after it adapts (B above the population size) first;
    # with a population size of 64, every B is before its first update, and is labelled so.
    assert amortization_sentence(table, popsize=8) == (
        "Fewest goals after which the training pays for itself, against cold CMA-ES after it "
        "adapts (B > 8, its population size): warm-contextual after 25 goals (60 per goal; "
        "across the 3 training seeds: 2-25 goals, 11-60 per goal) at B = 64; never at any "
        "budget: contextual."
    )
    assert amortization_sentence(table, popsize=64) == (
        "Fewest goals after which the training pays for itself, against cold CMA-ES after it "
        "adapts (B > 64, its population size): no budget of the study is that large; only "
        "against cold CMA-ES before its first update (B <= 64, its first generation of draws): "
        "warm-contextual after 25 goals (60 per goal; across the 3 training seeds: 2-25 goals, "
        "11-60 per goal) at B = 64; never at any budget: contextual."
    )
    with pytest.raises(ValueError, match="popsize must be a whole number >= 1, got -1"):
        amortization_sentence(table, popsize=-1)


def _warm_cold_log(margin: dict[int, float], tasks: int = 8) -> pd.DataFrame:
    """Tasks with F_ref near 1000: cold CMA-ES at 1000 + 50 / t, warm lower by margin[t] F."""
    rows = []
    for k in range(tasks):
        task = f"t{k}"
        jitter = 0.1 * k  # the differences are not all equal: Wilcoxon ranks them
        rows += _rows("cold", "random", [1100.0 + 10 * v for v in range(8)], task)
        cold = [1000.0 + 50.0 / t for t in range(1, 9)]
        warm = [f - margin.get(t, 0.0) * (1 + jitter) for t, f in enumerate(cold, start=1)]
        rows += _rows("cold", "cmaes", cold, task)
        rows += _rows("warm", "warm-contextual", warm, task)
    return pd.DataFrame(rows)


def _floors(log: pd.DataFrame, floor: float = 6.0) -> pd.Series:
    return pd.Series(floor, index=sorted(set(log["task"]) - {""}))


def test_the_verdict_is_one_sided_beyond_the_floor_and_one_holm_family() -> None:
    from benchmarks.reports.breakeven import warm_cold_table

    # Warm is better on every one of 8 tasks at budgets 2 and 8, by 3 F at 2 and by 20 F at 8;
    # the floor is 6 F: 3 F better is within the noise, 20 F beyond it.
    log = _warm_cold_log({2: 3.0, 8: 20.0})
    curves = regret_curves(log)
    budgets = [1, 2, 4, 8]
    table = warm_cold_table(curves, budgets, floors=_floors(log)).set_index("budget")
    # Budget 8: every (warm - cold) / floor + 1 is below 0: Wilcoxon's exact one-sided
    # p = 1 / 2^8; one Holm family of the 4 budgets tested.
    p = 1 / 2**8
    assert table.loc[8, "p"] == pytest.approx(p)
    assert table.loc[8, "p_holm"] == pytest.approx(4 * p) and table.loc[8, "beats_cold"]
    assert table.loc[8, "mean_floors"] < -1 and table.loc[8, "pairs"] == 8
    # Budget 2: better on every task, but by less than a floor: every difference + 1 is above
    # 0, so the test of "beyond the floor" says nothing (a two-sided test of the raw
    # differences would have had p = 2 / 2^8). Budgets 1 and 4: warm equals cold.
    assert table.loc[2, "p"] == pytest.approx(1.0) and not table.loc[2, "beats_cold"]
    assert -1 < table.loc[2, "mean_floors"] < 0
    assert not table.loc[[1, 4], "beats_cold"].any()
    # With 5 tasks, p = 1 / 2^5 = 0.031: alone it would be a win, in the one family of the 4
    # budgets it is not (4 p = 0.125).
    five = _warm_cold_log({2: 3.0, 8: 20.0}, tasks=5)
    family = warm_cold_table(regret_curves(five), budgets, floors=_floors(five))
    row = family.set_index("budget").loc[8]
    assert row["p"] == pytest.approx(1 / 2**5) and row["p_holm"] == pytest.approx(4 / 2**5)
    assert not family["beats_cold"].any()
    # A larger floor (30 F) puts the 20 F of budget 8 inside the noise.
    wide = warm_cold_table(curves, [8], floors=_floors(log, 30.0))
    assert -1 < wide.loc[0, "mean_floors"] < 0 and not wide.loc[0, "beats_cold"]
    with pytest.raises(ValueError, match="floors must be finite numbers > 0"):
        warm_cold_table(curves, budgets, floors=_floors(log, 0.0))


def test_warm_better_by_much_on_a_few_tasks_only_does_not_beat_cold() -> None:
    from benchmarks.reports.breakeven import warm_cold_table

    # 18 of 20 tasks: warm worse by 3-5 F (under a floor of 6 F); 2 tasks: better by 600 F.
    # The mean is far below -1 floor, and a two-sided test of the raw differences is
    # significant (on cold's side); the one-sided test of "beyond the floor" is not.
    rows = []
    for k in range(20):
        task = f"t{k}"
        shift = -600.0 if k < 2 else 3.0 + 0.1 * k
        rows += _rows("cold", "random", [1100.0 + 10 * v for v in range(8)], task)
        rows += _rows("cold", "cmaes", [1000.0] * 8, task)
        rows += _rows("warm", "warm-contextual", [1000.0 + shift] * 8, task)
    log = pd.DataFrame(rows)
    row = warm_cold_table(regret_curves(log), [8], floors=_floors(log)).iloc[0]
    assert row["mean_floors"] < -1 and row["median_floors"] > 0
    assert row["p"] > 0.5 and not row["beats_cold"]
    # Mirrored (warm better on 18 by 3-5 F, within the floor; worse on 2 by 600 F): no win.
    mirrored = log.assign(
        free_energy=np.where(
            log["method"] == "warm-contextual", 2000.0 - log["free_energy"], log["free_energy"]
        )
    )
    row = warm_cold_table(regret_curves(mirrored), [8], floors=_floors(log)).iloc[0]
    assert row["p"] > 0.99 and not row["beats_cold"]


def test_the_floor_is_the_larger_of_the_measured_range_and_the_least_floor() -> None:
    from benchmarks.reports.breakeven import task_floors

    f_ref = pd.Series({"a": 1000.0, "b": -2000.0, "c": 500.0})
    measured = pd.DataFrame({"task": ["a", "b"], "noise_range": [9.0, 3.0], "status": ["ok", "ok"]})
    table = task_floors(f_ref, measured, floor_fraction=0.006)
    # a: measured 9 > 6; b: measured 3 < 0.006 x 2000 = 12; c: no floor unit, the least one.
    assert table["floor"].tolist() == pytest.approx([9.0, 12.0, 3.0])
    assert table["measured"].tolist() == [True, True, False]
    with pytest.raises(ValueError, match="floor_fraction must be a number > 0, got 0"):
        task_floors(f_ref, measured, floor_fraction=0)


def test_the_noise_floor_fraction_is_the_protocols() -> None:
    from benchmarks.protocol.references import floor_min_fraction
    from benchmarks.reports.breakeven import noise_floor_fraction

    assert noise_floor_fraction() == floor_min_fraction()
    page = (Path(__file__).resolve().parents[1] / "docs" / "rl.md").read_text()
    assert f"the least floor {100 * noise_floor_fraction():.2f} % of |F_ref|" in (
        " ".join(page.split())
    )


def test_intervals_and_tests_over_tasks() -> None:
    # Two tasks with the same values: the t interval over tasks has zero width.
    log = pd.concat([_log(), _log().assign(task=lambda f: f["task"].replace("t", "u"))])
    curves = regret_curves(log)
    table = regret_table(curves, [1, 2]).set_index(["method", "budget"])
    assert table.loc[("cmaes", 2), "mean"] == pytest.approx(0.75)
    assert table.loc[("cmaes", 2), "tasks"] == 2
    assert table.loc[("cmaes", 2), "ci_low"] == pytest.approx(0.75)
    tests = comparison_table(curves, [2])
    assert set(tests["budget"]) == {2} and len(tests) == 6  # 4 methods: 6 pairs
    row = tests[(tests["a"] == "cmaes") & (tests["b"] == "warm-contextual")].iloc[0]
    assert row["mean_diff"] == pytest.approx(0.75) and not row["significant"]
    line = score_row("mine", regret_table(curves[curves["method"] == "cmaes"], [1, 2]))
    assert line == "| mine | 1.000 | 0.750 |"


class _FixedDesigner:
    """A policy that proposes one action at every task (no spread: the default step size)."""

    def predict(self, obs: object, deterministic: bool = True) -> tuple[np.ndarray, None]:
        return np.array([0.4, -0.3, 0.2], dtype=np.float32), None


@pytest.mark.slow
def test_a_run_of_the_largest_budget_read_at_a_smaller_one_is_the_run_of_that_budget() -> None:
    # The study runs every cold and warm run to the largest budget and reads it at the smaller
    # ones; that holds only if the first n evaluations of a long run are the run of budget n.
    # Budgets that end inside a generation and at its end (population 4; the warm run's first
    # evaluation is the proposal, so its generations end one later).
    from benchmarks.rl.agents import run_cmaes
    from benchmarks.rl.breakeven import _task_env
    from benchmarks.rl.warmstart import run_warm_cmaes

    task = breakeven_tasks()[0]

    def cold(n: int) -> list[float]:
        env = _task_env(task)
        try:
            records = run_cmaes(
                total_episodes=n,
                seed=11,
                goal=task.goal,
                box_mass=task.box_mass,
                popsize=4,
                env=env,
            )
        finally:
            env.close()
        return [r.free_energy for r in records]

    def warm(n: int) -> list[float]:
        env = _task_env(task)
        try:
            records, _ = run_warm_cmaes(
                _FixedDesigner(),
                total_episodes=n,
                seed=11,
                goal=task.goal,
                box_mass=task.box_mass,
                popsize=4,
                env=env,
            )
        finally:
            env.close()
        return [r.free_energy for r in records]

    for run in (cold, warm):
        longest = run(9)
        assert len(longest) == 9 and len(set(longest)) > 1
        for n in (2, 5):
            assert run(n) == longest[:n], (run.__name__, n)


def test_a_log_without_random_designs_has_no_scale() -> None:
    log = _log()
    with pytest.raises(ValueError, match="no random designs"):
        regret_curves(log[log["method"] != "random"])


# --- the smoke size end to end -----------------------------------------------------------


@pytest.fixture(scope="module")
def smoke_study(breakeven_smoke: Path) -> Path:
    # The session's study (tests/conftest.py), also read by docs/rl.md's block's tests.
    return breakeven_smoke


@pytest.mark.slow
def test_the_smoke_study_runs_resumes_and_reports(smoke_study: Path) -> None:
    log = load_breakeven(smoke_study)
    assert list(log.columns) == list(BREAKEVEN_COLUMNS)
    assert len(log) == breakeven_config("smoke").planned_evaluations()["total"]
    assert set(log["method"]) == {
        "random",
        "cmaes",
        "contextual",
        "ppo",
        "sac",
        "warm-contextual",
        "warm-ppo",
        "warm-sac",
        FLOOR_METHOD,
    }
    tested = log[log["variant"].isin(TESTED)]
    assert set(tested["task"]) == {"i03", "i04"}
    # Each task's noise floor: the best design of its cold CMA-ES runs in 4 nudged scenes, the
    # first the task's own, where its F is the run's, bit for bit (the same simulation).
    floors = noise_floors(log)
    assert floors["task"].tolist() == ["i03", "i04"] and (floors["scenes"] == 4).all()
    for row in floors.itertuples():
        cold = tested[(tested["method"] == "cmaes") & (tested["task"] == row.task)]
        best = cold.loc[cold["free_energy"].idxmin()]
        assert (row.c1, row.c2, row.c3) == (best["c1"], best["c2"], best["c3"])
        assert row.f_design == best["free_energy"]
        scenes = log[(log["variant"] == "floor") & (log["task"] == row.task)]
        assert scenes["evaluation"].tolist() == [1, 2, 3, 4]
        assert row.noise_range == scenes["free_energy"].max() - scenes["free_energy"].min() > 0
    assert (log[log["variant"] == "floor"]["replicate"] == -1).all()
    assert not (smoke_study / FAILURES_DIR).exists()
    # The warm run starts at the zero-shot design (simulated on ToolDesign-v0 through the
    # executor there, on ToolDesignRL-v0 here): the same F, bit for bit.
    for method in ("contextual", "ppo", "sac"):
        for task in ("i03", "i04"):
            zero = tested[(tested["method"] == method) & (tested["task"] == task)]
            warm = tested[(tested["method"] == f"warm-{method}") & (tested["task"] == task)]
            first = warm[warm["evaluation"] == 1]
            assert zero["free_energy"].tolist() == first["free_energy"].tolist()
            assert zero[["c1", "c2", "c3"]].to_numpy().tolist() == (
                first[["c1", "c2", "c3"]].to_numpy().tolist()
            )
    # Warm and cold CMA-ES of a task and replicate share their seed (paired).
    cold = tested[tested["method"] == "cmaes"].groupby("task")["seed"].first()
    warm = tested[tested["method"] == "warm-ppo"].groupby("task")["seed"].first()
    assert cold.to_dict() == warm.to_dict()
    assert (tested[tested["method"] == "cmaes"]["sigma0"] == 0.3).all()
    assert np.isfinite(tested[tested["method"] == "warm-sac"]["sigma0"]).all()
    # Each warm start's step size is the rule's, from the saved card's own spread at the task.
    from benchmarks.rl.policies import load_policy
    from benchmarks.rl.warmstart import proposal_spread, warm_sigma0

    for method in ("contextual", "ppo", "sac"):
        policy, _ = load_policy(smoke_study / "policies" / f"{method}-0.json")
        for task in breakeven_tasks()[:2]:
            run = tested[(tested["method"] == f"warm-{method}") & (tested["task"] == task.id)]
            expected = warm_sigma0(proposal_spread(policy, task.observation()))
            assert run["sigma0"].iloc[0] == pytest.approx(expected, rel=1e-12), (method, task)
    # The Parquet file alone loads the same frame.
    alone = load_breakeven(smoke_study / "evaluations.parquet")
    pd.testing.assert_frame_equal(
        alone.drop(columns=["eval_time", "opt_time"]), log.drop(columns=["eval_time", "opt_time"])
    )

    before = (smoke_study / "evaluations.parquet").read_bytes()
    # The same command again: nothing to run, the same data.
    assert (
        main(["rl", "breakeven", "--size", "smoke", "--out", str(smoke_study), "--no-progress"])
        == 0
    )
    assert (smoke_study / "evaluations.parquet").read_bytes() == before
    report = smoke_study / "report"
    for name in (
        "breakeven.md",
        "regret.csv",
        "noise_floors.csv",
        "warm_vs_cold.csv",
        "comparisons.csv",
        "amortization.csv",
        "regret.png",
        "amortization.png",
        "summary.json",
    ):
        assert (report / name).is_file(), name
    # `tooldesign report` rebuilds it from the stored files alone, byte for byte.
    before_report = {p.name: p.read_bytes() for p in report.iterdir()}
    assert main(["report", str(smoke_study)]) == 0
    assert {p.name: p.read_bytes() for p in report.iterdir()} == before_report
    regret = pd.read_csv(report / "regret.csv")
    assert set(regret["budget"]) == {1, 2, 4}
    # The verdict: 3 warm-started methods x 3 budgets in one Holm family; every pair apart.
    verdict = pd.read_csv(report / "warm_vs_cold.csv")
    assert sorted(set(verdict["method"])) == ["warm-contextual", "warm-ppo", "warm-sac"]
    assert len(verdict) == 9 and set(verdict["budget"]) == {1, 2, 4}
    assert (verdict["pairs"] == 2).all() and (verdict["tasks"] == 2).all()
    floor = pd.read_csv(report / "noise_floors.csv")
    assert floor["task"].tolist() == ["i03", "i04"] and floor["measured"].all()
    assert (floor["floor"] == np.fmax(floor["noise_range"], floor["least_floor"])).all()
    page = (report / "breakeven.md").read_text()
    assert "## Does warm-started CMA-ES beat cold CMA-ES?" in page
    assert "## Secondary: every pair of methods, each budget apart" in page
    # The verdict's words are the one wording docs/rl.md prints too, from the CSV read back.
    from benchmarks.reports.breakeven import (
        AMORTIZATION_COLUMNS,
        amortization_sentence,
        study_popsize,
        verdict_sentence,
    )
    from benchmarks.storage import read_manifest

    config = read_manifest(smoke_study)["config"]
    popsize = study_popsize(config)
    assert popsize == breakeven_config("smoke").size.popsize == 4
    sentence = verdict_sentence(
        verdict, budgets=config["size"]["budgets"], methods=config["methods"], popsize=popsize
    )
    assert f"{sentence} Table: `warm_vs_cold.csv`." in page
    assert list(verdict.columns) == list(WARM_COLD_COLUMNS)
    assert (verdict["p_worse_holm"] >= verdict["p_worse"]).all()
    # The amortization's range across seeds: one replicate, so the range is the pooled number.
    amortization = pd.read_csv(report / "amortization.csv")
    assert list(amortization.columns) == list(AMORTIZATION_COLUMNS)
    assert (amortization["replicates"] == 1).all()
    pd.testing.assert_series_equal(
        amortization["budget_needed_min"], amortization["budget_needed"], check_names=False
    )
    assert amortization_sentence(amortization, popsize=popsize) in page
    assert (verdict["replicates"] == 1).all()
    assert regret[regret["method"] == "random"]["mean"].notna().any()


class _Stop(Exception):
    """Raised by a progress callback: the study stops between two units, as after a kill."""


@pytest.mark.slow
def test_an_interrupted_study_resumes_to_the_same_data(smoke_study: Path, tmp_path: Path) -> None:
    out = tmp_path / "study"
    lines: list[str] = []

    def stop_after_five_units(line: str) -> None:
        lines.append(line)
        if len(lines) == 2 + 5:  # the estimate, the count on disk, then five units
            raise _Stop

    with pytest.raises(_Stop):
        run_breakeven(breakeven_config("smoke"), out, progress=stop_after_five_units)
    # The three trainings (cards, zero-shot designs) and two cold runs are on disk.
    assert sorted(p.name for p in (out / "policies").glob("*.json")) == [
        "contextual-0.json",
        "ppo-0.json",
        "sac-0.json",
    ]
    result = run_breakeven(breakeven_config("smoke"), out)
    assert result.units == 15 and result.units_run == 10
    timing = ["eval_time", "opt_time"]
    pd.testing.assert_frame_equal(
        load_breakeven(out).drop(columns=timing), load_breakeven(smoke_study).drop(columns=timing)
    )


@pytest.mark.slow
def test_a_study_with_other_settings_is_not_resumed(smoke_study: Path, tmp_path: Path) -> None:
    import shutil

    from benchmarks.storage import ResumeError

    copy = tmp_path / "copy"
    shutil.copytree(smoke_study, copy)
    with pytest.raises(ResumeError, match="learned"):
        run_breakeven(breakeven_config("smoke", learned=["contextual"]), copy)


@pytest.mark.slow
def test_a_users_callable_gets_its_row(
    smoke_study: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [
        "rl",
        "score",
        "--policy",
        f"{__name__}:straight_tool",
        "--study",
        str(smoke_study),
        "--name",
        "straight",
        "--refine",
        "--save",
        str(tmp_path / "mine.parquet"),
    ]
    assert main(argv) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "| method | 1 | 2 | 4 |"
    assert out[2].startswith("| straight | ") and out[3].startswith("| warm-straight | ")
    assert out[4] == f"evaluations: {tmp_path / 'mine.parquet'}" and len(out) == 5
    saved = pd.read_parquet(tmp_path / "mine.parquet")
    assert list(saved.columns) == list(BREAKEVEN_COLUMNS)
    # The straight tool (a = 0) at both tasks, then 4 warm-started evaluations at each.
    zero = saved[saved["variant"] == "zero-shot"]
    assert zero["task"].tolist() == ["i03", "i04"]
    assert (zero[["c1", "c2", "c3"]].to_numpy() == 0).all()
    assert (saved["variant"] == "warm").sum() == 8


def straight_tool(observation: np.ndarray) -> np.ndarray:
    """A user's policy: the straight tool (a = 0) at every task."""
    assert observation.shape == (4,) and observation.dtype == np.float32
    return np.zeros(3)


def test_score_refuses_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for argv, message in (
        (["--policy", "x:y", "--study", str(tmp_path / "none")], "no break-even study"),
        (["--policy", "x:y", "--study", str(tmp_path)], "no break-even study"),
        (["--policy", "x:y", "--study", str(tmp_path), "--save", "a.csv"], "--save must be"),
    ):
        with pytest.raises(SystemExit) as excinfo:
            main(["rl", "score", *argv])
        assert excinfo.value.code == 2
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err


@pytest.mark.slow
def test_a_stable_baselines3_zip_is_scored_through_the_process_pool(
    smoke_study: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sb3 = pytest.importorskip("stable_baselines3")
    from tooldesign_env.rl import ToolDesignRLEnv

    env = ToolDesignRLEnv()
    model = sb3.PPO("MlpPolicy", env, n_steps=8, batch_size=8, device="cpu", seed=0)
    model.save(tmp_path / "mine.zip")
    env.close()
    argv = ["rl", "score", "--policy", str(tmp_path / "mine.zip"), "--study", str(smoke_study)]
    with pytest.raises(SystemExit) as excinfo:
        main(argv)
    assert excinfo.value.code == 2
    err = capsys.readouterr().err
    assert "needs its algorithm" in err and "Traceback" not in err
    with pytest.raises(SystemExit) as excinfo:
        main([*argv, "--algorithm", "ppo"])
    assert "unpickling" in capsys.readouterr().err
    extra = ["--algorithm", "ppo", "--allow-pickle", "--executor", "process", "--workers", "2"]
    assert main([*argv, *extra]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[2].startswith("| mine | ") and len(out) == 3


@pytest.mark.slow
def test_units_on_dask_or_a_process_pool_give_the_serial_data(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    timing = ["eval_time", "opt_time"]
    frames = []
    for executor, workers in (("process", 1), ("dask", 2), ("process", 2)):
        config = breakeven_config(
            "smoke", learned=["contextual"], executor=executor, workers=workers
        )
        result = run_breakeven(config, tmp_path / f"{executor}-{workers}")
        frames.append(result.evaluations.drop(columns=timing))
    pd.testing.assert_frame_equal(frames[0], frames[1])
    pd.testing.assert_frame_equal(frames[0], frames[2])


def test_a_failed_zero_shot_design_counts_as_an_unusable_one() -> None:
    from benchmarks.rl.breakeven import _Work, _zero_shot_frame, unusable_free_energy

    tasks = breakeven_tasks()[:2]
    evaluated = pd.DataFrame(
        [
            {
                **t.row_fields(),
                **dict.fromkeys(("a1", "a2", "a3", "c1", "c2", "c3"), 0.0),
                "free_energy": math.nan if k == 1 else 5000.0,
                **dict.fromkeys(("goal_error", "confidence", "final_distance"), math.nan),
                "status": "failed" if k == 1 else "ok",
                "message": "RuntimeError: boom" if k == 1 else "",
                "eval_time": 0.1,
            }
            for k, t in enumerate(tasks)
        ]
    )
    work = _Work("train", "contextual", 7, 0)
    frame = _zero_shot_frame(evaluated, work=work, key=work.keys()[1], seconds=1.0, tasks=tasks)
    penalty = unusable_free_energy(tasks[1])
    # F_idle (the box never moves) + the invalid penalty 1e5, finite: the worst design.
    assert math.isfinite(penalty) and penalty > 1e5
    assert frame["free_energy"].tolist() == [5000.0, penalty]
    assert frame["status"].tolist() == ["ok", "failed"]
    # In the report it is a regret like any other (worse than random), not a missing value.
    rows = _rows("cold", "random", [4000.0 + 100 * v for v in range(16)], "t1")
    rows += _rows("cold", "cmaes", [4200.0] * 8, "t1")
    rows += _rows("zero-shot", "contextual", [penalty], "t1")
    curves = regret_curves(pd.DataFrame(rows), 8)
    regret = curves[curves["method"] == "contextual"]["regret"]
    assert regret.notna().all() and (regret > 1).all()


@pytest.mark.slow
def test_a_simulation_error_in_a_run_is_a_failed_evaluation_and_the_study_goes_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import json

    from benchmarks.rl import breakeven
    from benchmarks.storage import read_manifest

    real = breakeven._task_env
    steps = {"n": 0}

    def failing_env(task: object) -> object:
        env = real(task)  # type: ignore[arg-type]
        step = env.step

        def broken(action: object) -> object:
            steps["n"] += 1
            if steps["n"] == 3:  # the third evaluation of the cold and warm runs
                raise RuntimeError("injected: the physics server went away")
            return step(action)

        env.step = broken
        return env

    monkeypatch.setattr(breakeven, "_task_env", failing_env)
    out = tmp_path / "study"
    result = run_breakeven(breakeven_config("smoke", learned=["contextual"]), out)
    log = result.evaluations
    failed = log[log["status"] == "failed"]
    assert len(failed) == 1
    row = failed.iloc[0]
    # The first unit run at a task is random sampling at task 1: its third design failed.
    assert (row["method"], row["task"], row["evaluation"]) == ("random", "i03", 3)
    task = breakeven_tasks()[0]
    monkeypatch.setattr(breakeven, "_task_env", real)
    assert row["free_energy"] == breakeven.unusable_free_energy(task)
    # The run went on to its budget, and so did the study.
    run = log[(log["method"] == "random") & (log["task"] == "i03")]
    assert run["evaluation"].tolist() == [1, 2, 3, 4] and (run["status"] != "failed").sum() == 3
    assert result.units_run == result.units
    messages = out / FAILURES_DIR / f"cold-random-{int(row['seed'])}.json"
    data = json.loads(messages.read_text())
    assert data["failed"] == [
        {"evaluation": 3, "message": "RuntimeError: injected: the physics server went away"}
    ]
    assert any(FAILURES_DIR in name for name in read_manifest(out)["extra"]["file_sha256"])
    # The report says so, not only the log.
    make_breakeven_report(out)
    page = (out / "report" / "breakeven.md").read_text()
    assert "**1 evaluation(s) failed**" in page and "cold random 1" in page
    assert json.loads((out / "report" / "summary.json").read_text())["failed"] == {"cold random": 1}


@pytest.mark.slow
def test_a_studys_ppo_card_warm_starts_a_design_run(smoke_study: Path, tmp_path: Path) -> None:
    import json

    from benchmarks.rl.policies import load_policy
    from benchmarks.rl.warmstart import proposal_spread, warm_sigma0

    card = smoke_study / "policies" / "ppo-0.json"
    task = breakeven_tasks()[0]
    goal = [str(v) for v in task.goal]
    argv = ["design", "--policy", str(card), "--refine", "2", "--goal", *goal]
    argv += ["--box-mass", str(task.box_mass), "--out", str(tmp_path / "run")]
    assert main([*argv, "--no-progress", "--no-video"]) == 0
    settings = json.loads((tmp_path / "run" / "design.json").read_text())["config"][
        "optimizer_settings"
    ]
    policy, _ = load_policy(card)
    # PPO's spread is its Gaussian's exp(log_std), the step size half of it (in [0.02, 0.3]).
    spread = float(np.exp(policy.log_std.detach().numpy()).mean())
    assert proposal_spread(policy, task.observation()) == pytest.approx(spread)
    assert settings["sigma0"] == pytest.approx(warm_sigma0(spread))
    assert len(pd.read_csv(tmp_path / "run" / "evaluations.csv")) == 3


def test_the_verdict_tests_tasks_not_the_replicates_of_a_task() -> None:
    from benchmarks.reports.breakeven import warm_cold_table

    # Two tasks, ten replicates each, warm better beyond the floor in every pair: 20 pairs
    # counted as independent would give p = 1 / 2^20; they are two tasks, and two tasks cannot
    # make a win (the smallest one-sided p of 2 is 1 / 4).
    rows = []
    for k in range(2):
        for r in range(10):
            rows += _rows("cold", "random", [1100.0 + 10 * v for v in range(8)], f"t{k}", r)
            rows += _rows("cold", "cmaes", [1000.0 + r] * 8, f"t{k}", r)
            rows += _rows("warm", "warm-contextual", [950.0 + r] * 8, f"t{k}", r)
    log = pd.DataFrame(rows)
    row = warm_cold_table(regret_curves(log), [8], floors=_floors(log)).iloc[0]
    assert row["pairs"] == 20 and row["tasks"] == 2
    assert row["p"] == pytest.approx(1 / 4) and not row["beats_cold"]
    assert row["mean_floors"] == pytest.approx(-50 / 6) and row["median_floors"] < -1


def _seeds_log(shift: Callable[[int, int], float], tasks: int = 8) -> pd.DataFrame:
    """Tasks x 5 replicates; warm-contextual lower than cold CMA-ES by shift(task, replicate)."""
    rows = []
    for k in range(tasks):
        for r in range(5):
            task = f"t{k}"
            rows += _rows("cold", "random", [1100.0 + 10 * v for v in range(8)], task, r)
            rows += _rows("cold", "cmaes", [1000.0 + k] * 8, task, r)
            rows += _rows("warm", "warm-contextual", [1000.0 + k - shift(k, r)] * 8, task, r)
    return pd.DataFrame(rows)


def test_one_training_seed_alone_driving_the_win_shows_in_replicates_beyond() -> None:
    from benchmarks.reports.breakeven import verdict_markdown, warm_cold_table

    # Replicate 0's designer is better by 60 F (10 floors of 6 F) at every task, the other four
    # equal cold: every task's mean is about -2 floors, so the test over tasks passes (p =
    # 1 / 2^8), but one trained designer carries it.
    log = _seeds_log(lambda k, r: 60.0 + 0.5 * k if r == 0 else 0.0)
    table = warm_cold_table(regret_curves(log), [8], floors=_floors(log))
    row = table.iloc[0]
    assert row["beats_cold"] and row["p"] == pytest.approx(1 / 2**8)
    assert row["replicates"] == 5 and row["replicates_beyond"] == 1
    assert list(table.columns) == list(WARM_COLD_COLUMNS)
    line = verdict_markdown(table)[2]
    assert line.startswith("| 8 | warm-contextual | 40 (8) |") and "| 1 / 0 of 5 |" in line
    # The same mean spread over the seeds (each better by about 2 floors): 5 of 5.
    even = _seeds_log(lambda k, r: 12.0 + 0.1 * k)
    row = warm_cold_table(regret_curves(even), [8], floors=_floors(even)).iloc[0]
    assert row["beats_cold"] and row["replicates_beyond"] == 5


def _verdict_frame(rows: list[tuple[str, int, float, bool, int]]) -> pd.DataFrame:
    """A warm_vs_cold table: (method, budget, p_holm, beats_cold, tasks) per row.

    The mirror test finds nothing (p 1) in every tested row: no row is worse.
    """
    return pd.DataFrame(
        [
            {
                "method": m,
                "budget": b,
                "pairs": 5 * t,
                "tasks": t,
                "mean_floors": -1.5,
                "ci_low": math.nan if t < 2 else -2.0,
                "ci_high": math.nan if t < 2 else -1.0,
                "median_floors": -1.5,
                "replicates": 5,
                "replicates_beyond": 4,
                "replicates_worse": 0,
                "p": p,
                "p_holm": p,
                "beats_cold": won,
                "p_worse": math.nan if math.isnan(p) else 1.0,
                "p_worse_holm": math.nan if math.isnan(p) else 1.0,
                "worse_than_cold": False,
            }
            for m, b, p, won, t in rows
        ],
        columns=list(WARM_COLD_COLUMNS),
    )


STUDY = ["random", "cmaes", "contextual", "ppo", "warm-contextual", "warm-ppo"]


def test_the_verdict_counts_only_finite_p_as_tests_and_names_the_untested() -> None:
    from benchmarks.reports.breakeven import verdict_sentence

    # One task: no row has a p. No test was made, and the words must not say "in all N tests".
    one_task = _verdict_frame(
        [("warm-contextual", 8, math.nan, False, 1), ("warm-ppo", 8, math.nan, False, 1)]
    )
    words = verdict_sentence(one_task, budgets=[8], methods=STUDY, popsize=8)
    assert words == (
        "**Verdict:** no test was made, so the study does not say whether a warm-started "
        "designer beats cold CMA-ES; not tested (fewer than 2 tasks with both runs): "
        "warm-contextual at 8; warm-ppo at 8."
    )
    # A win at 2; warm-ppo untested at 2; budget 4 tested without a win; budget 16 of the
    # study not in the table at all: untested, and no "every budget of the study".
    mixed = _verdict_frame(
        [
            ("warm-contextual", 2, 0.01, True, 20),
            ("warm-ppo", 2, math.nan, False, 1),
            ("warm-contextual", 4, 0.3, False, 20),
            ("warm-ppo", 4, 0.6, False, 20),
        ]
    )
    words = verdict_sentence(mixed, budgets=[2, 4, 16], methods=STUDY, popsize=8)
    assert words == (
        "**Verdict:** warm-started CMA-ES beats cold CMA-ES beyond the noise floor (Holm p < "
        "0.05, over the tasks, for the study's trained designers) before cold CMA-ES's first "
        "update (its first generation of 8 draws), at budget 2 (at 2: warm-contextual, with 4 "
        "of 5 training seeds beyond the floor), while at budget 4 none of the designers tested "
        "does; not tested (fewer than 2 tasks with both runs): warm-contextual at 16; warm-ppo "
        "at 2 and 16. No warm-started designer is worse than cold CMA-ES beyond the noise floor "
        "at any budget tested (the mirror test: Holm p >= 0.05 in all 3 tests)."
    )
    # No win: the count is of the tests made (2), not of the rows (3).
    lost = _verdict_frame(
        [
            ("warm-contextual", 4, 0.3, False, 20),
            ("warm-ppo", 4, 0.6, False, 20),
            ("warm-ppo", 8, math.nan, False, 0),
        ]
    )
    words = verdict_sentence(lost, budgets=[4, 8], methods=STUDY, popsize=8)
    assert "at any budget tested (4): Holm p >= 0.05 in all 2 tests; the smallest, 0.3" in words
    assert words.endswith(
        "not tested (fewer than 2 tasks with both runs): warm-contextual at 8; warm-ppo at 8. "
        "No warm-started designer is worse than cold CMA-ES beyond the noise floor at any "
        "budget tested (the mirror test: Holm p >= 0.05 in all 2 tests)."
    )
    # Every budget of the study won: said; a budget of the study left out of the table: not.
    every = _verdict_frame(
        [("warm-contextual", 2, 0.01, True, 20), ("warm-contextual", 4, 0.02, True, 20)]
    )
    methods = ["cmaes", "warm-contextual"]
    assert (
        verdict_sentence(every, budgets=[2, 4], methods=methods, popsize=8)
        .split(". ")[0]
        .endswith("; that is every budget of the study")
    )
    assert "every budget" not in verdict_sentence(
        every, budgets=[2, 4, 8], methods=methods, popsize=8
    )


def test_the_verdict_tells_wins_before_cold_cmaes_first_update_from_wins_after() -> None:
    from benchmarks.reports.breakeven import study_popsize, verdict_sentence

    # Wins at 1, 4 and 8 (two designers at 4, with different seed counts) and 16; none at 64.
    table = _verdict_frame(
        [
            ("warm-contextual", 1, 0.001, True, 20),
            ("warm-contextual", 4, 0.001, True, 20),
            ("warm-ppo", 4, 0.002, True, 20),
            ("warm-contextual", 8, 0.01, True, 20),
            ("warm-contextual", 16, 0.01, True, 20),
            ("warm-contextual", 64, 0.5, False, 20),
        ]
    )
    table.loc[table["method"] == "warm-ppo", "replicates_beyond"] = 3
    budgets = [1, 4, 8, 16, 64]
    methods = ["cmaes", "warm-contextual", "warm-ppo"]
    words = verdict_sentence(table, budgets=budgets, methods=methods, popsize=8)
    assert words.startswith(
        "**Verdict:** warm-started CMA-ES beats cold CMA-ES beyond the noise floor (Holm p < "
        "0.05, over the tasks, for the study's trained designers) before cold CMA-ES's first "
        "update (its first generation of 8 draws), at budgets 1, 4 and 8 (at 1, where the warm "
        "run is its zero-shot design: warm-contextual, with 4 of 5 training seeds beyond the "
        "floor; at 4: warm-contextual and warm-ppo, with 4 of 5 and 3 of 5 training seeds "
        "beyond the floor respectively; at 8: warm-contextual, with 4 of 5 training seeds "
        "beyond the floor); after cold CMA-ES adapts, at budget 16 (at 16: warm-contextual, "
        "with 4 of 5 training seeds beyond the floor), while at budget 64 none of the designers "
        "tested does; not tested"
    )
    # The population size is the study's, not a constant: with 4, the win at 8 is after cold
    # CMA-ES adapts; with 64, every budget is before its first update.
    four = verdict_sentence(table, budgets=budgets, methods=methods, popsize=4)
    assert "(its first generation of 4 draws), at budgets 1 and 4 (" in four
    assert "after cold CMA-ES adapts, at budgets 8 and 16 (at 8: " in four
    big = verdict_sentence(table, budgets=budgets, methods=methods, popsize=64)
    assert "first generation of 64 draws), at budgets 1, 4, 8 and 16 (" in big
    assert "after cold CMA-ES adapts" not in big
    assert "while at budget 64 none of the designers tested does" in big
    # No win before the first update: that phase says so.
    late = _verdict_frame(
        [("warm-contextual", 4, 0.5, False, 20), ("warm-contextual", 16, 0.01, True, 20)]
    )
    words = verdict_sentence(late, budgets=[4, 16], methods=methods, popsize=8)
    assert (
        "(its first generation of 8 draws), at budget 4 none of the designers tested does; "
        "after cold CMA-ES adapts, at budget 16 (" in words
    )
    for bad in (0, 2.5, True, None):
        with pytest.raises(ValueError, match=f"popsize must be a whole number >= 1, got {bad}"):
            verdict_sentence(table, budgets=budgets, methods=methods, popsize=bad)  # type: ignore[arg-type]
    assert study_popsize({"size": {"popsize": 8}}) == 8
    configs: list[dict[str, Any]] = [{"size": {}}, {"size": {"popsize": "8"}}, {}]
    for config in configs:
        with pytest.raises(ValueError, match=r"no CMA-ES population size \(size.popsize\)"):
            study_popsize(config)


def _harm_log() -> pd.DataFrame:
    """12 tasks x 5 replicates: warm-contextual worse than cold CMA-ES beyond a 6 F floor.

    Tasks 0-10: replicates 0-3 of warm are worse by 30 + k F (5 to 6.7 floors), replicate 4
    equals cold; task 11: warm worse by 3 F (half a floor, within the noise) in every replicate.
    """
    return _seeds_log(lambda k, r: -3.0 if k == 11 else (-(30.0 + k) if r < 4 else 0.0), 12)


def test_the_mirror_test_names_warm_worse_than_cold_beyond_the_floor() -> None:
    from benchmarks.reports.breakeven import verdict_markdown, verdict_sentence, warm_cold_table

    log = _harm_log()
    table = warm_cold_table(regret_curves(log), [8], floors=_floors(log))
    row = table.iloc[0]
    # Per task, d' = mean z - 1: 11 tasks at 3 + 2k/15 > 0, one at -0.5 (rank 1): the exact
    # one-sided p of the signed ranks is 2 / 2^12 (T- of 0 or 1); one row, so Holm is the same.
    assert row["p_worse"] == pytest.approx(2 / 2**12)
    assert row["p_worse_holm"] == pytest.approx(2 / 2**12) and row["worse_than_cold"]
    assert not row["beats_cold"] and row["p"] > 0.99
    assert row["replicates_worse"] == 4 and row["replicates_beyond"] == 0
    assert list(table.columns) == list(WARM_COLD_COLUMNS)
    line = verdict_markdown(table)[2]
    assert line.startswith("| 8 | warm-contextual | 60 (12) |")
    assert line.endswith("| 0 / 4 of 5 | 1 | 0.000488 | no | yes |")
    mean = float(row["mean_floors"])
    words = verdict_sentence(table, budgets=[8], methods=["cmaes", "warm-contextual"], popsize=8)
    assert words.endswith(
        "in its one test (1, warm-contextual's) at budget 8. Warm-started CMA-ES is worse than "
        "cold CMA-ES beyond the noise floor (the mirror test, Holm p < 0.05): warm-contextual "
        f"at 8 ({mean:+.2f} floors; 4 of 5 training seeds worse beyond the floor)."
    )
    # Holm over the family of rows: the runs do not move with the budget, so at 4 budgets the
    # 4 rows have that p each; Holm multiplies every one by 4 (0.00195), all still worse.
    family = warm_cold_table(regret_curves(log), [1, 2, 4, 8], floors=_floors(log))
    assert family["p_worse_holm"].tolist() == pytest.approx([4 * 2 / 2**12] * 4)
    assert family["worse_than_cold"].all()
    # Worse by more than a floor on 4 of the 12 tasks only: the mean is above +1 floor, the
    # test does not pass, and the words still name the row.
    few = _seeds_log(lambda k, r: -(30.0 + k) if k < 4 else 0.5 * k, 12)
    row = warm_cold_table(regret_curves(few), [8], floors=_floors(few)).iloc[0]
    assert row["mean_floors"] > 1 and not row["worse_than_cold"]
    words = verdict_sentence(
        warm_cold_table(regret_curves(few), [8], floors=_floors(few)),
        budgets=[8],
        methods=["cmaes", "warm-contextual"],
        popsize=8,
    )
    assert words.endswith(
        "No warm-started designer is worse than cold CMA-ES beyond the noise floor at any budget "
        "tested (the mirror test: Holm p >= 0.05 in its one test); warm's mean over tasks is "
        "more than one floor above cold's, without a significant test, for warm-contextual at "
        f"8 ({row['mean_floors']:+.2f} floors; 5 of 5 training seeds worse beyond the floor)."
    )
    # A stored decision that is not one is refused by name.
    bad = table.assign(worse_than_cold=["yes"])
    with pytest.raises(ValueError, match="worse_than_cold must be True or False, got 'yes'"):
        verdict_markdown(bad)


def test_the_verdict_names_the_missing_cold_run_and_refuses_a_cell_that_is_no_decision() -> None:
    from benchmarks.reports.breakeven import verdict_row, verdict_sentence, verdict_test_text

    empty = _verdict_frame([])
    words = verdict_sentence(empty, budgets=[1, 4], methods=["random", "warm-ppo"], popsize=8)
    assert "has no cold CMA-ES run (method `cmaes`)" in words
    words = verdict_sentence(empty, budgets=[1, 4], methods=["random", "cmaes"], popsize=8)
    assert "has no warm-started designer" in words
    # An empty beats_cold cell (NaN as read back from CSV) is not read as "yes".
    table = _verdict_frame([("warm-ppo", 4, 0.01, True, 20)])
    table["beats_cold"] = [math.nan]
    with pytest.raises(ValueError, match="beats_cold must be True or False, got nan"):
        verdict_sentence(table, budgets=[4], methods=STUDY, popsize=8)
    with pytest.raises(ValueError, match="beats_cold must be True or False, got nan"):
        verdict_row(table.to_dict("records")[0])
    table["beats_cold"] = ["False"]
    assert verdict_row(table.to_dict("records")[0])[-2:] == ["no", "no"]
    with pytest.raises(ValueError, match="replicates must be a whole number >= 1, got 0"):
        verdict_test_text(0, 18, popsize=8)
    with pytest.raises(ValueError, match="tests must be a whole number >= 0, got -1"):
        verdict_test_text(5, -1, popsize=8)
    with pytest.raises(ValueError, match="popsize must be a whole number >= 1, got 0"):
        verdict_test_text(5, 18, popsize=0)
    # The test over training seeds: with 5 seeds and 18 tests it could not pass; with 9 it could.
    text = verdict_test_text(5, 18, popsize=8)
    assert "1 / 2^5 = 0.0312, times the 18 tests is not below 0.05" in text
    assert "could not pass" not in verdict_test_text(9, 18, popsize=8)
    assert "the study's trained designers (5 training seeds) on new tasks" in text
    # The mirror test and the budgets before cold CMA-ES's first update are described.
    assert (
        "The mirror test, for harm: the one-sided Wilcoxon test over the tasks that warm's F "
        "is higher than cold's by more than one floor (the task means - 1 above 0)" in text
    )
    assert "Up to 8 evaluations (the study's CMA-ES population size) cold CMA-ES" in text
    assert "Up to 4 evaluations" in verdict_test_text(5, 18, popsize=4)
