"""The box-moving noise floor of each task (perf/studies/task_floor.py, docs/tasks.md).

The study's pure helpers (span, summary, command line) are checked on hand values; its
rollout path on a tiny case (slow); and the figures docs/tasks.md quotes from
docs/results/tasks/floor-moving.json are rebuilt from that file and looked for on the page.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "tasks.md"
RESULTS = ROOT / "docs" / "results" / "tasks"
TASKS = ("push", "hook", "obstacle", "puck")


def _results() -> dict[str, dict[str, Any]]:
    rows = json.loads((RESULTS / "floor-moving.json").read_text(encoding="utf-8"))
    return {row["task"]: row for row in rows}


def _baselines() -> dict[str, dict[str, Any]]:
    rows = json.loads((RESULTS / "baselines.json").read_text(encoding="utf-8"))
    return {row["task"]: row for row in rows}


def _page() -> str:
    return re.sub(r"\s+", " ", PAGE.read_text(encoding="utf-8"))


def _baseline_row(median: float, best: float, regret: float) -> dict[str, Any]:
    return {
        "task": "hook",
        "random": {"free_energy_quantiles": [-200.0, 100.0, median, 1800.0, 1900.0]},
        "cmaes": {"best": {"free_energy": best}, "regret": regret},
    }


def test_the_span_is_the_random_quantile_minus_the_best_known():
    from perf.studies.task_floor import span

    row = _baseline_row(1700.0, -150.0, 30.0)  # best known: -150 - 30 = -180
    assert span(row) == {"typical": 1700.0, "best_known": -180.0, "span": 1880.0}
    assert span(row, 0.25)["span"] == 280.0
    assert span(row, 0.75)["typical"] == 1800.0


@pytest.mark.parametrize("quantile", [0.0, 1.0, 0.3, math.nan])
def test_the_span_refuses_a_quantile_baselines_json_does_not_store(quantile):
    from perf.studies.task_floor import span

    with pytest.raises(ValueError, match="span quantile must be 0.25, 0.5 or 0.75"):
        span(_baseline_row(1700.0, -150.0, 0.0), quantile)


def test_the_span_refuses_a_best_above_the_typical_design():
    from perf.studies.task_floor import span

    with pytest.raises(ValueError, match="is not positive"):
        span(_baseline_row(100.0, 150.0, 0.0))


def test_the_summary_gives_the_floor_relative_to_f_and_to_the_span():
    from perf.studies.task_floor import summary

    rows = [
        {"free_energy": [100.0, 102.0, 101.0], "range": 2.0},  # 2 % of |F| ~ 101
        {"free_energy": [-1.0, 1.0, 3.0], "range": 4.0},  # F crosses 0: 400 % of |mean 1|
        {"free_energy": [1000.0, 1001.0, 1000.5], "range": 1.0},  # 0.1 %
    ]
    got = summary(rows, 200.0)
    assert got["designs"] == 3
    assert got["median_range"] == 2.0 and got["max_range"] == 4.0
    assert got["median_relative_range"] == pytest.approx(2.0 / 101.0)
    assert got["max_relative_range"] == pytest.approx(4.0)
    assert got["above_bound"] == 2
    assert got["median_span_relative"] == 0.01 and got["max_span_relative"] == 0.02


@pytest.mark.parametrize(("rows", "span_value", "message"), [
    ([], 1.0, "no design to summarize"),
    ([{"free_energy": [1.0, 2.0], "range": 1.0}], 0.0, "span must be a finite number > 0"),
    ([{"free_energy": [1.0, 2.0], "range": 1.0}], math.inf, "span must be a finite number > 0"),
])
def test_the_summary_refuses_nothing_to_summarize_and_a_bad_span(rows, span_value, message):
    from perf.studies.task_floor import summary

    with pytest.raises(ValueError, match=message):
        summary(rows, span_value)


@pytest.mark.parametrize(("argv", "message"), [
    (["--moved", "0"], "--moved must be a distance > 0"),
    (["--moved", "nan"], "--moved must be a distance > 0"),
    (["--nudges", "1"], "--nudges must be from 2 to 100"),
    (["--span-quantile", "0.3"], "--span-quantile must be 0.25, 0.5 or 0.75"),
    (["--workers", "0"], "--workers must be at least 1"),
    (["--task", "hooks"], "invalid choice"),
])
def test_the_command_line_refuses_bad_options(argv, message, capsys):
    from perf.studies.task_floor import parse_args

    with pytest.raises(SystemExit):
        parse_args(argv)
    assert message in capsys.readouterr().err


@pytest.mark.slow  # imports task_baselines (the optimizers): over a second on a loaded machine
def test_the_candidates_hold_the_cmaes_design_and_every_succeeding_random_design():
    from perf.studies.task_floor import candidates, committed_inputs

    inputs = committed_inputs()
    for task in TASKS:
        pool = candidates(inputs[task])
        designs = [tuple(c["design"]) for c in pool]
        assert len(designs) == len(set(designs)), task  # merged, not repeated
        assert tuple(inputs[task]["baselines"]["cmaes"]["best"]["design"]) in designs, task
        old = [c for c in pool if c["old_set"]]
        assert [c["design"] for c in old] == [
            r["design"] for r in inputs[task]["floor"]["noise_floor"]["per_design"]
        ], task
        random = inputs[task]["baselines"]["random"]
        succeeding = [c for c in pool if any("(succeeds)" in s for s in c["sources"])]
        assert len(succeeding) == round(random["success_rate"] * random["n"]), task


@pytest.mark.slow  # 8 rollouts
def test_a_tiny_case_measures_the_moving_design_as_the_committed_floor_did():
    """Hook's first 4 candidates: 3 untouched boxes and one bow, in the default 5 scenes.

    The bow's F per scene must be noise-floor.json's: the same scenes through evaluate_batch
    as through the env. The bits depend on the CPU (tests/platforms.py): on another one only
    the box-moving split and the figures' shape are checked.
    """
    from platforms import platform_id

    from benchmarks.execution import make_executor
    from perf.studies.task_floor import committed_inputs, measure, report

    inputs = committed_inputs()
    with make_executor("serial") as executor:
        result = measure("hook", inputs["hook"], executor, limit=4)
    moved = [c["moves_box"] for c in result["candidates"]]
    assert moved == [False, False, False, True]
    assert result["moving"]["designs"] == 1 and result["rollouts"] == 4 + 4
    (bow,) = [c for c in result["candidates"] if c["moves_box"]]
    assert len(bow["free_energy"]) == 5 and bow["range"] > 0
    assert result["largest_displacement_unmoved"] < 1e-3 < 0.1 < bow["displacement"]
    committed = json.loads((RESULTS / "floor-moving.json").read_text(encoding="utf-8"))
    lines = report(result)
    assert lines[0] == "## hook" and lines[-1] == "8 rollouts"
    assert result["platform"] == platform_id()
    if platform_id() in {row["platform"] for row in committed}:
        assert result["old_set"]["remeasured_identical"] is True


def test_the_committed_run_rechecked_the_old_set_and_split_the_boxes_clearly():
    results = _results()
    assert sorted(results) == sorted(TASKS)
    for task, row in results.items():
        assert row["old_set"]["remeasured_identical"] is True, task
        low, high = row["largest_displacement_unmoved"], row["smallest_displacement_moved"]
        assert high > row["moved_threshold"], task
        assert low is None or low < row["moved_threshold"] / 10, task  # settling, not contact
        cmaes = [c for c in row["candidates"] if "CMA-ES's design" in c["sources"]]
        assert len(cmaes) == 1 and cmaes[0]["moves_box"] and "range" in cmaes[0], task
        assert row["span"]["span"] == pytest.approx(
            row["span"]["typical"] - row["span"]["best_known"]
        )


def _pct(value: float) -> str:
    return f"{100 * value:.2f} %"


def _table() -> list[str]:
    """The page's box-moving floor table, rebuilt from floor-moving.json."""
    results = _results()
    rows = [results[t] for t in TASKS]

    def line(label: str, cells: list[str]) -> str:
        return f"| {label} | " + " | ".join(cells) + " |"

    old = [r["old_set"] for r in rows]
    mov = [r["moving"] for r in rows]
    candidates = [len(r["candidates"]) for r in rows]
    return [
        "| | " + " | ".join(TASKS) + " |",
        "|---|" + "---|" * len(TASKS),
        line("old set: designs, of which move the box",
             [f"{o['designs']}, {o['moved_box']}" for o in old]),
        line("old set: median of \\|F\\| (largest)",
             [f"{_pct(o['median_relative_range'])} ({_pct(o['max_relative_range'])})"
              for o in old]),
        line("old set: median of the span", [_pct(o["median_span_relative"]) for o in old]),
        line("candidates, of which move the box, of which succeed",
             [f"{n}, {m['designs']}, {m['succeeding']}" for n, m in zip(candidates, mov,
                                                                         strict=True)]),
        line("box-moving: median range in F units (largest)",
             [f"{m['median_range']:.1f} ({m['max_range']:.1f})" for m in mov]),
        line("box-moving: median of \\|F\\| (largest)",
             [f"{_pct(m['median_relative_range'])} ({_pct(m['max_relative_range'])})"
              for m in mov]),
        line("box-moving: designs above 1 % of \\|F\\|",
             [f"{m['above_bound']} of {m['designs']}" for m in mov]),
        line("F span: median random F - best F known",
             [f"{r['span']['typical']:.0f} - {_signed(r['span']['best_known'])} = "
              f"{r['span']['span']:.0f}" for r in rows]),
        line("box-moving: median of the span (largest)",
             [f"{_pct(m['median_span_relative'])} ({_pct(m['max_span_relative'])})"
              for m in mov]),
        line("CMA-ES's design: its range, of \\|F\\|",
             [_cmaes_cell(r) for r in rows]),
        line("gap (median random F - CMA-ES's F) over the box-moving median range",
             [f"{r['gap']['gap']:.0f} / {r['moving']['median_range']:.1f} = "
              f"{r['gap']['over_moving_median_range']:.0f}" for r in rows]),
        line("median \\|F\\| <= 1 % on box-moving designs",
             ["yes" if m["median_relative_range"] <= 0.01 else "**no**" for m in mov]),
    ]


