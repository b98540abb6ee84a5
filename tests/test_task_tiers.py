"""The tier rule of perf.studies.task_tiers: the random share, CMA-ES's regret, the harder wins.

The rule on hand-made numbers (each boundary, the harder of two, a cell the protocol did not
run), CMA-ES's baseline read from a real protocol run folder (the committed quick run, push
only) and from a made-up one with the task axis, ``--from`` without simulating, and bad input.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from benchmarks.reports.success import wilson_interval
from perf.studies import task_tiers
from perf.studies.task_tiers import (
    TierRule,
    bootstrap_median,
    harder,
    label_cells,
    markdown_table,
    protocol_baselines,
    read_random_cells,
)

ROOT = Path(__file__).resolve().parents[1]
QUICK = ROOT / "docs" / "results" / "protocol-quick"
TIERS_JSON = ROOT / "docs" / "results" / "tasks" / "tiers.json"
PAGE = ROOT / "docs" / "tasks.md"


# --- the rule on hand-made numbers ---


@pytest.mark.parametrize(
    ("share", "expected"),
    [
        (1.0, "easy"),
        (0.10, "easy"),
        (0.0999, "medium"),
        (0.01, "medium"),
        (0.0099, "hard"),
        (0.0, "hard"),
    ],
)
def test_the_random_tier_at_each_boundary(share, expected):
    assert TierRule().share_tier(share) == expected


@pytest.mark.parametrize(
    ("regret", "expected"),
    [
        (-0.2, "easy"),
        (0.0, "easy"),
        (0.2499, "easy"),
        (0.25, "medium"),
        (0.7499, "medium"),
        (0.75, "hard"),
        (1.0, "hard"),
        (3.0, "hard"),
        (None, None),
        (math.nan, None),
    ],
)
def test_the_regret_tier_at_each_boundary(regret, expected):
    assert TierRule().regret_tier(regret) == expected


@pytest.mark.parametrize(
    ("share", "regret", "expected"),
    [
        (0.5, 0.1, "easy"),  # both easy
        (0.5, 0.5, "medium"),  # regret harder
        (0.5, 0.9, "hard"),
        (0.05, 0.1, "medium"),  # share harder
        (0.0, 0.1, "hard"),
        (0.0, 0.9, "hard"),
        (0.05, None, "medium"),  # no protocol data: the random label
        (0.0, math.nan, "hard"),
    ],
)
def test_the_label_is_the_harder_of_the_two(share, regret, expected):
    assert TierRule().label(share, regret) == expected


def test_harder_orders_easy_medium_hard_and_skips_none():
    assert harder("easy", "hard") == harder("hard", "easy") == "hard"
    assert harder("medium", "easy") == harder("easy", "medium") == "medium"
    assert harder(None, "easy") == "easy"
    with pytest.raises(ValueError, match="at least one tier"):
        harder(None)
    with pytest.raises(ValueError, match="'trivial'"):
        harder("easy", "trivial")


def test_thresholds_are_parameters():
    rule = TierRule(easy_share=0.5, hard_share=0.2, easy_regret=0.5, hard_regret=1.0)
    assert [rule.share_tier(p) for p in (0.5, 0.3, 0.1)] == ["easy", "medium", "hard"]
    assert [rule.regret_tier(r) for r in (0.4, 0.9, 1.0)] == ["easy", "medium", "hard"]
    assert TierRule().easy_share == 0.10 and TierRule().hard_share == 0.01  # the baselines'
    assert (TierRule().easy_regret, TierRule().hard_regret) == (0.25, 0.75)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"easy_regret": -0.1}, "easy_regret must be a finite number > 0, got -0.1"),
        ({"hard_share": 0.0}, "hard_share must be a finite number > 0, got 0.0"),
        ({"hard_regret": math.inf}, "hard_regret must be a finite number > 0"),
        ({"easy_regret": math.nan}, "easy_regret must be a finite number > 0"),
        ({"easy_share": True}, "easy_share must be a number, got True"),
        ({"easy_share": 0.005}, "0 < hard_share < easy_share <= 1"),
        ({"easy_share": 0.01}, "0 < hard_share < easy_share <= 1"),  # equal: no medium band
        ({"easy_share": 1.5}, "0 < hard_share < easy_share <= 1"),
        ({"easy_regret": 0.8}, "0 < easy_regret < hard_regret, got easy_regret 0.8"),
        ({"easy_regret": 0.75}, "0 < easy_regret < hard_regret"),
    ],
)
def test_bad_thresholds_are_refused_in_one_line(kwargs, message):
    with pytest.raises(ValueError) as err:
        TierRule(**kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_bad_thresholds_on_the_command_line(capsys):
    for argv, named in (
        (["--easy-regret", "0.9", "--hard-regret", "0.5"], "--easy-regret 0.9"),
        (["--hard-share", "-0.01"], "--hard-share must be a finite number > 0"),
    ):
        with pytest.raises(SystemExit):
            task_tiers.parse_args(argv)
        assert named in capsys.readouterr().err


def test_a_share_outside_zero_one_is_refused():
    with pytest.raises(ValueError, match=r"in \[0, 1\], got 1.2"):
        TierRule().share_tier(1.2)


def _random_cell(task: str, degree: int, successes: int, n: int = 64) -> dict[str, Any]:
    return {
        "task": task,
        "degree": degree,
        "n": n,
        "usable": n,
        "successes": successes,
        "success_rate": successes / n,
        "success_95": list(wilson_interval(successes, n)),
        "free_energy_median": 1000.0,
        "tier": "stale",
    }


def _baseline(regret: float | None) -> dict[str, Any]:
    return {
        "runs": 4,
        "instances": 2,
        "budget": 32,
        "regret_median": regret,
        "regret_95": None,
        "regret_undefined": 0,
        "successes": 1,
        "success_known": 4,
        "success_rate": 0.25,
        "success_95": list(wilson_interval(1, 4)),
    }


def test_a_cell_without_protocol_data_keeps_its_random_label():
    cells = [_random_cell("push", 3, 10), _random_cell("push", 5, 2), _random_cell("hook", 3, 0)]
    baselines = {"cells": {("push", 3): _baseline(0.8), ("hook", 3): _baseline(0.1)}}
    push3, push5, hook3 = label_cells(cells, baselines)
    assert (push3["random_tier"], push3["regret_tier"], push3["tier"]) == ("easy", "hard", "hard")
    assert (push5["random_tier"], push5["regret_tier"], push5["tier"]) == ("medium", None, "medium")
    assert push5["baseline"] is None
    assert (hook3["random_tier"], hook3["regret_tier"], hook3["tier"]) == ("hard", "easy", "hard")
    # The file's old "tier" is recomputed by the rule in use, never copied.
    assert label_cells([_random_cell("push", 3, 10)])[0]["tier"] == "easy"
    table = markdown_table([push3, push5, hook3])
    # 10/64's Wilson interval [8.7, 26.4] % reaches medium, but the regret (no interval) makes
    # the label hard either way; 2/64's [0.9, 10.7] % reaches both neighbours.
    assert "| push | **hard** (random easy?; CMA-ES regret 0.80: hard) |" in table
    assert "**medium?** (random medium?; not run by the protocol)" in table


# --- labels whose intervals reach another tier ---


@pytest.mark.parametrize(
    ("share", "interval", "expected"),
    [
        (0.5, [0.4, 0.6], ("easy", "easy")),  # inside a band
        (0.05, [0.02, 0.09], ("medium", "medium")),
        (0.0, [0.0, 0.009], ("hard", "hard")),
        (0.05, [0.005, 0.09], ("medium", "hard")),  # straddles the lower boundary (1 %)
        (0.05, [0.02, 0.12], ("easy", "medium")),  # straddles the upper boundary (10 %)
        (0.05, [0.005, 0.12], ("easy", "hard")),  # both
        (0.05, [0.02, 0.10], ("easy", "medium")),  # an end on a threshold reaches its tier
        (0.05, [0.01, 0.09], ("medium", "medium")),  # 1 % itself is medium
        (0.05, None, ("medium", "medium")),  # no interval: the share's tier
        (0.0, list(wilson_interval(0, 64)), ("medium", "hard")),  # 0 of 64: [0, 5.7] %
    ],
)
def test_the_random_tiers_within_the_wilson_interval(share, interval, expected):
    assert TierRule().share_tiers(share, interval) == expected


@pytest.mark.parametrize(
    ("regret", "interval", "expected"),
    [
        (0.5, [0.3, 0.7], ("medium", "medium")),  # inside a band
        (0.1, [0.0, 0.2], ("easy", "easy")),
        (0.5, [0.2, 0.7], ("easy", "medium")),  # straddles the lower boundary (0.25)
        (0.5, [0.3, 0.8], ("medium", "hard")),  # straddles the upper boundary (0.75)
        (0.5, [0.3, 0.75], ("medium", "hard")),  # 0.75 itself is hard
        (0.5, [0.25, 0.7], ("medium", "medium")),  # 0.25 itself is medium
        (0.5, None, ("medium", "medium")),  # no interval (one instance): the median's tier
        (None, [0.1, 0.9], None),  # no regret, no tier
    ],
)
def test_the_regret_tiers_within_the_bootstrap_interval(regret, interval, expected):
    assert TierRule().regret_tiers(regret, interval) == expected


def _interval_cell(share_95: list[float], successes: int = 3) -> dict[str, Any]:
    """A hand-made random cell (3/64 = 4.7 %, medium) whose interval is given."""
    return {**_random_cell("push", 3, successes), "success_95": share_95}


def _regret(median: float, interval: list[float] | None) -> dict[str, Any]:
    return {**_baseline(median), "regret_95": interval}


@pytest.mark.parametrize(
    ("share_95", "baseline", "flags", "span"),
    [
        # both inside their bands: sure
        ([0.02, 0.08], _regret(0.5, [0.3, 0.7]), (False, False, False), ("medium", "medium")),
        # the share straddles its lower boundary: the label may be hard
        ([0.005, 0.08], _regret(0.5, [0.3, 0.7]), (True, False, True), ("medium", "hard")),
        # the regret straddles its upper boundary: likewise
        ([0.02, 0.08], _regret(0.5, [0.3, 0.8]), (False, True, True), ("medium", "hard")),
        # the share straddles its upper boundary: the label may be easy only if the regret can
        ([0.02, 0.12], _regret(0.5, [0.3, 0.7]), (True, False, False), ("medium", "medium")),
        ([0.02, 0.12], _regret(0.5, [0.2, 0.7]), (True, True, True), ("easy", "medium")),
        # a sure hard regret decides whatever the share does
        ([0.005, 0.12], _regret(0.9, [0.8, 1.0]), (True, False, False), ("hard", "hard")),
        # the regret without an interval: not known, its median's tier alone
        ([0.02, 0.08], _regret(0.5, None), (False, None, False), ("medium", "medium")),
        ([0.005, 0.08], _regret(0.5, None), (True, None, True), ("medium", "hard")),
        # not run by the protocol: the share's alone
        ([0.02, 0.08], None, (False, None, False), ("medium", "medium")),
        ([0.02, 0.12], None, (True, None, True), ("easy", "medium")),
    ],
)
def test_a_label_whose_intervals_reach_another_tier_is_flagged(share_95, baseline, flags, span):
    baselines = {"cells": {} if baseline is None else {("push", 3): baseline}}
    (cell,) = label_cells([_interval_cell(share_95)], baselines)
    assert (cell["random_uncertain"], cell["regret_uncertain"], cell["uncertain"]) == flags
    assert tuple(cell["tier_range"]) == span
    assert cell["uncertain"] is (span[0] != span[1])
    assert (
        TierRule().label_tiers(
            3 / 64,
            share_95,
            None if baseline is None else baseline["regret_median"],
            None if baseline is None else baseline["regret_95"],
        )
        == span
    )
    # The label itself is the medians': medium, or hard with a hard regret.
    assert cell["tier"] == ("hard" if baseline and baseline["regret_median"] >= 0.75 else "medium")
    # Printed and tabled with a "?" on each tier its interval leaves open.
    line = task_tiers._line(cell)
    assert line.endswith(": medium?" if flags[0] else ": medium")
    table = markdown_table([cell])
    label = f"**{cell['tier']}{'?' if flags[2] else ''}**"
    assert f"| push | {label} (random medium{'?' if flags[0] else ''};" in table
    if baseline is not None:
        below = task_tiers._baseline_line(cell, "cmaes")
        regret_tier = cell["regret_tier"] + ("?" if flags[1] else "")
        assert f": regret {regret_tier} -> tier {cell['tier']}" in below
        assert f"{regret_tier}) |" in table
        if flags[2]:
            assert below.endswith(f"? ({span[0]} to {span[1]} within the intervals)")
        else:
            assert below.endswith(f"-> tier {cell['tier']}")


def test_bad_intervals_are_refused_in_one_line():
    rule = TierRule()
    for call, message in (
        (lambda: rule.share_tiers(0.05, [-0.1, 0.2]), r"in \[0, 1\], got -0.1"),
        (lambda: rule.share_tiers(1.5, None), r"in \[0, 1\], got 1.5"),
        (lambda: rule.label_tiers(0.05, [0.02, 1.2], 0.5, [0.3, 0.7]), r"got 1.2"),
    ):
        with pytest.raises(ValueError, match=message) as err:
            call()
        assert "\n" not in str(err.value)
    # A regret interval's NaN end is no tier (never a crash), as a NaN median is none.
    assert rule.regret_tiers(0.5, [math.nan, 0.8]) == ("medium", "hard")
    assert rule.regret_tiers(math.nan, [0.1, 0.8]) is None


def test_the_printed_labels_carry_the_marker_and_its_note(capsys):
    assert task_tiers.main(["--from", str(TIERS_JSON), "--task", "hook"]) == 0
    lines = capsys.readouterr().out.splitlines()
    # hook: 9/64 [7.6, 24.6] %, 8/64 [6.5, 22.8] % reach medium; 13/64 [12.3, 31.7] % does not.
    assert [line.rsplit(": ", 1)[1] for line in lines[1:4]] == ["easy?", "easy?", "easy"]
    assert lines[4] == task_tiers.UNCERTAIN_NOTE and len(lines) == 5
    assert task_tiers.main(["--from", str(TIERS_JSON), "--task", "hook", "--degrees", "8"]) == 0
    assert task_tiers.UNCERTAIN_NOTE not in capsys.readouterr().out  # nothing marked


# --- bootstrap ---


def test_the_bootstrap_interval_of_the_median_over_groups():
    groups = [[0.1, 0.2], [0.3, 0.4], [0.5, 0.9], [1.2, 0.05]]
    low, high = bootstrap_median(groups) or (math.nan, math.nan)
    pooled = np.concatenate(groups)
    assert pooled.min() <= low <= np.median(pooled) <= high <= pooled.max()
    assert bootstrap_median(groups) == (low, high)  # same seed, same interval
    # The seed is the generator's: with few resamples, intervals differ from seed to seed.
    assert len({bootstrap_median(groups, resamples=10, seed=s) for s in range(10)}) > 1
    # Groups of unequal sizes pool as they are (NaN padding is never a value).
    assert bootstrap_median([[1.0], [2.0, 2.0, 2.0]], resamples=200) == (1.0, 2.0)
    assert bootstrap_median([[0.3, 0.4]]) is None  # one instance: no interval over instances
    for bad, message in (
        ({"groups": [[], [1.0]]}, "at least one value"),
        ({"groups": [[math.nan], [1.0]]}, "all finite"),
        ({"groups": groups, "resamples": 0}, "resamples must be a whole number >= 1, got 0"),
        ({"groups": groups, "level": 1.0}, r"level must be in \(0, 1\), got 1.0"),
    ):
        with pytest.raises(ValueError, match=message):
            bootstrap_median(**bad)


# --- reading a real protocol run folder: the committed quick run (push at d = 3, 5, 8; hook,
# obstacle and puck at d = 3) ---


def _runs_csv(folder: Path) -> list[dict[str, str]]:
    with (folder / "report" / "runs.csv").open(encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def test_the_quick_runs_baseline_is_its_runs_table():
    baselines = protocol_baselines(QUICK)
    assert (baselines["size"], baselines["optimizer"]) == ("quick", "cmaes")
    assert baselines["budgets"] == {3: 32, 5: 56, 8: 80}
    assert set(baselines["cells"]) == {("push", 3), ("push", 5), ("push", 8)} | {
        (task, 3) for task in ("hook", "obstacle", "puck")
    }
    rows = _runs_csv(QUICK)
    for (task, degree), cell in baselines["cells"].items():
        mine = [
            r
            for r in rows
            if r["optimizer"] == "cmaes" and r["task"] == task and int(r["degree"]) == degree
        ]
        regrets = sorted(float(r["regret_1"]) for r in mine)
        assert len(regrets) == 12 == cell["runs"]  # 6 instances x 2 seeds
        middle = (regrets[5] + regrets[6]) / 2  # the median of 12, by hand
        assert cell["regret_median"] == pytest.approx(middle, rel=1e-12)
        assert cell["instances"] == len({r["instance"] for r in mine}) == 6
        assert cell["budget"] == baselines["budgets"][degree]
        assert cell["regret_undefined"] == 0
        low, high = cell["regret_95"]
        assert regrets[0] <= low <= cell["regret_median"] <= high <= regrets[-1]
        successes = sum(r["success_1"] == "True" for r in mine)
        assert (cell["successes"], cell["success_known"]) == (successes, 12)
        assert cell["success_rate"] == successes / 12
        assert cell["success_95"] == list(wilson_interval(successes, 12))


def test_from_and_protocol_label_without_simulating(tmp_path, monkeypatch, capsys):
    def no_simulation(*args: Any) -> None:
        raise AssertionError("--from must not simulate")

    monkeypatch.setattr(task_tiers, "measure_cell", no_simulation)
    out = tmp_path / "tiers.json"
    argv = ["--from", str(TIERS_JSON), "--protocol", str(QUICK), "--json", str(out)]
    assert task_tiers.main(argv) == 0
    printed = capsys.readouterr().out
    record = json.loads(out.read_text(encoding="utf-8"))
    committed = json.loads(TIERS_JSON.read_text(encoding="utf-8"))
    assert (record["random"], record["seed"]) == (committed["random"], committed["seed"])
    assert record["random_from"] == str(TIERS_JSON)
    assert record["rule"] == {
        "easy_share": 0.1,
        "hard_share": 0.01,
        "easy_regret": 0.25,
        "hard_regret": 0.75,
    }
    assert record["protocol"]["size"] == "quick" and record["protocol"]["budgets"]["3"] == 32
    baselines = protocol_baselines(QUICK)["cells"]
    assert len(record["cells"]) == len(committed["cells"])
    for cell, old in zip(record["cells"], committed["cells"], strict=True):
        key = (cell["task"], cell["degree"])
        for field in ("n", "successes", "success_rate", "success_95", "free_energy_median"):
            assert cell[field] == old[field], (key, field)
        # The committed cells' random share's tier (labelled ones keep it as random_tier).
        assert cell["random_tier"] == old.get("random_tier", old["tier"])
        if key in baselines:
            assert cell["baseline"] == baselines[key]
            assert cell["tier"] == harder(cell["random_tier"], cell["regret_tier"])
        else:  # hook, obstacle, puck at d = 5 and 8: not in the quick run
            assert cell["baseline"] is None and cell["regret_tier"] is None
            assert cell["tier"] == cell["random_tier"]
    assert "Not run by the protocol, labelled by the random share alone: hook d = 5" in printed
    # The regret tiers of the quick run: 0.32, 0.24, 0.29 at d = 3, 5, 8.
    push = {c["degree"]: c for c in record["cells"] if c["task"] == "push"}
    assert [push[d]["regret_tier"] for d in (3, 5, 8)] == ["medium", "easy", "medium"]
    assert [push[d]["tier"] for d in (3, 5, 8)] == ["medium", "hard", "hard"]
    # Every one of them is left open by its intervals (written to the JSON, as docs/tasks.md
    # says): at d = 3 the share [0.9, 10.7] % and the regret [0.10, 0.65] reach easy and
    # hard; at d = 5 and 8 no success of 64 ([0, 5.7] %) may be medium, and so may the regret.
    assert [push[d]["tier_range"] for d in (3, 5, 8)] == [
        ["easy", "hard"],
        ["medium", "hard"],
        ["medium", "hard"],
    ]
    assert all(push[d]["uncertain"] and push[d]["regret_uncertain"] for d in (3, 5, 8))
    sure = [(c["task"], c["degree"]) for c in record["cells"] if not c["uncertain"]]
    assert sure == [("hook", 8)]  # 13/64: [12.3, 31.7] %, easy throughout


def test_from_selects_cells_and_refuses_absent_ones(capsys):
    record = read_random_cells(TIERS_JSON)
    assert len(record["cells"]) == 12 and "tier" not in record["cells"][0]
    assert task_tiers.main(["--from", str(TIERS_JSON), "--task", "hook", "--degrees", "5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[1].startswith("hook      d = 5:  8/64 succeed")
    assert lines[2] == task_tiers.UNCERTAIN_NOTE  # 8/64 [6.5, 22.8] % reaches medium
    assert lines[0].endswith("easy p >= 10 %, medium 1 % <= p < 10 %, hard p < 1 %")


def test_the_default_command_line_is_unchanged():
    args = task_tiers.parse_args([])
    assert (args.random, args.seed, args.workers, args.degrees, args.task) == (64, 0, 2, None, None)
    assert (args.from_file, args.protocol, args.rule) == (None, None, TierRule())


# --- the task axis: a made-up report of push and the other tasks ---


def _task_axis_folder(tmp_path: Path) -> tuple[Path, list[dict[str, Any]]]:
    from benchmarks.protocol.suite import protocol_config, write_protocol_record

    config = protocol_config("quick", tasks=["all"])
    folder = tmp_path / "protocol-tasks"
    folder.mkdir()
    write_protocol_record(folder, config)
    rows = []
    for k, (instance, degree) in enumerate(config.cells()):
        for seed in range(config.n_seeds):
            for optimizer in ("cmaes", "random"):
                regret = 0.1 * (k % 7) + 0.05 * seed if optimizer == "cmaes" else 1.0
                rows.append(
                    {
                        "optimizer": optimizer,
                        "task": instance.task,
                        "instance": instance.label,
                        "set": instance.set,
                        "degree": degree,
                        "seed": 100 + seed,
                        "regret_1": ""
                        if (instance.task, instance.id, seed) == ("puck", "i01", 0)
                        else repr(regret),
                        "success_1": "" if instance.task == "obstacle" else str(seed == 1),
                    }
                )
    _write_runs(folder, rows)
    return folder, rows


def _write_runs(folder: Path, rows: list[dict[str, Any]]) -> None:
    (folder / "report").mkdir(exist_ok=True)
    with (folder / "report" / "runs.csv").open("w", encoding="utf-8", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def test_a_task_axis_report_gives_each_task_its_cells(tmp_path):
    folder, rows = _task_axis_folder(tmp_path)
    baselines = protocol_baselines(folder)
    tasks = ("push", "hook", "obstacle", "puck")
    expected = {("push", d) for d in (3, 5, 8)} | {(t, 3) for t in tasks[1:]}
    assert set(baselines["cells"]) == expected
    for (task, degree), cell in baselines["cells"].items():
        mine = [
            r for r in rows if (r["optimizer"], r["task"], r["degree"]) == ("cmaes", task, degree)
        ]
        regrets = [float(r["regret_1"]) for r in mine if r["regret_1"] != ""]
        assert cell["runs"] == len(mine) == 12 and cell["instances"] == 6
        assert cell["regret_median"] == pytest.approx(float(np.median(regrets)), rel=1e-12)
        assert cell["regret_undefined"] == len(mine) - len(regrets)
        if task == "obstacle":  # no success stored: n/a, never a failure
            assert (cell["success_known"], cell["success_rate"], cell["success_95"]) == (
                0,
                None,
                None,
            )
        else:
            assert (cell["successes"], cell["success_known"]) == (6, 12)
    assert baselines["cells"][("puck", 3)]["regret_undefined"] == 1
    cells = label_cells([_random_cell(t, d, 7) for t in tasks for d in (3, 5, 8)], baselines)
    assert [c["task"] for c in cells if c["baseline"] is None] == [
        "hook",
        "hook",
        "obstacle",
        "obstacle",
        "puck",
        "puck",
    ]


def test_a_stale_report_is_refused(tmp_path):
    folder, rows = _task_axis_folder(tmp_path)
    _write_runs(folder, [r for r in rows if r["task"] != "hook"])  # made before hook ran
    with pytest.raises(ValueError) as err:
        protocol_baselines(folder)
    text = str(err.value)
    assert "has 0 run(s) of cmaes on hook at d = 3" in text and "plans 12" in text
    assert f"tooldesign report {folder}" in text and "\n" not in text


# --- bad input ---


def test_a_folder_that_is_not_a_protocol_run_is_named(tmp_path):
    with pytest.raises(ValueError) as err:
        protocol_baselines(tmp_path)
    assert str(err.value) == f"{tmp_path} is not a protocol run folder: it has no protocol.json"


def test_a_protocol_folder_without_a_report_is_named(tmp_path, capsys):
    shutil.copy(QUICK / "protocol.json", tmp_path / "protocol.json")
    with pytest.raises(ValueError) as err:
        protocol_baselines(tmp_path)
    text = str(err.value)
    assert text.startswith(f"{tmp_path} has no report (report/runs.csv)") and "\n" not in text
    # On the command line: one line on stderr, exit 2, nothing written.
    out = tmp_path / "tiers.json"
    argv = ["--from", str(TIERS_JSON), "--protocol", str(tmp_path), "--json", str(out)]
    assert task_tiers.main(argv) == 2
    err_lines = capsys.readouterr().err.strip().splitlines()
    assert len(err_lines) == 1 and "has no report" in err_lines[0] and not out.exists()


def test_a_report_without_the_columns_or_cmaes_is_named(tmp_path):
    shutil.copy(QUICK / "protocol.json", tmp_path / "protocol.json")
    rows = _runs_csv(QUICK)
    _write_runs(tmp_path, [{k: v for k, v in r.items() if k != "regret_1"} for r in rows])
    with pytest.raises(
        ValueError, match=r"runs.csv is not a protocol report's runs table: no column regret_1$"
    ):
        protocol_baselines(tmp_path)
    _write_runs(tmp_path, [r for r in rows if r["optimizer"] != "cmaes"])
    with pytest.raises(ValueError, match=r"no run of optimizer 'cmaes' \(it has: bo, pso, "):
        protocol_baselines(tmp_path)
    (tmp_path / "report" / "runs.csv").write_bytes(b"")
    with pytest.raises(ValueError, match="is not a report table"):
        protocol_baselines(tmp_path)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "does not exist: give a tiers JSON"),
        ("{not json", "is not a tiers JSON"),
        ('{"cells": []}', "is not a tiers JSON: it has no list of cells"),
        ('{"cells": [{"task": "push"}]}', "cell 0 has no degree, n, usable"),
    ],
)
def test_a_bad_from_file_is_named(tmp_path, content, message):
    path = tmp_path / "tiers.json"
    if content is not None:
        path.write_text(content, encoding="utf-8")
    with pytest.raises(ValueError, match=message) as err:
        read_random_cells(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def _cell_with(**changes: Any) -> dict[str, Any]:
    cell = _random_cell("push", 3, 2)
    cell.update(changes)
    return cell


@pytest.mark.parametrize(
    ("cell", "message"),
    [
        ("push", "cell 0 is str, not an object of fields"),
        (_cell_with(task="pushh"), "cell 0 has task 'pushh'; the study's tasks are push, hook"),
        (_cell_with(task=3), "cell 0 has task 3;"),
        (_cell_with(degree=4), r"cell 0 \(push\) has degree 4; the protocol's degrees are 3, 5, 8"),
        (_cell_with(degree="3"), r"cell 0 \(push\) has degree '3';"),
        (_cell_with(degree=True), r"cell 0 \(push\) has degree True;"),
        (_cell_with(n=0), r"cell 0 \(push, d = 3\) has n 0; it must be a whole number >= 1"),
        (_cell_with(n=True), r"has n True; it must be a whole number >= 1"),
        (_cell_with(usable=65), r"has usable 65; it must be a whole number in \[0, n = 64\]"),
        (_cell_with(usable=-1), r"has usable -1; it must be a whole number in \[0, n = 64\]"),
        (_cell_with(usable=1.5), r"has usable 1.5;"),
        (_cell_with(usable=1), r"has successes 2; it must be a whole number in \[0, usable = 1\]"),
        (_cell_with(successes=2.0), r"has successes 2.0;"),
        (_cell_with(success_rate="0.03125"), r"has success_rate '0.03125'; it must be successes"),
        (_cell_with(success_rate=0.5), r"has success_rate 0.5; it must be successes / n = 2/64"),
        (_cell_with(success_95="x"), r"has success_95 'x'; it must be the 95 % Wilson interval"),
        (_cell_with(success_95=[0.0]), r"has success_95 \[0.0\]; it must be the 95 % Wilson"),
        (_cell_with(success_95=[0.0, 0.5]), r"of 2 of 64, \[0.00861214, 0.106973\]$"),
        (_cell_with(success_95=["a", "b"]), r"has success_95 \['a', 'b'\];"),
        (_cell_with(free_energy_median="x"), r"has free_energy_median 'x'; it must be a finite"),
        (_cell_with(free_energy_median=math.nan), r"has free_energy_median nan; it must be"),
        (_cell_with(free_energy_median=None), r"has free_energy_median None; it must be a finite"),
        (
            _cell_with(successes=0, success_rate=0.0, success_95=[0.0, 0.0], usable=0),
            r"has success_95 \[0.0, 0.0\];",
        ),
    ],
)
def test_every_field_of_a_from_cell_is_checked(tmp_path, cell, message):
    path = tmp_path / "tiers.json"
    path.write_text(json.dumps({"random": 64, "seed": 0, "cells": [cell]}), encoding="utf-8")
    with pytest.raises(ValueError, match=message) as err:
        read_random_cells(path)
    text = str(err.value)
    assert text.startswith(f"{path}: cell 0") and "\n" not in text


def test_a_bad_from_file_on_the_command_line_is_one_line(tmp_path, capsys):
    path = tmp_path / "tiers.json"
    path.write_text(json.dumps({"cells": [_cell_with(success_95="x")]}), encoding="utf-8")
    out = tmp_path / "out.json"
    assert task_tiers.main(["--from", str(path), "--json", str(out)]) == 2
    captured = capsys.readouterr()
    err_lines = captured.err.strip().splitlines()
    assert err_lines == [
        f"task_tiers: error: {path}: cell 0 (push, d = 3) has success_95 'x'; it must be the "
        "95 % Wilson interval of 2 of 64, [0.00861214, 0.106973]"
    ]
    assert captured.out == "" and not out.exists()


def test_a_from_cell_without_usable_designs_has_no_median(tmp_path):
    none_usable = {"successes": 0, "success_rate": 0.0, "usable": 0}
    none_usable["success_95"] = list(wilson_interval(0, 64))
    path = tmp_path / "tiers.json"
    for median, ok in ((None, True), (1000.0, False)):
        cell = _cell_with(**none_usable, free_energy_median=median)
        path.write_text(json.dumps({"cells": [cell]}), encoding="utf-8")
        if ok:
            assert read_random_cells(path)["cells"][0]["free_energy_median"] is None
        else:
            with pytest.raises(ValueError, match="it must be null: no design is usable"):
                read_random_cells(path)


@pytest.mark.parametrize(
    ("record", "message"),
    [
        ({"random": "64"}, r": random '64' must be a whole number >= 1 \(or absent\)"),
        ({"random": 0}, r": random 0 must be a whole number >= 1"),
        ({"seed": 1.5}, r": seed 1.5 must be a whole number \(or absent\)"),
        (
            {"random": 32},
            r": cell 0 \(push, d = 3\) has n 64; it must be the file's random designs",
        ),
    ],
)
def test_the_from_files_metadata_is_checked(tmp_path, record, message):
    path = tmp_path / "tiers.json"
    path.write_text(json.dumps({**record, "cells": [_cell_with()]}), encoding="utf-8")
    with pytest.raises(ValueError, match=message) as err:
        read_random_cells(path)
    assert str(err.value).startswith(str(path)) and "\n" not in str(err.value)


def test_a_cell_twice_in_a_from_file_is_named(tmp_path):
    path = tmp_path / "tiers.json"
    cells = [_cell_with(), _random_cell("hook", 3, 9), _cell_with()]
    path.write_text(json.dumps({"cells": cells}), encoding="utf-8")
    with pytest.raises(ValueError, match=r"the cell push at d = 3 appears more than once$"):
        read_random_cells(path)


def test_a_task_or_degree_given_twice_is_labelled_once(capsys):
    args = task_tiers.parse_args(["--task", "push", "--task", "hook", "--task", "push"])
    assert args.task == ["push", "hook"]
    assert task_tiers.parse_args(["--degrees", "5", "3", "5"]).degrees == [5, 3]
    argv = ["--from", str(TIERS_JSON), "--task", "push", "--task", "push", "--degrees", "3", "3"]
    assert task_tiers.main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines if " d = " in line] == ["push      d = 3"]


@pytest.mark.parametrize(
    ("kept", "words"),
    [
        ({"random": 64, "seed": 0}, "64 random designs per cell (seed 0), from FILE;"),
        ({}, "random designs per cell and seed: not recorded in FILE, from FILE;"),
        ({"seed": 0}, "random designs per cell: not recorded in FILE (seed 0), from FILE;"),
        ({"random": 64}, "64 random designs per cell (seed: not recorded in FILE), from FILE;"),
    ],
)
def test_missing_metadata_of_a_from_file_is_worded_honestly(tmp_path, capsys, kept, words):
    path = tmp_path / "tiers.json"
    committed = json.loads(TIERS_JSON.read_text(encoding="utf-8"))
    path.write_text(json.dumps({**kept, "cells": committed["cells"]}), encoding="utf-8")
    out = tmp_path / "out.json"
    assert task_tiers.main(["--from", str(path), "--task", "hook", "--json", str(out)]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert header.startswith("Tiers per (task, d): " + words.replace("FILE", str(path)))
    assert "None" not in header
    record = json.loads(out.read_text(encoding="utf-8"))
    assert (record["random"], record["seed"]) == (kept.get("random"), kept.get("seed"))


def test_from_refuses_simulation_options_and_absent_cells(capsys):
    for option in (["--random", "8"], ["--seed", "1"], ["--workers", "1"]):
        with pytest.raises(SystemExit):
            task_tiers.parse_args(["--from", str(TIERS_JSON), *option])
        assert "--from FILE takes the file's figures" in capsys.readouterr().err
    only_push = {"cells": [_random_cell("push", 3, 2)]}
    with pytest.raises(ValueError, match="has no cell hook at d = 3"):
        task_tiers._select(only_push["cells"], ["hook"], [3], "FILE")


# --- docs/tasks.md says what the rule is and what the committed tiers hold ---


def _page_text() -> str:
    return " ".join(PAGE.read_text(encoding="utf-8").split())


def test_the_page_states_the_rules_thresholds():
    rule = TierRule()
    assert (
        f"*easy* for r < {rule.easy_regret:g}, *medium* for {rule.easy_regret:g} <= r < "
        f"{rule.hard_regret:g}, *hard* for r >= {rule.hard_regret:g}" in _page_text()
    )
    assert (
        f"*easy* for p >= {100 * rule.easy_share:g} %, *medium* for {100 * rule.hard_share:g} % "
        f"<= p < {100 * rule.easy_share:g} %, *hard* for p < {100 * rule.hard_share:g} %"
        in _page_text()
    )


def test_the_pages_quick_run_figures_are_the_quick_runs():
    cells = protocol_baselines(QUICK)["cells"]
    push = [cells[("push", d)] for d in (3, 5, 8)]
    rule = TierRule()
    figures = ", ".join(
        f"{c['regret_median']:.2f} [{c['regret_95'][0]:.2f}, {c['regret_95'][1]:.2f}]"
        for c in push[:2]
    )
    last = push[2]
    claim = (
        f"r is {figures} and {last['regret_median']:.2f} [{last['regret_95'][0]:.2f}, "
        f"{last['regret_95'][1]:.2f}] at d = 3, 5 and 8 (regret tiers "
        f"{', '.join(str(rule.regret_tier(c['regret_median'])) for c in push)}; "
        f"{push[0]['successes']} of {push[0]['runs']} runs end on a succeeding design at each d)"
    )
    assert claim in _page_text()
    assert {(c["successes"], c["runs"]) for c in push} == {(2, 12)}  # "at each d"
    assert "budgets of 32, 56 and 80 evaluations, 12 runs of CMA-ES on 6 instances per d" in (
        _page_text()
    )


def test_the_pages_quick_run_labels_and_their_marks_are_the_studys():
    cells = label_cells(read_random_cells(TIERS_JSON)["cells"], protocol_baselines(QUICK))
    push = [c for c in cells if c["task"] == "push"]
    assert [c["degree"] for c in push] == [3, 5, 8]
    words = [f"{c['tier']}? ({c['tier_range'][0]} to {c['tier_range'][1]})" for c in push]
    assert all(c["uncertain"] for c in push)
    claim = (
        f"they print as {words[0].replace(')', ' within the intervals)')}, "
        f"{push[1]['tier']}? and {words[2]}"
    )
    assert push[1]["tier_range"] == push[2]["tier_range"]  # "hard? and hard? (...)"
    assert claim in _page_text()


def test_the_page_marks_the_random_tiers_their_intervals_leave_open():
    rule = TierRule()
    record = json.loads(TIERS_JSON.read_text(encoding="utf-8"))
    for cell in record["cells"]:
        easiest, hardest = rule.share_tiers(cell["success_rate"], cell["success_95"])
        mark = "?" if easiest != hardest else ""
        low, high = cell["success_95"]
        shown = (
            f"{cell['successes']}/{cell['n']} ({100 * cell['success_rate']:.1f} %, "
            f"[{100 * low:.1f}, {100 * high:.1f}] %): **{rule.share_tier(cell['success_rate'])}"
            f"{mark}**"
        )
        assert f"{shown} |" in _page_text(), shown


def test_the_page_says_whether_the_committed_tiers_have_the_regret():
    record = json.loads(TIERS_JSON.read_text(encoding="utf-8"))
    pending = "The committed tiers.json holds the random share's tiers alone until that run is"
    if record.get("protocol") is None:
        assert all(c.get("regret_tier") is None for c in record["cells"])
        assert pending in _page_text()
    else:  # labelled: the page shows the labels the study printed, and no longer says pending
        assert " ".join(markdown_table(record["cells"]).split()) in _page_text()
        assert pending not in _page_text()
