"""A design run says how many of its evaluations succeed, not only whether its lowest F does.

In hook and obstacle the lowest-F design leaves the box off the goal while 39-48 % of CMA-ES's
evaluations succeed (docs/tasks.md): the evaluation log has a ``success`` column, design.json
the counts and the lowest-F succeeding design, and ``tooldesign design`` and report.html say
"k of n evaluations succeed; the lowest-F succeeding design C = ...".
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks.reports.success import (
    SUCCESS_COLUMN,
    EvaluationSuccesses,
    evaluation_successes,
    evaluations_success,
    evaluations_success_text,
)
from tooldesign_env.tasks import get_task

HOOK = get_task("hook")
REST = float(HOOK.box_start()[2])  # the box's resting height, m


def _log(rows: list[dict]) -> pd.DataFrame:
    base = {"iteration": 0, "c1": 0.1, "c2": 0.2, "c3": 0.3, "status": "ok"}
    out = []
    for i, row in enumerate(rows):
        out.append({**base, "candidate": i, **row})
    return pd.DataFrame(out)


def test_each_row_is_judged_by_its_stored_column_or_else_its_stored_pose():
    log = _log(
        [
            # Standing within 0.1 m of the goal: a success.
            {"free_energy": 5.0, "final_distance": 0.05, "final_height": REST, "final_tilt": 0.0},
            # Within the radius but lying on its side: not.
            {"free_energy": 4.0, "final_distance": 0.05, "final_height": 0.05, "final_tilt": 1.5},
            # Too far.
            {"free_energy": 3.0, "final_distance": 0.2, "final_height": REST, "final_tilt": 0.0},
            # Unusable: never a success, whatever its distance.
            {"free_energy": 9.0, "final_distance": 0.0, "final_height": REST, "final_tilt": 0.0,
             "status": "invalid"},
            # A row stored before the height and tilt existed: the distance alone.
            {"free_energy": 6.0, "final_distance": 0.08},
            # Half a pose: unknown, never a failure.
            {"free_energy": 7.0, "final_distance": 0.05, "final_height": REST},
        ]
    )
    assert evaluation_successes(log, HOOK) == [True, False, False, False, True, None]
    # A stored column is the outcome where it has one (1 or 0); NaN is judged from the pose.
    log[SUCCESS_COLUMN] = [0.0, 1.0, math.nan, 0.0, math.nan, 1.0]
    assert evaluation_successes(log, HOOK) == [False, True, False, False, True, True]


def test_the_lowest_f_succeeding_design_is_named_not_the_lowest_f():
    log = _log(
        [
            {"free_energy": -187.0, "final_distance": 0.12, "c1": 1.5},  # lowest F, fails
            {"free_energy": 40.0, "final_distance": 0.09, "c1": 0.7, "iteration": 1},
            {"free_energy": 1.4, "final_distance": 0.036, "c1": 0.4, "iteration": 2},
            {"free_energy": 1.4, "final_distance": 0.05, "c1": 0.5, "iteration": 3},  # a tie
            {"free_energy": 20.0, "final_distance": math.nan},  # not stored
        ]
    )
    summary = evaluations_success(log, HOOK)
    assert (summary.successes, summary.n, summary.unknown) == (3, 4, 1)
    assert summary.best is not None and summary.best["c1"] == 0.4  # the first of the tie
    text = evaluations_success_text(summary, 3)
    assert text == (
        "3 of 4 evaluations succeed (1 more with no stored outcome); the lowest-F succeeding "
        "design C = (0.4, 0.2, 0.3) (iteration 2, candidate 2), F = 1.4, ends 0.036 m from "
        "the goal"
    )
    assert evaluations_success_text(summary) == text  # the c<i> columns of the row
    none = evaluations_success(log.assign(final_distance=0.5), HOOK)
    assert none.best is None
    assert evaluations_success_text(none) == "0 of 5 evaluations succeed; none succeeds"


def test_the_success_helpers_refuse_bad_input():
    log = _log([{"free_energy": 1.0, "final_distance": 0.05}])
    with pytest.raises(TypeError, match="evaluations must be a pandas DataFrame"):
        evaluation_successes(log.to_dict(), HOOK)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="criterion must be a TaskDefinition or a radius"):
        evaluation_successes(log, "hook")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="'free_energy' column"):
        evaluations_success(log.drop(columns="free_energy"), HOOK)
    with pytest.raises(TypeError, match="summary must be an EvaluationSuccesses"):
        evaluations_success_text((1, 2, 0, None))  # type: ignore[arg-type]
    summary = EvaluationSuccesses(0, 1, 0, None)
    for degree in (0, 1.5, True):
        with pytest.raises(ValueError, match="degree must be a whole number >= 1"):
            evaluations_success_text(summary, degree)  # type: ignore[arg-type]


@pytest.mark.slow  # draws the design page's pictures (about 2 s)
def test_a_design_report_names_its_task_and_its_succeeding_evaluations(tmp_path):
    """A folder stored before the ``success`` column and the card's counts: read from its log."""
    sys.path.insert(0, str(Path(__file__).parent))
    from test_html_report import _design_folder

    from benchmarks.reports.html import write_html_report

    folder = _design_folder(tmp_path / "run", iterations=3, batch=4)
    log = pd.read_csv(folder / "evaluations.csv")
    assert SUCCESS_COLUMN not in log.columns and "success" not in json.loads(
        (folder / "design.json").read_text()
    )
    hits = log[log["final_distance"] <= 0.1]  # push's radius; no height or tilt stored
    assert 0 < len(hits) < len(log)
    best = hits.loc[hits["free_energy"].idxmin()]
    text = write_html_report(folder).read_text()
    assert (
        f"<strong>Every evaluation:</strong> {len(hits)} of {len(log)} evaluations succeed; "
        f"the lowest-F succeeding design C = ({best['c1']:.4g}, {best['c2']:.4g}, "
        f"{best['c3']:.4g}) (iteration {best['iteration']}, candidate {best['candidate']}), "
        f"F = {best['free_energy']:.6g}, ends {best['final_distance']:.3f} m from the goal."
    ) in text
    # The robustness sentence: the stand-in paths end 0.7 m from the goal at every mass.
    assert "at 0 of 4 altered masses." in text
    # The task, in the subtitle and among the settings (none stored: push, the paper's).
    label = "push (push the box along the floor to the goal (the paper&#x27;s task))"
    assert f"designs, task {label}, goal X^g" in text
    assert f'<td class="key">task</td><td class="text">{label}</td>' in text


