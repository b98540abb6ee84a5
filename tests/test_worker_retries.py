"""A worker killed mid-batch: the item is run again alone, retried ``max_retries`` times (#10).

The work functions of ``worker_killer`` SIGKILL their own worker process for one chosen item,
on every start or on the first few only (a death from outside, such as the out-of-memory
killer). Each test checks the outcomes, how many times the item started, and that no worker
process of the pool is left once the executor is closed.
"""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path

import psutil
import pytest
import worker_killer
from scheduler_jobs import OneBatch

from benchmarks.cli import main
from benchmarks.design import DesignConfig, DesignStepper, run_design
from benchmarks.execution import (
    MAX_RETRIES_MAX,
    Scheduler,
    WorkerDied,
    evaluator,
    make_executor,
    map_robust,
)
from benchmarks.suites import builtin_suite, suite_from_json

GRACE = 5.0  # s a shut-down pool's workers may take to exit


def _assert_no_worker_left(starts_dir: Path) -> None:
    pids = worker_killer.worker_pids(starts_dir)
    assert pids, "no worker recorded its pid"
    end = time.monotonic() + GRACE
    alive = pids
    while alive and time.monotonic() < end:
        alive = {pid for pid in alive if _alive(pid)}
        time.sleep(0.05)  # polling process states; the pools exit in well under a second
    assert not alive, f"{len(alive)} of {len(pids)} worker processes outlived their pool"


def _alive(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


@pytest.mark.slow
@pytest.mark.parametrize(
    ("max_retries", "deaths", "starts", "survives"),
    [
        (0, None, 2, False),  # dies in the batch, then once alone: failed
        (2, None, 4, False),  # dies in the batch, then alone and on both retries: failed
        (0, 2, 2, False),  # would live on its third start, but no retry is allowed
        (2, 2, 3, True),  # dies in the batch and alone, lives on its first retry
    ],
)
def test_a_killed_item_is_retried_max_retries_times_then_failed(
    tmp_path: Path, max_retries: int, deaths: int | None, starts: int, survives: bool
) -> None:
    victim = "2 * 21"
    work = functools.partial(
        worker_killer.die_or_eval, victim=victim, deaths=deaths, starts_dir=str(tmp_path)
    )
    items = ["abs(-2)", victim, "abs(-5)", "1 + 1"]
    with make_executor("process", workers=2, max_retries=max_retries) as executor:
        outcomes = map_robust(executor, work, items)
        assert map_robust(executor, eval, ["3 * 3"])[0][:2] == (9, None)  # the pool works
    assert [o.result for o in outcomes] == [2, 42 if survives else None, 5, 2]
    assert [o.error for i, o in enumerate(outcomes) if i != 1] == [None] * 3
    if survives:
        assert outcomes[1].error is None
    else:
        assert isinstance(outcomes[1].error, WorkerDied)
        assert outcomes[1].error.runs == 1 + max_retries
        assert f"max_retries={max_retries}" in str(outcomes[1].error)
    assert worker_killer.starts(tmp_path) == starts
    _assert_no_worker_left(tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize(("max_retries", "starts"), [(0, 2), (2, 4)])
def test_the_scheduler_retries_a_killed_item_alone(
    tmp_path: Path, max_retries: int, starts: int
) -> None:
    work = functools.partial(
        worker_killer.die_or_eval, victim="0 - 1", deaths=None, starts_dir=str(tmp_path)
    )
    killer, other = OneBatch(["abs(-2)", "0 - 1"]), OneBatch(["abs(-5)", "1 + 1"])
    with make_executor("process", workers=2, max_retries=max_retries) as executor:
        Scheduler(executor, work, max_active=2).run([killer, other])
    assert [o.result for o in killer.outcomes] == [2, None]
    assert isinstance(killer.outcomes[1].error, WorkerDied)
    assert [(o.result, o.error) for o in other.outcomes] == [(5, None), (2, None)]
    assert worker_killer.starts(tmp_path) == starts
    _assert_no_worker_left(tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("value", [-1, MAX_RETRIES_MAX + 1, 1.0, True, "2", None])
def test_max_retries_must_be_an_int_from_0_to_100(value: object) -> None:
    with pytest.raises((TypeError, ValueError), match="max_retries"):
        DesignConfig(max_retries=value)  # type: ignore[arg-type]
    with pytest.raises((TypeError, ValueError), match="max_retries"):
        with make_executor("serial", max_retries=value):  # type: ignore[arg-type]
            pass
    suite = builtin_suite("optimizers", "smoke").to_json()
    with pytest.raises((TypeError, ValueError), match="max_retries"):
        suite_from_json({**suite, "max_retries": value})


def test_max_retries_reaches_the_suite_and_may_change_on_resume() -> None:
    suite = builtin_suite("optimizers", "smoke")
    assert suite.max_retries == 0
    changed = suite.replace(max_retries=3)
    assert {run.design.max_retries for run in changed.runs()} == {3}
    assert suite_from_json(changed.to_json()) == changed
    from benchmarks.suites.config import RUNTIME_FIELDS

    assert "max_retries" in RUNTIME_FIELDS


@pytest.mark.slow
@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["design", "--max-retries", "-1"], "must be an int from 0 to 100, got '-1'"),
        (["design", "--max-retries", "True"], "got 'True'"),
        (["design", "--max-retries", "101"], "got '101'"),
        (["design", "--max-retries", "1.5"], "got '1.5'"),
        (["bench", "optimizers", "--max-retries", "x"], "got 'x'"),
        (["bench", "optimizers", "--max-retries", ""], "got ''"),
    ],
)
def test_bad_max_retries_flags_exit_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], match: str
) -> None:
    with pytest.raises(SystemExit) as stop:
        main([*argv, "--out", str(tmp_path / "out")])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--max-retries" in err[0] and match in err[0], err
    assert not (tmp_path / "out").exists()


