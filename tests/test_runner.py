"""benchmarks.suites.runner: resume after SIGKILL, executors agree, refusals, broken pools."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pandas as pd
import pytest
from cli_kill import run_until
from scheduler_jobs import OneBatch

from benchmarks.cli import main
from benchmarks.design import DesignConfig, run_design
from benchmarks.execution import Outcome, Scheduler, make_executor
from benchmarks.storage import (
    DESIGNS_DIR,
    ResultStore,
    ResumeError,
    RunSession,
    Unit,
    design_path,
    read_designs,
)
from benchmarks.suites import builtin_suite, load_suite
from benchmarks.suites.runner import run_suite

ROOT = Path(__file__).resolve().parents[1]
TIMING = ["eval_time", "opt_time"]

# Two short runs with a robustness test and kept paths: every stage of a run can be killed.
TINY = (
    'base = "mass-perturbation"\n'
    'name = "tiny"\n'
    "n_seeds = 1\n"
    "batch_size = 3\n"
    "iterations = 2\n"
    "robustness_masses = [0.5, 0.9]\n"
)


@pytest.fixture(scope="module")
def tiny_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("config") / "tiny.toml"
    path.write_text(TINY, encoding="utf-8")
    return path


def bench_args(config: Path, out: Path, *extra: str) -> list[str]:
    return ["bench", "--config", str(config), "--out", str(out), *extra]


@pytest.fixture(scope="module")
def uninterrupted(tiny_file: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("uninterrupted") / "run"
    assert main(bench_args(tiny_file, out, "--executor", "serial", "--no-progress")) == 0
    return out


def _designs_without_timing(folder: Path) -> list[dict]:
    records = read_designs(folder)
    for record in records:
        record.pop("test_time", None)
    return records


def _compare_suites(a: Path, b: Path) -> None:
    pd.testing.assert_frame_equal(
        ResultStore(a).read().drop(columns=TIMING), ResultStore(b).read().drop(columns=TIMING)
    )
    assert _designs_without_timing(a) == _designs_without_timing(b)
    paths_a = sorted((a / DESIGNS_DIR).rglob("*.paths.json"))
    paths_b = sorted((b / DESIGNS_DIR).rglob("*.paths.json"))
    assert [p.relative_to(a) for p in paths_a] == [p.relative_to(b) for p in paths_b]
    assert paths_a and all(
        x.read_bytes() == y.read_bytes() for x, y in zip(paths_a, paths_b, strict=True)
    )
    for table in sorted((a / "report").glob("*.csv")) + sorted((a / "report").glob("*.md")):
        assert table.read_bytes() == (b / "report" / table.name).read_bytes(), table.name


@pytest.mark.slow
def test_resume_after_sigkill_equals_uninterrupted_suite(
    tiny_file: Path, uninterrupted: Path, tmp_path: Path
) -> None:
    out = tmp_path / "killed"
    suite = load_suite(tiny_file)
    first = suite.runs()[0]
    unit = Unit(
        suite=first.suite,
        variant=first.variant.name,
        optimizer=first.optimizer.column,
        seed=first.task.seed,
        iteration=0,
    )
    parts = ResultStore(out)
    serial = ("--executor", "serial", "--no-progress")
    # Killed in the ask/tell loop of the first run, after its iteration 0 was logged ...
    run_until(bench_args(tiny_file, out, *serial), parts.part_path(unit))
    assert not (out / DESIGNS_DIR).exists()
    # ... and again while the first run's design is tested (after its last iteration).
    last = parts.part_path(dataclasses.replace(unit, iteration=suite.iterations - 1))
    run_until(bench_args(tiny_file, out, *serial), last)
    assert not design_path(
        out, variant=first.variant.name, optimizer=first.optimizer.column, seed=first.task.seed
    ).exists()
    # The same command finishes it, here on the process pool: executors agree.
    assert main(bench_args(tiny_file, out, "--executor", "process", "--workers", "2")) == 0
    _compare_suites(uninterrupted, out)
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["extra"]["sessions"]) == 3
    assert manifest["config"]["executor"] == "process"  # runtime fields may change


@pytest.mark.slow
def test_rerunning_a_finished_suite_changes_no_result(
    tiny_file: Path, uninterrupted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "again"
    out.mkdir()
    for path in uninterrupted.rglob("*"):
        if path.is_file():
            target = out / path.relative_to(uninterrupted)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(path.read_bytes())
    before = {p: p.read_bytes() for p in (out / "parts").rglob("*.csv")}
    before.update({p: p.read_bytes() for p in (out / DESIGNS_DIR).rglob("*.json")})
    assert main(bench_args(tiny_file, out, "--executor", "serial", "--no-progress")) == 0
    assert {p: p.read_bytes() for p in before} == before
    printed = capsys.readouterr().out
    assert "total time:" in printed and "simulation:" in printed and "optimizer:" in printed
    manifest = json.loads((out / "manifest.json").read_text())
    assert len(manifest["extra"]["sessions"]) == 2
    assert manifest["wall_time"] >= manifest["extra"]["sessions"][0]["wall_time"]


@pytest.mark.slow
def test_a_finished_suite_grows_by_the_runs_of_new_seeds(
    tiny_file: Path, uninterrupted: Path, tmp_path: Path
) -> None:
    # The one-seed suite, copied, then resumed with two seeds: its first run is kept as it is
    # and the result equals a fresh two-seed suite. Fewer seeds are refused.
    grown = tmp_path / "grown"
    for path in uninterrupted.rglob("*"):
        if path.is_file():
            target = grown / path.relative_to(uninterrupted)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(path.read_bytes())
    first = {p.relative_to(grown): p.read_bytes() for p in (grown / "parts").rglob("*.csv")}
    two = tmp_path / "two.toml"
    two.write_text(TINY.replace("n_seeds = 1", "n_seeds = 2"), encoding="utf-8")
    assert main(bench_args(two, grown, "--executor", "serial", "--no-progress")) == 0
    assert {p: (grown / p).read_bytes() for p in first} == first
    fresh = tmp_path / "fresh"
    assert main(bench_args(two, fresh, "--executor", "serial", "--no-progress")) == 0
    _compare_suites(grown, fresh)
    manifest = json.loads((grown / "manifest.json").read_text())
    assert manifest["config"]["n_seeds"] == 2
    with pytest.raises(ResumeError, match="n_seeds: 2 -> 1"):
        run_suite(load_suite(tiny_file), grown, resume=True, progress=False)


@pytest.mark.slow
def test_resume_refuses_other_settings_and_foreign_folders(tiny_file: Path, tmp_path: Path) -> None:
    suite = load_suite(tiny_file)
    out = tmp_path / "run"
    RunSession(out, kind="suite", config=suite.to_json(), resume=False).checkpoint()
    with pytest.raises(ResumeError, match="other settings.*iterations"):
        run_suite(suite.replace(iterations=3), out, progress=False)
    with pytest.raises(ValueError, match="not empty"):
        run_suite(suite, out, resume=False, progress=False)
    stray = tmp_path / "stray"
    stray.mkdir()
    (stray / "notes.txt").write_text("mine")
    with pytest.raises(ResumeError, match="no manifest.json"):
        run_suite(suite, stray, progress=False)
    a_file = tmp_path / "file"
    a_file.write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        run_suite(suite, a_file, progress=False)
    with pytest.raises(TypeError, match="SuiteConfig"):
        run_suite({"name": "x"}, tmp_path / "new")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="out_dir"):
        run_suite(suite, 3)  # type: ignore[arg-type]


@pytest.mark.slow
def test_a_design_run_folder_is_not_resumed_as_a_suite(tmp_path: Path) -> None:
    out = tmp_path / "design"
    config = DesignConfig(iterations=1, batch_size=2, executor="serial")
    run_design(config, out, progress=False)
    with pytest.raises(ResumeError, match="another kind"):
        run_suite(builtin_suite("optimizers", "smoke"), out, progress=False)


@pytest.mark.slow
def test_parts_of_runs_the_suite_does_not_plan_are_refused(tiny_file: Path, tmp_path: Path) -> None:
    suite = load_suite(tiny_file)
    out = tmp_path / "run"
    RunSession(out, kind="suite", config=suite.to_json(), resume=False).checkpoint()
    stray = Unit(suite="other", optimizer="cmaes", seed=1, iteration=0)
    path = ResultStore(out).part_path(stray)
    path.parent.mkdir(parents=True)
    path.write_text("suite\n")
    before = path.read_bytes()
    with pytest.raises(ResumeError, match="does not plan"):
        run_suite(suite, out, progress=False)
    assert path.read_bytes() == before


@pytest.mark.slow
def test_a_dead_worker_is_retried_alone_and_fails_only_its_own_item() -> None:
    # eval is a picklable builtin: one item kills its worker process, the pool breaks and takes
    # the other job's pending items with it; recovery gives each item its own outcome.
    killer = OneBatch(["abs(-2)", "__import__('os')._exit(3)"])
    other = OneBatch(["abs(-5)", "1 + 1"])
    with make_executor("process", workers=1) as executor:
        Scheduler(executor, eval, max_active=2).run([killer, other])
        assert [o.result for o in killer.outcomes] == [2, None]
        assert type(killer.outcomes[1].error).__name__ == "WorkerDied"  # a BrokenProcessPool
        assert [(o.result, o.error) for o in other.outcomes] == [(5, None), (2, None)]
        assert executor.submit(eval, "3 * 3").result() == 9  # the pool works again


@pytest.mark.slow
def test_the_scheduler_runs_jobs_of_several_batches_in_order() -> None:
    class Countdown:
        def __init__(self, n: int) -> None:
            self.n, self.seen = n, []

        def start(self) -> list[str]:
            return [str(self.n)]

        def advance(self, outcomes: list[Outcome]) -> list[str] | None:
            self.seen.append(outcomes[0].result)
            self.n -= 1
            return [str(self.n)] if self.n > 0 else None

    jobs = [Countdown(3), Countdown(1), Countdown(2)]
    with make_executor("serial") as executor:
        Scheduler(executor, eval, max_active=2).run(jobs)
    assert [job.seen for job in jobs] == [[3, 2, 1], [1], [2, 1]]


@pytest.mark.slow
def test_the_scheduler_sleeps_while_a_job_waits_for_its_last_item(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A job's first item is done at once, its second only when released. Waiting on the done
    # item too made `wait` return at once, over and over: the main process spun at full speed
    # and took CPU from the workers (the full optimizers suite ran 1.6x slower per evaluation).
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from benchmarks.execution import scheduler as module

    calls = []
    real_wait = module.wait

    def counting_wait(*args: object, **kwargs: object) -> object:
        calls.append(1)
        if len(calls) == 3:
            release.set()  # a spinning loop gets here at once; a sleeping one never does
        return real_wait(*args, **kwargs)  # type: ignore[arg-type]

    release = threading.Event()
    monkeypatch.setattr(module, "wait", counting_wait)
    timer = threading.Timer(0.3, release.set)
    timer.start()
    job = OneBatch(["fast", "slow"])
    try:
        with ThreadPoolExecutor(2) as executor:
            work = lambda item: item if item == "fast" else (release.wait(30), item)[1]  # noqa: E731
            Scheduler(executor, work, max_active=1).run([job])
    finally:
        timer.cancel()
    assert [o.result for o in job.outcomes] == ["fast", "slow"]
    assert len(calls) <= 2, f"the scheduler called wait {len(calls)} times for 2 items"


@pytest.mark.slow
@pytest.mark.parametrize("max_active", [0, -1, 1.5, True, 10**30])
def test_the_scheduler_refuses_bad_settings(max_active: object) -> None:
    from benchmarks.execution import SerialExecutor
    from benchmarks.execution.scheduler import MAX_ACTIVE_MAX

    with pytest.raises(ValueError, match=f"max_active must be an int from 1 to {MAX_ACTIVE_MAX}"):
        Scheduler(SerialExecutor(), eval, max_active=max_active)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="work must be a callable"):
        Scheduler(SerialExecutor(), 3, max_active=1)  # type: ignore[arg-type]


@pytest.mark.slow
@pytest.mark.parametrize("executor", [None, make_executor, "process"])
def test_the_scheduler_refuses_what_is_not_an_executor(executor: object) -> None:
    # None and the make_executor function itself were accepted, and failed only at the first
    # submit (an audit of issue 9).
    with pytest.raises(TypeError, match="executor must be an Executor .* got") as info:
        Scheduler(executor, eval, max_active=1)  # type: ignore[arg-type]
    if executor is make_executor:
        assert "with make_executor(...) as executor" in str(info.value)


class _Returns:
    def __init__(self, first: object) -> None:
        self.first = first

    def start(self) -> object:
        return self.first

    def advance(self, outcomes: list[Outcome]) -> None:
        return None


@pytest.mark.slow
@pytest.mark.parametrize("first", [3, "abs(-1)", 2.5])
def test_a_job_whose_batch_is_not_a_list_of_items_is_named(first: object) -> None:
    # start() returning an int ended in "'int' object is not iterable", naming neither the job
    # nor what is allowed (an audit of issue 9).
    from benchmarks.execution import SerialExecutor

    with pytest.raises(TypeError, match=r"_Returns\.start\(\) must return a sequence of work "):
        Scheduler(SerialExecutor(), eval, max_active=1).run([_Returns(first)])


@pytest.mark.slow
def test_a_job_without_start_and_advance_is_named() -> None:
    from benchmarks.execution import SerialExecutor

    with pytest.raises(TypeError, match="a job must have start\\(\\) and advance"):
        Scheduler(SerialExecutor(), eval, max_active=1).run([object()])  # type: ignore[list-item]