@pytest.mark.slow  # a design run of 2 evaluations on hook and 2 more simulations
def test_a_design_run_stores_every_evaluations_success_as_the_env_says(tmp_path):
    from benchmarks.design import DesignConfig, run_design
    from tooldesign_env import ToolDesignEnv

    config = DesignConfig(
        task_name="hook",
        goal=HOOK.goal,
        iterations=1,
        batch_size=2,
        seed=1,
        # Near hook's (0.4, 1.4, 0.18), which leaves the box 0.036 m off (docs/tasks.md).
        optimizer_settings={"x0": [0.4, 1.4, 0.18], "sigma0": 0.01},
        executor="serial",
        robustness_masses=(0.3,),
    )
    result = run_design(config, tmp_path / "d", progress=False)
    log = pd.read_csv(tmp_path / "d" / "evaluations.csv")
    assert set(log[SUCCESS_COLUMN]) <= {0.0, 1.0}
    env = ToolDesignEnv(task="hook")
    try:
        env.reset(seed=0)
        for _, row in log.iterrows():
            info = env.step(row[["c1", "c2", "c3"]].to_numpy(dtype=np.float64))[4]
            assert bool(row[SUCCESS_COLUMN]) is info["success"]
    finally:
        env.close()
    card = json.loads((tmp_path / "d" / "design.json").read_text())
    hits = log[log[SUCCESS_COLUMN] == 1.0]
    assert len(hits) >= 1  # designs within 0.03 of hook's, which ends 0.036 m off, succeed
    assert card["evaluations"]["succeeded"] == result.successes == len(hits)
    assert card["evaluations"]["success_unknown"] == 0 and result.success_known == len(log)
    best = log.loc[log["free_energy"].idxmin()]
    assert card["success"] is result.success is bool(best[SUCCESS_COLUMN])
    first = hits.loc[hits["free_energy"].idxmin()]
    assert card["best_succeeding"] == result.best_succeeding
    assert card["best_succeeding"]["free_energy"] == first["free_energy"]
    assert card["best_succeeding"]["coefficients"] == first[["c1", "c2", "c3"]].tolist()
