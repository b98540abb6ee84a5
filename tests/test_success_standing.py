"""Success in the reports is the task's whole test: the box must end standing, not only near.

Every evaluation stores the box's ``final_height`` (m) and ``final_tilt`` (rad) beside
``final_distance`` (``tooldesign_env.schema.STANDING_COLUMNS``); the reports apply
``TaskDefinition.succeeded`` with them, and judge rows stored before the columns existed by
the distance alone, as they always were (``benchmarks/reports/success.py``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from benchmarks.protocol.report import _best_succeeded
from benchmarks.reports.comparison import _summary_markdown, summary_table
from benchmarks.reports.success import (
    design_succeeded,
    has_standing,
    run_successes,
    success_criterion,
    success_sentence,
)
from benchmarks.reports.suite import designs_table
from benchmarks.storage import ResultStore
from tooldesign_env.schema import STANDING_COLUMNS
from tooldesign_env.tasks import get_task

PUSH = get_task("push")
REST = float(PUSH.box_start()[2])  # the box's resting centre height, m (half its 0.2 m height)
LYING = (REST / 2.0, math.pi / 2.0)  # on its side: centre 0.05 m high, up axis horizontal
TIPPED = (REST, 0.5)  # the height of a standing box, but leaning 29 degrees (onto a curb)
STANDING = (REST + 0.001, 0.01)


def test_the_columns_are_named_once() -> None:
    assert STANDING_COLUMNS == ("final_height", "final_tilt")


# --- one design ---------------------------------------------------------------------------------


def test_a_box_lying_or_tipped_within_the_radius_is_no_success() -> None:
    assert design_succeeded("ok", 0.02, PUSH, *STANDING) is True
    assert design_succeeded("ok", 0.02, PUSH, *LYING) is False
    assert design_succeeded("ok", 0.02, PUSH, *TIPPED) is False
    # As the env's own test says for the same numbers.
    for height, tilt in (STANDING, LYING, TIPPED):
        got = design_succeeded("ok", 0.02, PUSH, height, tilt)
        assert got is PUSH.succeeded(0.02, height, final_tilt=tilt)
    assert design_succeeded("ok", 0.2, PUSH, *STANDING) is False  # standing, but too far
    assert design_succeeded("invalid", 0.0, PUSH, *STANDING) is False


def test_a_row_without_height_and_tilt_is_judged_by_the_distance_alone() -> None:
    for missing in (None, float("nan"), pd.NA):
        assert design_succeeded("ok", 0.02, PUSH, missing, missing) is True
        assert design_succeeded("ok", 0.2, PUSH, missing, missing) is False
    assert design_succeeded("ok", 0.02, PUSH) is design_succeeded("ok", 0.02, 0.1) is True


@pytest.mark.parametrize(
    "height, tilt",
    [(REST, float("nan")), (float("nan"), 0.0), (math.inf, 0.0), (REST, -math.inf)],
)
def test_a_half_stored_or_infinite_height_or_tilt_is_unknown(height: float, tilt: float) -> None:
    # The task's test cannot be applied: n/a, never a success nor a failure.
    assert design_succeeded("ok", 0.02, PUSH, height, tilt) is None
    assert design_succeeded("failed", 0.02, PUSH, height, tilt) is False


def test_bad_criteria_are_refused() -> None:
    with pytest.raises(ValueError, match="needs the task's test: pass the TaskDefinition"):
        design_succeeded("ok", 0.02, 0.1, *LYING)
    with pytest.raises(TypeError, match="criterion must be a TaskDefinition or a radius"):
        design_succeeded("ok", 0.02, "push")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown task"):
        success_criterion("nope")
    assert success_criterion() is PUSH


# --- runs, frames and reports -------------------------------------------------------------------


def _log(standing: bool) -> pd.DataFrame:
    """Two runs whose lowest-F design ended 0.02 m from the goal; cmaes's box lies there."""
    rows = []
    for optimizer, final in (("cmaes", LYING), ("random", STANDING)):
        for iteration, (f, distance, state) in enumerate(
            [(5.0, 0.5, STANDING), (1.0, 0.02, final)]
        ):
            row = {
                "suite": "s",
                "variant": "",
                "optimizer": optimizer,
                "seed": 0,
                "iteration": iteration,
                "candidate": 0,
                "free_energy": f,
                "final_distance": distance,
                "status": "ok",
            }
            if standing:
                row.update(zip(STANDING_COLUMNS, state, strict=True))
            rows.append(row)
    return pd.DataFrame(rows)


def test_a_stored_lying_box_is_not_counted_by_the_reports() -> None:
    log = _log(standing=True)
    got = run_successes(log, PUSH).set_index("optimizer")["success"].to_dict()
    assert got == {"cmaes": False, "random": True}
    summary = summary_table(log, n_boot=10, tolerance=PUSH).set_index("optimizer")
    assert summary.loc["cmaes", "successes"] == 0 and summary.loc["random", "successes"] == 1
    # The protocol's per-checkpoint success: after 1 evaluation the standing far design, after
    # 2 the lying near one.
    run = log[log["optimizer"] == "cmaes"]
    assert _best_succeeded(run, 1, PUSH) is False and _best_succeeded(run, 2, PUSH) is False
    assert _best_succeeded(log[log["optimizer"] == "random"], 2, PUSH) is True
    assert has_standing(log)
    markdown = _summary_markdown(summary.reset_index(), 0.95, task="push", standing=True)
    assert "left the box standing within 0.1 m" in markdown


