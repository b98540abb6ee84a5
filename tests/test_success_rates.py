"""Success rates beside F: computed from stored rows, Wilson intervals, the committed reports.

A design succeeds when it was usable and left the box within the task's tolerance of the goal
(``info["success"]``); the reports derive it from the stored ``status`` and ``final_distance``
(``benchmarks/reports/success.py``), so every committed folder reports it without simulating.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm

from benchmarks.reports.comparison import _summary_markdown, make_report, summary_table
from benchmarks.reports.success import (
    design_succeeded,
    run_successes,
    success_cell,
    success_rate,
    task_of_manifest,
    task_tolerance,
    wilson_interval,
)
from benchmarks.storage import ResultStore

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
Z = float(norm.ppf(0.975))
PUSH = 0.1  # tooldesign_env/tasks/push.py's tolerance, m


# --- the Wilson interval ------------------------------------------------------------------------


@pytest.mark.parametrize("n", [1, 2, 10, 37])
def test_wilson_edges_are_exact_at_zero_and_all(n: int) -> None:
    # Closed forms at the edges: k = 0 gives [0, z^2 / (n + z^2)], k = n its mirror.
    low, high = wilson_interval(0, n)
    assert low == 0.0 and high == pytest.approx(Z * Z / (n + Z * Z), rel=1e-12)
    low, high = wilson_interval(n, n)
    assert high == 1.0 and low == pytest.approx(n / (n + Z * Z), rel=1e-12)


def test_wilson_matches_its_formula_and_is_symmetric() -> None:
    # 5 of 10 at 95 %: the textbook [0.2366, 0.7634].
    low, high = wilson_interval(5, 10)
    assert (low, high) == pytest.approx((0.236593, 0.763407), abs=1e-6)
    for k in range(8):
        a_low, a_high = wilson_interval(k, 7)
        b_low, b_high = wilson_interval(7 - k, 7)
        assert a_low == pytest.approx(1 - b_high) and a_high == pytest.approx(1 - b_low)
        assert 0.0 <= a_low <= k / 7 <= a_high <= 1.0
    # A wider level gives a wider interval.
    assert wilson_interval(3, 10, 0.99)[0] < wilson_interval(3, 10, 0.95)[0]


def test_wilson_of_no_trials_is_nan() -> None:
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((11, 10), r"successes must be in \[0, n\]"),
        ((-1, 10), r"successes must be in \[0, n\]"),
        ((0, -1), r"successes must be in \[0, n\]"),
        ((1.5, 10), "successes must be a whole number"),
        ((True, 10), "successes must be a whole number"),
        ((1, 10.0), "n must be a whole number"),
        ((1, 10, 1.0), r"level must be in \(0, 1\)"),
        ((1, 10, 0.0), r"level must be in \(0, 1\)"),
    ],
)
def test_wilson_refuses_bad_input(args: tuple[Any, ...], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        wilson_interval(*args)


# --- one design, one run, a rate --------------------------------------------------------------


def test_a_design_succeeds_only_usable_and_within_the_tolerance() -> None:
    assert design_succeeded("ok", 0.1, PUSH) is True  # on the radius counts, as in the env
    assert design_succeeded("ok", 0.1000001, PUSH) is False
    assert design_succeeded("invalid", 0.0, PUSH) is False
    assert design_succeeded("failed", None, PUSH) is False
    assert design_succeeded("ok", None, PUSH) is None
    assert design_succeeded("ok", float("nan"), PUSH) is None


def _rows(runs: dict[tuple[str, int], list[tuple[float, float, str]]]) -> pd.DataFrame:
    """Evaluation rows by hand: per (optimizer, seed), its (F, final distance, status)."""
    rows = []
    for (optimizer, seed), evaluations in runs.items():
        for iteration, (f, distance, status) in enumerate(evaluations):
            rows.append(
                {
                    "suite": "s",
                    "variant": "",
                    "optimizer": optimizer,
                    "seed": seed,
                    "iteration": iteration,
                    "candidate": 0,
                    "free_energy": f,
                    "final_distance": distance,
                    "status": status,
                }
            )
    return pd.DataFrame(rows)


HAND = {
    # The lowest F (8) is far; the run fails though an earlier design was close.
    ("cmaes", 0): [(10.0, 0.05, "ok"), (8.0, 0.3, "ok")],
    # The lowest F is an invalid design's penalty-free NaN-less row: only ok rows count.
    ("cmaes", 1): [(9.0, 0.08, "ok"), (1.0, 0.0, "invalid")],
    # A tie: the first of the equal lowest F is the run's design.
    ("cmaes", 2): [(5.0, 0.01, "ok"), (5.0, 0.9, "ok")],
    # Nothing usable: no success.
    ("random", 0): [(float("nan"), float("nan"), "failed"), (7.0, 0.0, "invalid")],
    # Usable, but its distance was not stored: unknown.
    ("random", 1): [(4.0, float("nan"), "ok")],
    ("random", 2): [(6.0, 0.1, "ok")],
}


def test_each_runs_final_design_decides_its_success() -> None:
    got = run_successes(_rows(HAND), PUSH).set_index(["optimizer", "seed"])["success"]
    assert got.to_dict() == {
        ("cmaes", 0): False,
        ("cmaes", 1): True,
        ("cmaes", 2): True,
        ("random", 0): False,
        ("random", 1): None,
        ("random", 2): True,
    }


def test_the_summary_gives_counts_rates_and_wilson_bounds() -> None:
    summary = summary_table(_rows(HAND), tolerance=PUSH).set_index("optimizer")
    cmaes, random = summary.loc["cmaes"], summary.loc["random"]
    assert (cmaes["successes"], cmaes["success_runs"]) == (2, 3)
    assert cmaes["success_rate"] == pytest.approx(2 / 3)
    assert (cmaes["success_low"], cmaes["success_high"]) == pytest.approx(wilson_interval(2, 3))
    # The unknown run is left out of n, not counted as a failure.
    assert (random["successes"], random["success_runs"]) == (1, 2)
    text = _summary_markdown(summary.reset_index(), 0.95, task="push", tolerance=PUSH)
    row = next(line for line in text.splitlines() if line.startswith("| random"))
    assert "50 % (1/2) [9 %, 91 %] (1 run(s) without a final distance)" in row
    assert "within 0.1 m of the goal (the push task's tolerance)" in text
    # A tighter tolerance: fewer successes, from the same rows.
    tight = summary_table(_rows(HAND), tolerance=0.02).set_index("optimizer")
    assert tight.loc["cmaes", "successes"] == 1


def test_rows_without_final_distance_report_na_never_zero() -> None:
    rows = _rows(HAND).drop(columns="final_distance")
    summary = summary_table(rows, tolerance=PUSH).set_index("optimizer")
    # Only the runs with nothing usable are known (failures); the rest are unknown.
    assert summary.loc["cmaes", "success_runs"] == 0
    assert math.isnan(summary.loc["cmaes", "success_rate"])
    assert success_cell(success_rate([None, None])) == "n/a (2 run(s) without a final distance)"
    text = _summary_markdown(summary.reset_index(), 0.95)
    row = next(line for line in text.splitlines() if line.startswith("| cmaes"))
    assert "| n/a (3 run(s) without a final distance) |" in row and "0 %" not in row


def test_rates_at_the_edges_show_their_wilson_bounds() -> None:
    assert success_cell(success_rate([False] * 10)) == "0 % (0/10) [0 %, 28 %]"
    assert success_cell(success_rate([True] * 10)) == "100 % (10/10) [72 %, 100 %]"
    assert success_cell(success_rate([])) == "n/a"


@pytest.mark.slow
def test_a_folder_whose_distances_were_not_stored_still_reports(tmp_path: Path) -> None:
    # The store keeps a final_distance column; an old or partial writer may leave it empty.
    store = ResultStore(tmp_path / "run")
    rows = _rows({("cmaes", s): [(10.0 - s, float("nan"), "ok")] for s in range(3)})
    for seed in range(3):
        store.write_batch(
            rows[rows["seed"] == seed]
            .drop(columns="variant")
            .assign(
                eval_id=0,
                goal_error=1.0,
                confidence=0.0,
                eval_time=0.0,
                opt_time=0.0,
                goal_x=0.0,
                goal_y=1.5,
                goal_z=0.1,
                goal_precision=20.0,
                box_mass=0.1,
                c1=0.0,
            )
        )
    make_report(tmp_path / "run", n_boot=50)
    summary = pd.read_csv(tmp_path / "run" / "report" / "summary.csv")
    assert summary["success_runs"].tolist() == [0] and summary["success_rate"].isna().all()
    assert (
        "n/a (3 run(s) without a final distance)"
        in (tmp_path / "run" / "report" / "summary.md").read_text()
    )


# --- which task -------------------------------------------------------------------------------


def test_the_task_comes_from_the_manifest_and_defaults_to_push() -> None:
    assert task_of_manifest(None) == "push"
    assert task_of_manifest({"config": {"goal": [0, 1, 0]}}) == "push"  # suites, old runs
    assert task_of_manifest({"config": {"task_name": "hook"}}) == "hook"
    assert task_tolerance() == PUSH == task_tolerance("push")
    with pytest.raises(ValueError, match="unknown task 'nope'"):
        task_tolerance("nope")


# --- the protocol, the designs table, the HTML card --------------------------------------------


def test_the_protocol_measures_success_at_each_budget() -> None:
    from benchmarks.protocol.report import _auc_table, measure_runs

    runs = pd.DataFrame(
        {
            "optimizer": "a",
            "instance": "i01",
            "set": "public",
            "degree": 3,
            "seed": 0,
            "evaluation": [1, 2, 3, 4],
            "free_energy": [1000.0, 150.0, np.nan, 105.0],
            "status": ["ok", "ok", "failed", "ok"],
            "final_distance": [0.05, 0.4, np.nan, 0.08],
        }
    )
    reference = {"f_ref": 100.0, "noise_floor": 10.0, "random_pool": [1100.0] * 5}
    _, scores = measure_runs(runs, {("i01", 3): reference}, {3: 4}, n_targets=3)
    # Budget 4: the best after 1 evaluation is F 1000 (close), after 2 F 150 (far), after 4
    # F 105 (close).
    record = scores.iloc[0]
    assert (record["success_0.25"], record["success_0.5"], record["success_1"]) == (
        True,
        False,
        True,
    )
    table = _auc_table(scores, "degree")
    assert table["success"].tolist() == ["100 % (1/1) [21 %, 100 %]"]
    # Cells stored without final_distance: unknown, not failed.
    _, scores = measure_runs(
        runs.drop(columns="final_distance"), {("i01", 3): reference}, {3: 4}, n_targets=3
    )
    assert scores.iloc[0]["success_1"] is None
    assert _auc_table(scores, "degree")["success"].tolist() == [
        "n/a (1 run(s) without a final distance)"
    ]


def test_the_designs_table_says_which_design_succeeded() -> None:
    from benchmarks.reports.suite import designs_table

    def record(seed: int, distance: float | None, status: str) -> dict[str, Any]:
        return {
            "suite": "s",
            "variant": "",
            "optimizer": "cmaes",
            "seed": seed,
            "goal": [0.0, 1.5, 0.1],
            "goal_precision": 20.0,
            "coefficients": [0.0, 0.0, 0.0],
            "free_energy": 1.0,
            "final_distance": distance,
            "status": status,
        }

    records = [record(0, 0.05, "ok"), record(1, 0.2, "ok"), record(2, None, "ok")]
    records.append(record(3, 0.0, "invalid"))
    table = designs_table(records)
    assert table["success"].tolist() == [True, False, None, False]
    assert designs_table(records, tolerance=0.3)["success"].tolist() == [True, True, None, False]


def test_the_html_card_says_success_from_the_stored_distance() -> None:
    from benchmarks.reports.html import _success_line

    assert "Success: yes" in _success_line("ok", 0.04, None)
    assert "Success: no" in _success_line("ok", 0.3, "push", {"status": "ok", "final_distance": 0})
    assert "the straight tool: yes" in _success_line(
        "ok", 0.3, "push", {"status": "ok", "final_distance": 0}
    )
    assert "Success:</strong> n/a" in _success_line("ok", None, "hook")
    assert "not usable" in _success_line("invalid", 0.0, "push")
    assert "not registered here" in _success_line("ok", 0.0, "someones-plugin-task")


def test_an_evaluation_page_says_no_success_where_the_env_said_the_box_does_not_stand(
    tmp_path: Path,
) -> None:
    """terms.json holds the env's success, which also asks the box to stand: the page agrees
    with it (and with tooldesign evaluate's line) for a box lying within the radius."""
    from benchmarks.reports.html import _evaluate_page, _success_line

    lying = {"success": False, "final_tilt": math.pi / 2, "final_height": 0.05}
    line = _success_line("ok", 0.04, "obstacle", standing=lying)
    assert "Success: no" in line and "does not stand" in line, line
    assert "90.0 degrees" in line and "0.050 m high" in line
    # Standing, or no verdict of the env stored (an older folder): the distance decides.
    upright = {"success": True, "final_tilt": 0.0, "final_height": 0.1}
    assert "Success: yes" in _success_line("ok", 0.04, "obstacle", standing=upright)
    assert "Success: yes" in _success_line("ok", 0.04, "obstacle", standing={})
    terms = {"valid": True, "final_distance": 0.04, "task": "obstacle", **lying}
    assert "does not stand" in _evaluate_page(tmp_path, [], terms)


# --- the committed reports -------------------------------------------------------------------


def _committed_folders() -> list[Path]:
    return sorted(p.parents[1] for p in RESULTS.glob("**/report/summary.csv"))


def _by_hand(folder: Path) -> dict[tuple[str, str], tuple[int, int]]:
    """(successes, runs) per (variant, optimizer), from the rows with pandas alone."""
    rows = ResultStore(folder).read()
    ok = rows[(rows["status"] == "ok") & np.isfinite(rows["free_energy"])]
    # Each run's lowest F, the first of equal ones in the log's order.
    best = ok.loc[ok.groupby(["variant", "optimizer", "seed"], sort=False)["free_energy"].idxmin()]
    best = best.assign(hit=best["final_distance"] <= PUSH)
    everyone = rows.groupby(["variant", "optimizer"])["seed"].nunique()
    hits = best.groupby(["variant", "optimizer"])["hit"].sum()
    return {key: (int(hits.get(key, 0)), int(n)) for key, n in everyone.items()}


def test_there_are_committed_reports_to_check() -> None:
    assert len(_committed_folders()) >= 10


@pytest.mark.parametrize("folder", _committed_folders(), ids=lambda p: str(p.relative_to(RESULTS)))
def test_committed_success_rates_are_those_of_the_rows(folder: Path) -> None:
    summary = pd.read_csv(folder / "report" / "summary.csv", keep_default_na=False)
    expected = _by_hand(folder)
    got = {
        (str(row["variant"]), str(row["optimizer"])): (
            int(row["successes"]),
            int(row["success_runs"]),
        )
        for _, row in summary.iterrows()
    }
    assert got == expected
    text = (folder / "report" / "summary.md").read_text()
    for (_, optimizer), (k, n) in expected.items():
        low, high = wilson_interval(k, n)
        cell = f"{100 * k / n:.0f} % ({k}/{n}) [{100 * low:.0f} %, {100 * high:.0f} %]"
        assert f"| {optimizer} |" in text and cell in text
    designs = folder / "report" / "designs.csv"
    if designs.exists():
        table = pd.read_csv(designs)
        hit = (table["status"] == "ok") & (table["final_distance"] <= PUSH)
        assert table["success"].astype(bool).tolist() == hit.tolist()


@pytest.mark.slow
def test_the_protocol_reports_the_success_its_cells_give(
    protocol_smoke: Path, tmp_path: Path
) -> None:
    from benchmarks.protocol import make_protocol_report
    from benchmarks.protocol.report import load_runs

    make_protocol_report([protocol_smoke], tmp_path / "report")
    runs = pd.read_csv(tmp_path / "report" / "runs.csv")
    _, rows = load_runs(protocol_smoke)
    # Each run's lowest F (a failed evaluation has none), the first of equal ones.
    rows = rows[rows["free_energy"].notna()].sort_values("evaluation", kind="stable")
    best = rows.loc[
        rows.groupby(["optimizer", "instance", "degree", "seed"])["free_energy"].idxmin()
    ]
    best = best.assign(hit=(best["status"] == "ok") & (best["final_distance"] <= PUSH))
    expected = best.set_index(["optimizer", "instance", "degree", "seed"])["hit"]
    got = runs.set_index(["optimizer", "instance", "degree", "seed"])["success_1"].astype(bool)
    assert got.sort_index().to_dict() == expected.sort_index().to_dict()
    text = (tmp_path / "report" / "report.md").read_text()
    assert "| final regret (median) | success | runs |" in text
    for (optimizer, degree), hits in expected.groupby(level=["optimizer", "degree"]):
        k, n = int(hits.sum()), len(hits)
        low, high = wilson_interval(k, n)
        cell = f"{100 * k / n:.0f} % ({k}/{n}) [{100 * low:.0f} %, {100 * high:.0f} %]"
        assert any(
            line.startswith(f"| {degree} | {optimizer} |") and cell in line
            for line in text.splitlines()
        ), (optimizer, degree, cell)


# --- the rl suite's report -------------------------------------------------------------------


def test_the_rl_fixed_goal_table_gives_success_at_each_budget() -> None:
    from benchmarks.reports.rl import fixed_goal_table

    # 16 episodes per seed; seed 0's best design is close from episode 3 on, seed 1's best is
    # far until its last episode, seed 2 never stores a distance, seed 3 is invalid then far.
    def run(seed: int, f: list[float], d: list[float], status: list[str]) -> list[dict[str, Any]]:
        return [
            {
                "variant": "fixed",
                "optimizer": "cmaes",
                "seed": seed,
                "candidate": k,
                "free_energy": f[k],
                "final_distance": d[k],
                "status": status[k],
            }
            for k in range(16)
        ]

    ok = ["ok"] * 16
    rows = run(0, [9.0, 9.0, 5.0] + [6.0] * 13, [0.5, 0.5, 0.05] + [0.01] * 13, ok)
    rows += run(1, [9.0] * 15 + [1.0], [0.5] * 15 + [0.02], ok)
    rows += run(2, [9.0] * 16, [np.nan] * 16, ok)
    rows += run(3, [1.0] + [9.0] * 15, [0.0] + [0.4] * 15, ["invalid"] + ["ok"] * 15)
    table = fixed_goal_table(pd.DataFrame(rows), 0.015).set_index("episodes")
    row = table.loc[16]
    # Seed 3's lowest F is its invalid design (the log keeps the env's penalty-free F here):
    # an unusable design never succeeds.
    assert (row["successes"], row["success_seeds"]) == (2, 3)
    assert (row["success_low"], row["success_high"]) == pytest.approx(wilson_interval(2, 3))


@pytest.mark.slow
def test_the_committed_rl_report_gives_the_success_its_rows_give() -> None:
    folder = RESULTS / "square" / "rl"
    rows = ResultStore(folder).read()
    fixed = rows[rows["variant"] == "fixed"]
    table = pd.read_csv(folder / "report" / "fixed-goal.csv")
    for method, group in fixed.groupby("optimizer"):
        last = table[table["method"] == method].sort_values("episodes").iloc[-1]
        hits = 0
        for _, seed_rows in group.groupby("seed"):
            seed_rows = seed_rows.iloc[: int(last["episodes"])]
            best = seed_rows.loc[seed_rows["free_energy"].idxmin()]
            hits += int(best["status"] == "ok" and best["final_distance"] <= PUSH)
        assert (int(last["successes"]), int(last["success_seeds"])) == (hits, last["seeds"])
    held_out = pd.read_csv(folder / "report" / "held-out-per-goal.csv")
    hit = (held_out["final_distance"] <= PUSH).tolist()
    assert held_out["success"].astype(bool).tolist() == hit
    summary = pd.read_csv(folder / "report" / "held-out.csv").set_index("approach")
    counts = held_out.groupby("approach")["success"].sum()
    assert summary["successes"].to_dict() == counts.astype(int).to_dict()