def _signed(value: float) -> str:
    """A whole number, in parentheses if negative (it follows a minus sign)."""
    return f"({value:.0f})" if value < 0 else f"{value:.0f}"


def _cmaes_cell(row: dict[str, Any]) -> str:
    (c,) = [c for c in row["candidates"] if "CMA-ES's design" in c["sources"]]
    return f"{c['range']:.1f}, {_pct(c['relative_range'])}"


def test_the_page_table_is_floor_moving_json():
    page = PAGE.read_text(encoding="utf-8").splitlines()
    table = _table()
    start = page.index(table[0], page.index("### The noise floor on designs that move the box"))
    assert page[start : start + len(table)] == table


def _claims() -> list[str]:
    """The prose's figures about the box-moving floor, formatted from the files."""
    results, baselines = _results(), _baselines()
    rows = [results[t] for t in TASKS]
    hook = results["hook"]
    hook_moving = [c for c in hook["candidates"] if "range" in c]
    claims = [
        f"more than {hook['moved_threshold'] * 100:g} cm",
        f"an untouched box moves at most {max(_unmoved(r) for r in rows):.1g} m",
        f"the least a touching design moved it is "
        f"{min(r['smallest_displacement_moved'] for r in rows):.3f} m",
        f"{sum(r['rollouts'] for r in rows)} rollouts",
        f"{min(len(r['candidates']) for r in rows)} to {max(len(r['candidates']) for r in rows)} "
        "candidates a task",
        "the box-moving candidates ("
        + ", ".join(str(r["moving"]["designs"]) for r in rows[:-1])
        + f" and {rows[-1]['moving']['designs']};",
    ]
    failing = [r for r in rows if r["moving"]["median_relative_range"] > 0.01]
    passing = [r for r in rows if r["moving"]["median_relative_range"] <= 0.01]
    assert [r["task"] for r in failing] == ["hook"]  # the page's heading names hook alone
    claims.append(
        "median of |F| above 1 %: "
        + ", ".join(f"{r['task']} {_pct(r['moving']['median_relative_range'])}" for r in failing)
    )
    claims.append(
        "pass on box-moving designs ("
        + ", ".join(f"{r['task']} {_pct(r['moving']['median_relative_range'])}" for r in passing)
        + ")"
    )
    claims.append(
        f"{hook['moving']['above_bound']} of its {hook['moving']['designs']} box-moving designs"
    )
    top = max(hook_moving, key=lambda c: c["relative_range"])
    claims.append(
        f"the largest, {_pct(top['relative_range'])}, is the {top['sources'][0]}, whose F is "
        f"{top['free_energy'][0]:.1f} and R {top['range']:.1f}"
    )
    old = baselines["hook"]["noise_floor"]["median_range"]
    claims.append(
        f"Its median range is {hook['moving']['median_range']:.1f} F units, about "
        f"{hook['moving']['median_range'] / old:.0f} times the old set's {old:.1f}"
    )
    (curl,) = [c for c in hook["candidates"] if c["design"] == [1.5, 1.5, 0.5]]
    reference = _smoke_reference()
    assert reference["design"] == curl["design"]
    claims.append(f"has a floor of {reference['noise_floor']:.1f} at F {reference['f_ref']:.0f}")
    claims.append(
        f"the curl the review cited has R {curl['range']:.1f} here over {hook['nudges']} scenes "
        f"({reference['noise_floor']:.1f} over the reference's {reference['noise_nudges']}"
    )
    widest = max(hook_moving, key=lambda c: c["span_relative"])
    assert "lowest-F random design" in widest["sources"]
    claims.append(
        f"{_pct(hook['moving']['median_span_relative'])} (median), "
        f"{_pct(hook['moving']['max_span_relative'])} at most (the lowest-F random design)"
    )
    worst = max(rows, key=lambda r: r["moving"]["median_span_relative"])
    claims.append(
        f"at most {_pct(worst['moving']['median_span_relative'])} of the span (median, "
        f"{worst['task']})"
    )
    nearest = sorted(rows, key=lambda r: -r["moving"]["median_span_relative"])[:2]
    assert [r["task"] for r in nearest] == ["push", "puck"]
    claims.append(
        f"push and puck ({_pct(nearest[0]['moving']['median_span_relative'])} and "
        f"{_pct(nearest[1]['moving']['median_span_relative'])}) have the floors nearest their "
        f"spans"
    )
    energies = [c["free_energy"][0] for r in nearest for c in r["candidates"] if "range" in c]
    claims.append(f"their F is large ({min(energies):,.0f} to {max(energies):,.0f} on their")
    claims.append(
        f"their span small ({nearest[0]['span']['span']:,.0f} and "
        f"{nearest[1]['span']['span']:,.0f})"
    )
    ratios = [r["gap"]["over_moving_median_range"] for r in rows]
    claims.append(f"{min(ratios):.0f} to {max(ratios):.0f} times the box-moving median range")
    claims.append(
        "(" + ", ".join(f"{t} {q:.0f}" for t, q in zip(TASKS, ratios, strict=True)) + ")"
    )
    own = [r["gap"]["over_cmaes_range"] for r in rows]
    claims.append(f"{min(own):.0f} to {max(own):.0f} times the CMA-ES design's own range")
    claims.append(
        f"hook {hook['gap']['over_moving_median_range']:.0f} with it, "
        f"{hook['gap']['gap'] / old:.0f} with the old set's"
    )
    plans = {p["task"]: p for p in json.loads((RESULTS / "plans.json").read_text("utf-8"))}
    own_plan = plans["hook"]["rows"]["pi_0"]
    claims.append(
        f"hook's pi_0 would read "
        f"{(own_plan['f_median'] - own_plan['f_min']) / hook['moving']['median_range']:.0f} "
        f"with the box-moving median range instead of {own_plan['gap_over_noise']:.0f}"
    )
    return claims