def test_an_old_frame_without_the_columns_reads_as_before() -> None:
    log = _log(standing=False)
    assert not has_standing(log)
    by_task = run_successes(log, PUSH)
    pd.testing.assert_frame_equal(by_task, run_successes(log, 0.1))  # the radius alone
    assert by_task.set_index("optimizer")["success"].to_dict() == {"cmaes": True, "random": True}
    assert _best_succeeded(log[log["optimizer"] == "cmaes"], 2, PUSH) is True
    summary = summary_table(log, n_boot=10, tolerance=PUSH)
    pd.testing.assert_frame_equal(summary, summary_table(log, n_boot=10, tolerance=0.1))
    # The sentence of an old folder's report is the one it always had.
    assert success_sentence("push", 0.1) == (
        "Success: the run's final design was usable and left the box within 0.1 m of the goal "
        "(the push task's tolerance), from the stored status and final distance; the share of "
        "runs with a 95% Wilson interval, n/a where no final distance was stored."
    )


def test_a_resumed_old_folder_judges_each_row_by_what_it_stores(tmp_path: Path) -> None:
    # An old part (no height or tilt) and a new one (with them) in one run folder.
    log = _log(standing=True)
    store = ResultStore(tmp_path)
    base = {"eval_id": 0, "c1": 0.0, "eval_time": 0.0, "opt_time": 0.0, "goal_precision": 20.0}
    base |= {"goal_x": 0.0, "goal_y": 1.5, "goal_z": 0.1, "box_mass": 0.1}
    base |= {"goal_error": 1.0, "confidence": 0.0}
    for (optimizer, _iteration), rows in log.groupby(["optimizer", "iteration"]):
        frame = rows.assign(**base)
        if optimizer == "cmaes":  # cmaes's run was stored before the columns existed
            frame = frame.drop(columns=list(STANDING_COLUMNS))
        store.write_batch(frame)
    read = store.read()
    columns = list(read.columns)
    assert columns.index("final_height") == columns.index("final_distance") + 1
    assert columns.index("final_tilt") == columns.index("final_distance") + 2
    assert read.loc[read["optimizer"] == "cmaes", "final_tilt"].isna().all()
    got = run_successes(read, PUSH).set_index("optimizer")["success"].to_dict()
    assert got == {"cmaes": True, "random": True}  # cmaes by the distance alone, as before


def test_a_design_record_with_height_and_tilt_is_judged_by_the_task() -> None:
    record = {
        "suite": "s",
        "variant": "",
        "optimizer": "cmaes",
        "seed": 0,
        "goal": [0.0, 1.5, 0.1],
        "goal_precision": 20.0,
        "coefficients": [0.0, 0.0, 0.0],
        "free_energy": 1.0,
        "goal_error": 1.0,
        "confidence": 0.0,
        "final_distance": 0.02,
        "status": "ok",
    }
    lying = {**record, **dict(zip(STANDING_COLUMNS, LYING, strict=True))}
    table = designs_table([record, lying], tolerance=PUSH)
    assert table["success"].tolist() == [True, False]
    assert list(designs_table([record], tolerance=0.1).columns) == list(table.columns)


# --- one real evaluation ------------------------------------------------------------------------


@pytest.mark.slow
def test_an_evaluation_stores_the_envs_final_height_and_tilt() -> None:
    import gymnasium as gym

    import tooldesign_env  # noqa: F401  (registers the ids)
    from benchmarks.design import DesignConfig, DesignStepper
    from benchmarks.execution.evaluator import EvaluationRequest, TaskSettings, evaluate_design

    design = (0.0, 0.0, 0.2)
    task = TaskSettings()
    row = evaluate_design(EvaluationRequest(coeffs=design, task=task))
    env = gym.make("ToolDesign-v0")
    try:
        env.reset(options={"goal": task.goal, "box_mass": task.box_mass})
        info = env.step(np.asarray(design, dtype=np.float64))[4]
    finally:
        env.close()
    assert row["status"] == "ok"
    for name in STANDING_COLUMNS:
        assert math.isfinite(row[name]) and row[name] == info[name], name
    assert design_succeeded(
        row["status"], row["final_distance"], PUSH, row["final_height"], row["final_tilt"]
    ) is bool(info["success"])
    # What the stepper makes of the row is what the store writes: the two columns, as given.
    stepper = DesignStepper(DesignConfig(iterations=1, batch_size=1, seed=0, optimizer="random"))
    stepper.ask()
    frame = stepper.tell([row])
    assert [frame[c].iloc[0] for c in STANDING_COLUMNS] == [row[c] for c in STANDING_COLUMNS]