def _killing_design_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, max_retries: int
) -> tuple[DesignConfig, tuple[float, ...], Path]:
    config = DesignConfig(
        seed=3, iterations=1, batch_size=3, workers=2, executor="process", max_retries=max_retries
    )
    # The optimizer asks the same first batch in the run: its candidate 1 kills its worker.
    victim = tuple(float(c) for c in DesignStepper(config).ask()[1])
    starts_dir = tmp_path / "starts"
    starts_dir.mkdir()
    work = functools.partial(
        worker_killer.die_or_evaluate, victim=victim, deaths=None, starts_dir=str(starts_dir)
    )
    monkeypatch.setattr(evaluator, "evaluate_design", work)
    return config, victim, starts_dir


@pytest.mark.slow
def test_a_design_run_whose_worker_is_killed_finishes_and_counts_the_failure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config, victim, starts_dir = _killing_design_run(tmp_path, monkeypatch, max_retries=0)
    with pytest.warns(RuntimeWarning, match="candidate 1 failed: worker process died") as seen:
        result = run_design(config, tmp_path / "run", progress=False)
    assert any("WorkerDied" in str(w.message) and "max_retries=0" in str(w.message) for w in seen)
    log = result.evaluations
    assert log["status"].tolist()[1] == "failed" and "failed" not in log["status"].tolist()[::2]
    coefficients = log[["c1", "c2", "c3"]].iloc[1].tolist()
    assert coefficients == list(victim)
    assert result.card["evaluations"]["failed"] == 1
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["extra"]["evaluation_counts"] == {
        "total": 3,
        "ok": int((log["status"] == "ok").sum()),
        "invalid": int((log["status"] == "invalid").sum()),
        "failed": 1,
    }
    assert worker_killer.starts(starts_dir) == 2
    _assert_no_worker_left(starts_dir)


@pytest.mark.slow
def test_the_design_command_retries_a_killed_design_and_prints_the_failures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    config, victim, starts_dir = _killing_design_run(tmp_path, monkeypatch, max_retries=2)
    argv = ["design", "--seed", "3", "--iterations", "1", "--batch-size", "3", "--workers", "2"]
    argv += ["--max-retries", "2", "--no-video", "--no-progress", "--out", str(tmp_path / "run")]
    with pytest.warns(RuntimeWarning, match="candidate 1 failed: worker process died"):
        assert main(argv) == 0
    out = capsys.readouterr().out
    assert "evaluations: 3 (" in out and "1 failed); each failure's message" in out, out
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert manifest["config"]["max_retries"] == 2
    assert manifest["extra"]["evaluation_counts"]["failed"] == 1
    assert worker_killer.starts(starts_dir) == 4  # in the batch, alone, and two retries
    _assert_no_worker_left(starts_dir)


def test_a_broken_pools_leftover_workers_are_stopped_and_a_healthy_pools_are_not() -> None:
    # CPython 3.11 may start one more worker in a submit that races with the breakage; it
    # waits on the call queue forever and the interpreter never exits. The executor stops
    # whatever workers a broken pool still has when it restarts or shuts that pool down.
    import multiprocessing
    import types

    from benchmarks.execution.executors import _stop_leftover_workers

    context = multiprocessing.get_context("spawn")
    workers = [context.Process(target=time.sleep, args=(60,), daemon=True) for _ in range(2)]
    for process in workers:
        process.start()
    try:
        healthy = types.SimpleNamespace(_broken=False, _processes={1: workers[0]})
        broken = types.SimpleNamespace(_broken="a worker died", _processes={2: workers[1]})
        _stop_leftover_workers(healthy)  # type: ignore[arg-type]
        _stop_leftover_workers(broken)  # type: ignore[arg-type]
        workers[1].join(GRACE)
        assert not workers[1].is_alive() and workers[1].exitcode is not None
        assert workers[0].is_alive()
        # A pool already shut down has no process list; nothing to do, no error.
        _stop_leftover_workers(types.SimpleNamespace(_broken="x", _processes=None))  # type: ignore[arg-type]
    finally:
        for process in workers:
            process.kill()
            process.join(GRACE)