def _smoke_reference() -> dict[str, Any]:
    """Hook i01's d = 3 cell of the protocol's smoke references (the review's figure)."""
    path = ROOT / "benchmarks" / "protocol" / "data" / "references-smoke.json"
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    (cell,) = [
        c for c in cells if c.get("task") == "hook" and c["instance"] == "i01" and c["degree"] == 3
    ]
    return cell


def _unmoved(row: dict[str, Any]) -> float:
    value = row["largest_displacement_unmoved"]
    return 0.0 if value is None else float(value)


def test_the_committed_output_is_the_report_of_the_committed_json():
    """floor-moving-output.txt is what the study printed for floor-moving.json's results."""
    from perf.studies.task_floor import report

    rows = json.loads((RESULTS / "floor-moving.json").read_text(encoding="utf-8"))
    text = (RESULTS / "floor-moving-output.txt").read_text(encoding="utf-8")
    assert text.splitlines() == [line for row in rows for line in report(row)]


@pytest.mark.parametrize("index", range(23))
def test_each_floor_figure_of_the_prose_is_the_files(index):
    claims = _claims()
    assert len(claims) == 23
    assert claims[index] in _page(), f"docs/tasks.md does not say {claims[index]!r}"


@pytest.mark.parametrize("moved", [0.0, -0.01, math.nan, math.inf])
def test_measure_refuses_a_bad_threshold_before_simulating(moved):
    from perf.studies.task_floor import committed_inputs, measure

    with pytest.raises(ValueError, match="moved must be a distance > 0 in m"):
        measure("hook", committed_inputs()["hook"], executor=None, moved=moved)
