"""A suite on a real Dask cluster, started with Dask's own commands, stores the serial numbers.

The Dask executor's integration test (slow): ``perf/speed/dask_cluster.py`` starts ``dask
scheduler`` and two ``dask worker`` commands as separate processes (no ``LocalCluster``), runs a
tiny ``optimizers`` suite serially and on the cluster, and compares every stored number to the
last bit. The other tests check the pieces it
relies on: the comparison sees a one-ulp change, the workers' code check, and how many runs are
kept in flight on a cluster.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import os
import shutil
import subprocess
import sys
import time
from concurrent.futures import Future
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("distributed", reason="needs dask.distributed: pip install 'tooldesign[dask]'")

import benchmarks
from benchmarks.execution import Scheduler, dask_client
from benchmarks.execution.dask_client import (
    PLUGIN_NAME,
    WORKER_CODE,
    ClusterLost,
    IdentityCheck,
    _forward,
    check_workers,
    code_identity,
    differences,
    forget_check,
    tree_digest,
)
from benchmarks.execution.errors import ClusterMismatch
from benchmarks.suites import builtin_suite
from benchmarks.suites.runner import SuiteResult, _max_active, summary_text
from perf.speed import dask_cluster

#: The folder this test imported the project from (a checkout).
ROOT = Path(benchmarks.__file__).resolve().parents[1]



def _cluster_processes(marker: str) -> list[str]:
    """Command lines of the running processes that mention ``marker`` (a test's folder)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if marker in cmdline and "dask" in cmdline:
                found.append(cmdline)
    return found


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups and /proc")
def test_a_cluster_of_dask_commands_stores_the_serial_numbers_bit_for_bit(tmp_path):
    out = tmp_path / "runs"
    argv = [sys.executable, "-m", "perf.speed.dask_cluster", "--seeds", "1", "--iterations", "2"]
    result = subprocess.run(
        [*argv, "--batch-size", "2", "--workers", "2", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=ROOT,  # the script runs as a module from the repository's root (perf/ is not installed)
    )
    text = result.stdout + result.stderr
    assert result.returncode == 0, text
    assert "2 workers connected" in text
    assert "dask vs serial: identical" in text
    assert "cluster stopped, no process left" in text
    assert not _cluster_processes(str(out))
    # Both runs are whole: 4 optimizers x 1 seed x 2 iterations x 2 designs, and their designs.
    for label in ("serial", "dask"):
        manifest = json.loads((out / label / "manifest.json").read_text())
        assert manifest["config"]["executor"] == label
        assert manifest["extra"]["planned_evaluations"] == 16
        assert len(list((out / label / "designs").rglob("*.json"))) == 4
    # The cluster's own logs show both workers took part.
    logs = [(out / "cluster" / f"worker-{i}.log").read_text() for i in range(2)]
    assert all("Registered to" in log for log in logs)


def _write_run(
    folder: Path,
    free_energy: float,
    eval_time: float,
    *,
    commit: str = "aaaa",
    scene: dict[str, float] | None = None,
) -> None:
    (folder / "designs").mkdir(parents=True)
    record = {"free_energy": free_energy, "test_time": eval_time, "coefficients": [0.1, 0.2]}
    (folder / "designs" / "seed=1.json").write_text(json.dumps(record))
    (folder / "log.csv").write_text(
        f"free_energy,eval_time,opt_time\n{free_energy!r},{eval_time!r},{eval_time / 10!r}\n"
    )
    (folder / "report").mkdir()
    # The report's Markdown is the CSV's table for reading: not compared.
    (folder / "report" / "summary.md").write_text(f"made in {eval_time} s\n")
    config = {"executor": folder.name, "workers": 2, "iterations": 2, "scene": scene or {}}
    manifest = {
        "config": config,
        "wall_time": eval_time,
        "git_commit": commit,
        "git_dirty": False,
        "host": {"cpu_count": 2},
        "extra": {"evaluation_counts": {"ok": 1}, "sessions": [{"wall_time": eval_time}]},
    }
    (folder / "manifest.json").write_text(json.dumps(manifest))


def test_the_comparison_ignores_timings_and_where_it_ran_but_sees_one_ulp(tmp_path):
    value = 8999.691150647544
    _write_run(tmp_path / "serial", value, 1.5)
    _write_run(tmp_path / "dask", value, 2.5, commit="bbbb")  # a commit landed between the runs
    _write_run(tmp_path / "other", float(np.nextafter(value, math.inf)), 1.5)
    serial, dask, other = (
        dask_cluster.stored_numbers(tmp_path / name) for name in ("serial", "dask", "other")
    )
    assert dask_cluster.differences(serial, dask) == []
    found = dask_cluster.differences(serial, other)
    assert sorted(line.split(":")[0] for line in found) == ["designs/seed=1.json", "log.csv"]
    # The commit is a note, not a difference (an audit: a commit between the runs gave exit 1).
    notes = dask_cluster.provenance_notes(tmp_path / "serial", tmp_path / "dask")
    assert notes == ["git_commit: aaaa != bbbb"]


def test_the_comparison_drops_runtime_fields_by_name_not_every_key_with_time_in_it(tmp_path):
    # An audit: every key containing "time" was dropped, config fields such as the scene's
    # time_step and box_settle_time too; a change of them went unseen.
    for field in ("time_step", "box_settle_time"):
        _write_run(tmp_path / f"a-{field}", 1.0, 1.5, scene={field: 0.004})
        _write_run(tmp_path / f"b-{field}", 1.0, 1.5, scene={field: 0.002})
        found = dask_cluster.differences(
            dask_cluster.stored_numbers(tmp_path / f"a-{field}"),
            dask_cluster.stored_numbers(tmp_path / f"b-{field}"),
        )
        assert found == [f"manifest.json: .config.scene.{field}: 0.004 != 0.002"]


BAD_ARGUMENTS = [
    # The suite the script makes is checked before the cluster starts: each was a failure
    # inside distributed. (The argparse wording of its own flags is the script's business.)
    (["--batch-size", "1"], "optimizer 'cmaes': batch_size must be >= 2"),
    (["--seeds", "100000"], "n_seeds must be from 1 to 10000, got 100000"),
]


@pytest.mark.parametrize(("argv", "message"), BAD_ARGUMENTS)
def test_bad_arguments_are_refused_before_the_cluster_starts(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        dask_cluster.parse_args(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.slow
def test_good_arguments_make_the_suite_and_an_out_folder_must_be_new(tmp_path, capsys):
    args = dask_cluster.parse_args(["--size", "smoke", "--seeds", "3", "--port", "0"])
    assert (args.config.n_seeds, args.config.iterations, args.port) == (3, 2, 0)
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "run").mkdir()
    with pytest.raises(SystemExit):
        dask_cluster.parse_args(["--out", str(tmp_path / "old")])
    assert "is not an empty folder" in capsys.readouterr().err


def test_a_worker_with_other_code_refuses_and_closes_itself():
    closed = []
    loop = SimpleNamespace(add_callback=lambda fn, **kw: closed.append((fn, kw)))
    worker = SimpleNamespace(address="tcp://w:1", loop=loop, close=object())
    IdentityCheck(code_identity()).setup(worker)  # the same code: nothing happens
    assert closed == []
    other = {**code_identity(), "pybullet": "0.0.1"}
    with pytest.raises(RuntimeError, match=r"tcp://w:1 runs other code.*pybullet"):
        IdentityCheck(other).setup(worker)
    assert closed == [(worker.close, {"nanny": True, "reason": "tooldesign-code-identity"})]


def test_the_identity_names_the_sources_and_libraries():
    identity = code_identity()
    keys = ("python", "machine", "numpy", "pybullet", "source:tooldesign_env")
    for key in (*keys, "source:benchmarks.execution"):
        assert identity[key] not in ("", "not installed", "not importable"), key
    # The client's own code (CLI, reports, optimizers) is not the workers' business.
    assert not {"source:benchmarks", "source:optimizers"} & set(identity)
    assert differences(identity, dict(identity)) == []
    assert differences(identity, {**identity, "numpy": "1.0"}) == [
        f"numpy: client {identity['numpy']!r}, worker '1.0'"
    ]


def _copy_tree(target: Path) -> Path:
    """A copy of the project's packages (and perf/, as in a checkout), as another worker's."""
    ignore = shutil.ignore_patterns("__pycache__", "*.so")
    for package in ("benchmarks", "tooldesign_env", "optimizers", "perf"):
        shutil.copytree(ROOT / package, target / package, ignore=ignore)
    return target


def _append(path: Path, line: str) -> None:
    path.write_text(path.read_text() + line)


def test_the_identity_is_the_code_a_worker_runs_not_the_clients_own(tmp_path):
    # An audit: a comment in the CLI changed the digest of all of benchmarks/, and the client
    # was refused by (and shut down) a cluster that ran the same evaluation code.
    tree = _copy_tree(tmp_path)
    identity = code_identity()
    digests = {p: tree_digest(tree, p) for p in WORKER_CODE}
    assert digests == {p: identity[f"source:{p}"] for p in WORKER_CODE}  # as imported here
    for client_only in (
        "benchmarks/cli/bench.py",
        "benchmarks/reports/suite.py",
        "benchmarks/suites/runner.py",
        "perf/speed/dask_cluster.py",
        "optimizers/__init__.py",
    ):
        _append(tree / client_only, "# a comment\n")
    assert {p: tree_digest(tree, p) for p in WORKER_CODE} == digests
    # What a worker runs: the evaluator, the C control loop, the env, and benchmarks/__init__.py
    # (importing benchmarks.execution runs it).
    for worker_code, package in (
        ("benchmarks/execution/evaluator.py", "benchmarks.execution"),
        ("benchmarks/__init__.py", "benchmarks.execution"),
        ("tooldesign_env/native/control_loop.c", "tooldesign_env"),
        ("tooldesign_env/geometry/tool.py", "tooldesign_env"),
    ):
        before = tree_digest(tree, package)
        _append(tree / worker_code, "\n// a comment\n" if worker_code.endswith(".c") else "#\n")
        assert tree_digest(tree, package) != before, worker_code


_WORKER_IMPORTS = """
import json, sys
import benchmarks.execution.dask_client  # the plugin's module, unpickled on every worker
from benchmarks.execution import TaskSettings, evaluate_item
from benchmarks.execution.evaluator import EvaluationRequest, FinalTest
task = TaskSettings()
assert evaluate_item(EvaluationRequest(coeffs=(0.0, 0.0, 0.0), task=task))["status"] == "ok"
evaluate_item(FinalTest(coeffs=(0.0, 0.0, 0.0), task=task, masses=(0.5,), keep_paths=True))
print(json.dumps(sorted(sys.modules)))
"""


@pytest.mark.slow
def test_a_worker_imports_no_project_code_outside_the_identity():
    # A worker's tasks: a design (evaluate_item), a final test with masses; and the plugin.
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    result = subprocess.run(
        [sys.executable, "-c", _WORKER_IMPORTS],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    modules = json.loads(result.stdout.splitlines()[-1])
    project = [
        m for m in modules if m.split(".")[0] in ("benchmarks", "optimizers", "tooldesign_env")
    ]
    parents = {".".join(p.split(".")[:i]) for p in WORKER_CODE for i in range(1, p.count(".") + 1)}
    outside = [
        m
        for m in project
        if m not in parents and not any(m == p or m.startswith(p + ".") for p in WORKER_CODE)
    ]
    assert outside == [], "a worker imports code that code_identity does not cover"
    assert "tooldesign_env.simulation" in project  # it did simulate


class _FakeClient:
    """What check_workers and forget_check use of a Client, with the workers' answers given."""

    def __init__(self, reports: dict[str, Any]) -> None:
        self.id = f"client-{id(self)}"
        self.status = "running"
        self.reports = reports
        self.registered: list[str] = []
        self.unregistered: list[str] = []

    def run(self, function: Any, on_error: str) -> dict[str, Any]:
        assert function is code_identity and on_error == "return"
        return self.reports

    def register_plugin(self, plugin: Any, name: str) -> None:
        assert isinstance(plugin, IdentityCheck) and plugin.expected == code_identity()
        self.registered.append(name)

    def unregister_worker_plugin(self, name: str) -> None:
        self.unregistered.append(name)


def test_a_client_with_other_code_is_refused_and_the_cluster_is_left_alone():
    same = dict(code_identity())
    other = {**same, "source:benchmarks.execution": "0" * 16}
    client = _FakeClient(
        {
            "tcp://a:1": same,
            "tcp://b:1": other,
            "tcp://c:1": other,
            "tcp://d:1": ModuleNotFoundError("No module named 'benchmarks'"),
            "tcp://e:1": OSError("the worker died while asked"),  # gone: checked if it returns
        }
    )
    with pytest.raises(ClusterMismatch) as error:
        check_workers(client)  # type: ignore[arg-type]
    message = str(error.value)
    assert message.startswith("3 of the 5 workers of the Dask cluster run other code")
    assert "the cluster is left as it is" in message
    digest = same["source:benchmarks.execution"]
    assert (
        f"tcp://b:1, tcp://c:1: source:benchmarks.execution: client {digest!r}, "
        "worker '0000000000000000'"
    ) in message
    assert "tcp://d:1: cannot report its code (ModuleNotFoundError" in message
    assert "tcp://a:1" not in message and "tcp://e:1" not in message
    assert client.registered == []  # nothing was sent to the workers: none shuts down
    forget_check(client)  # type: ignore[arg-type]
    assert client.unregistered == []  # nor is another run's check removed


def test_a_cluster_of_the_same_code_gets_the_check_for_workers_that_join():
    client = _FakeClient({"tcp://a:1": dict(code_identity()), "tcp://b:1": dict(code_identity())})
    check_workers(client)  # type: ignore[arg-type]
    assert client.registered == [f"{PLUGIN_NAME}-{client.id}"]  # its own: another run keeps its
    other = _FakeClient({"tcp://a:1": dict(code_identity())})
    check_workers(other)  # type: ignore[arg-type]
    forget_check(client)  # type: ignore[arg-type]
    assert client.unregistered == [f"{PLUGIN_NAME}-{client.id}"]
    forget_check(other)  # type: ignore[arg-type]
    assert other.unregistered == [f"{PLUGIN_NAME}-{other.id}"]
    for each in (client, other):
        dask_client.end_quiet(each)  # type: ignore[arg-type]


def _write_identity_probe(tree: Path) -> None:
    """Change a comment of the evaluator: the copy's worker code differs from this process's."""
    _append(tree / "benchmarks" / "execution" / "evaluator.py", "# another commit\n")


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups and /proc")
def test_dask_workers_of_other_code_refuse_the_client_and_keep_running(tmp_path, monkeypatch):
    # The audit's case: a client whose code differed shut down every `dask worker` command.
    from distributed import Client

    tree = _copy_tree(tmp_path / "tree")
    _write_identity_probe(tree)
    native = ROOT / "tooldesign_env" / "native"
    for library in native.glob("*.so"):
        shutil.copy2(library, tree / "tooldesign_env" / "native")
    env = {**os.environ, "PYTHONPATH": str(tree)}
    monkeypatch.setattr(dask_cluster, "cluster_env", lambda: env)
    with dask_cluster.DaskCluster(workers=2, logs=tmp_path / "cluster") as cluster:
        cluster.wait_for_workers(120)
        with Client(cluster.address, timeout=60) as client:
            with pytest.raises(
                ClusterMismatch, match=r"2 of the 2 workers.*source:benchmarks\.execution"
            ):
                check_workers(client)
            forget_check(client)
            time.sleep(2)  # a worker that shuts itself down takes well under this
            assert len(client.nthreads()) == 2
        cluster._check_alive()  # every `dask worker` command still runs
        logs = [(cluster.logs / f"worker-{i}.log").read_text() for i in range(2)]
        assert not any(PLUGIN_NAME in log for log in logs)


def test_runs_in_flight_follow_the_clusters_workers_not_this_machines_cpus():
    cluster = SimpleNamespace(max_workers=32)
    config = builtin_suite("optimizers", "full").replace(executor="dask", scheduler="tcp://h:1")
    assert _max_active(config, cluster) == math.ceil(2 * 32 / 8) + 1
    assert _max_active(config.replace(workers=4), cluster) == 2  # --workers still decides
    local = config.replace(scheduler=None, workers=2)
    assert _max_active(local, cluster) == 2


def _forwarded(task: Future[object]) -> Future[object]:
    future: Future[object] = Future()
    _forward(future, task)
    return future


def test_a_cancelled_task_is_a_lost_cluster_not_a_failed_design():
    cancelled: Future[object] = Future()
    cancelled.cancel()
    assert isinstance(_forwarded(cancelled).exception(), ClusterLost)
    assert not issubclass(ClusterLost, Exception)  # no `except Exception` makes it a bad design
    done: Future[object] = Future()
    done.set_result({"free_energy": 1.0})
    assert _forwarded(done).result() == {"free_energy": 1.0}
    failed: Future[object] = Future()
    failed.set_exception(ValueError("the design raised"))
    assert isinstance(_forwarded(failed).exception(), ValueError)


def test_the_scheduler_stops_on_a_lost_cluster_and_tells_the_job_nothing():
    class Lost:
        def submit(self, fn, item):
            future: Future[object] = Future()
            future.set_exception(ClusterLost("gone"))
            return future

    class OneBatch:
        told: list[object] = []

        def start(self):
            return [1, 2]

        def advance(self, outcomes):
            self.told.append(outcomes)
            return None

    job = OneBatch()
    with pytest.raises(ClusterLost):
        Scheduler(Lost(), str, max_active=1).run([job])  # type: ignore[arg-type]
    assert job.told == []


def _record(error: BaseException | None) -> logging.LogRecord:
    exc_info = None if error is None else (type(error), error, None)
    return logging.LogRecord("distributed.client", logging.ERROR, __file__, 1, "", None, exc_info)


def test_the_clients_tracebacks_of_a_lost_scheduler_are_left_out_during_a_run():
    # An audit: ClusterLost's line came after ~50 lines of Dask's tracebacks of the lost comm.
    from distributed.comm.core import CommClosedError

    lost = [CommClosedError("in <TCP (closed) ConnectionPool.gather>"), asyncio.CancelledError()]
    client = _FakeClient({})
    check_workers(client)  # type: ignore[arg-type]
    other = _FakeClient({})  # a second run in this process, refused: adds no filter
    other.reports = {"tcp://x:1": ModuleNotFoundError("No module named 'benchmarks'")}
    with pytest.raises(ClusterMismatch):
        check_workers(other)  # type: ignore[arg-type]
    dask_client.end_quiet(other)  # type: ignore[arg-type]
    try:
        for name in dask_client._CLIENT_LOGGERS:
            logger = logging.getLogger(name)
            assert not any(logger.filter(_record(error)) for error in lost), name
            assert logger.filter(_record(ValueError("not a lost connection")))
            assert logger.filter(_record(None))  # "Failed to reconnect to scheduler after 30 s"
        forget_check(client)  # type: ignore[arg-type]
        # Until the client is closed, Dask's thread may still be logging as the run stops.
        assert not logging.getLogger("distributed.client").filter(_record(lost[1]))
    finally:
        dask_client.end_quiet(client)  # type: ignore[arg-type]
    for name in dask_client._CLIENT_LOGGERS:  # the run is over: nothing is left out any more
        assert logging.getLogger(name).filter(_record(lost[0])), name


@pytest.mark.parametrize(
    ("command", "module", "go_on"),
    [
        (["evaluate", "--coeffs", "0", "0", "0"], "evaluate", "nothing was stored: run the"),
        (["design"], "design", "stored; continue with the same command and --resume on a"),
        (["bench"], "bench", "stored; run the same command again: it resumes on a working"),
    ],
)
def test_a_lost_cluster_says_once_what_was_stored_and_how_to_go_on(
    monkeypatch, capsys, command, module, go_on
):
    # An audit: the command's line said it twice, once from ClusterLost and once of its own;
    # a review: it told every command to "rerun the same command", which design refuses.
    import importlib

    from benchmarks.cli import main

    cancelled: Future[object] = Future()
    cancelled.cancel()
    lost = _forwarded(cancelled).exception()
    assert isinstance(lost, ClusterLost)

    def fail(args: object) -> None:
        raise lost

    monkeypatch.setattr(importlib.import_module(f"benchmarks.cli.{module}"), "_run", fail)
    with pytest.raises(SystemExit) as exit_info:
        main([*command, "--out", "unused"])
    assert exit_info.value.code == 1
    err = capsys.readouterr().err
    assert "scheduler stopped or could not be reached" in err
    assert err.count("nothing") == 1
    assert go_on in err


def _suite_result(config: Any) -> SuiteResult:
    return SuiteResult(
        out_dir=Path("run"),
        config=config,
        evaluations=pd.DataFrame({"status": ["ok", "ok", "failed"]}),
        designs=[],
        wall_time=10.0,
        session_time=10.0,
        simulation_time=15.0,
        test_time=0.0,
        optimizer_time=0.1,
    )


def test_the_summary_names_the_cluster_not_this_machines_cpus():
    # An audit: a 1-worker cluster was summed up as "executor dask with 2 worker(s)", the CPUs
    # of the client's machine.
    config = builtin_suite("optimizers", "smoke").replace(
        executor="dask", scheduler="tcp://head:8786"
    )
    text = summary_text(_suite_result(config))
    assert "executor dask on the Dask cluster at tcp://head:8786" in text
    assert "worker(s)" not in text
    local = config.replace(scheduler=None, workers=3)  # a LocalCluster of 3 workers
    assert "executor dask with 3 worker(s)" in summary_text(_suite_result(local))


def test_a_run_removes_the_checks_of_clients_that_are_gone():
    # A client killed outright leaves its check on the scheduler; the next run removes it.
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False) as cluster:
        with Client(cluster) as client:
            stale = f"{PLUGIN_NAME}-Client-gone"
            client.register_plugin(IdentityCheck(code_identity()), name=stale)
            assert stale in cluster.scheduler.worker_plugins
            check_workers(client)
            try:
                names = set(cluster.scheduler.worker_plugins)
                assert stale not in names
                assert dask_client.plugin_name(client) in names  # its own
            finally:
                forget_check(client)
                dask_client.end_quiet(client)
            assert dask_client.plugin_name(client) not in cluster.scheduler.worker_plugins
