"""A suite on a real Dask cluster, started with Dask's own commands, stores the serial numbers.

``benchmarks/perf/dask_cluster.py`` starts ``dask scheduler`` and two ``dask worker`` commands
as separate processes (no ``LocalCluster``), runs a tiny ``optimizers`` suite serially and on the
cluster, and compares every stored number to the last bit. The other tests check the pieces it
relies on: the comparison sees a one-ulp change, the workers' code check, and how many runs are
kept in flight on a cluster.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from concurrent.futures import Future
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("distributed", reason="needs dask.distributed: pip install 'tooldesign[dask]'")

from benchmarks.execution import Scheduler
from benchmarks.execution.dask_client import (
    ClusterLost,
    IdentityCheck,
    _forward,
    code_identity,
    differences,
)
from benchmarks.perf import dask_cluster
from benchmarks.suites import builtin_suite
from benchmarks.suites.runner import _max_active

SCRIPT = Path(dask_cluster.__file__)


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
    argv = [sys.executable, str(SCRIPT), "--seeds", "1", "--iterations", "2", "--batch-size", "2"]
    result = subprocess.run(
        [*argv, "--workers", "2", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=900,
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


def _write_run(folder: Path, free_energy: float, eval_time: float) -> None:
    (folder / "designs").mkdir(parents=True)
    record = {"free_energy": free_energy, "test_time": eval_time, "coefficients": [0.1, 0.2]}
    (folder / "designs" / "seed=1.json").write_text(json.dumps(record))
    (folder / "log.csv").write_text(f"free_energy,eval_time\n{free_energy!r},{eval_time!r}\n")
    manifest = {"config": {"executor": folder.name, "iterations": 2}, "wall_time": eval_time}
    (folder / "manifest.json").write_text(json.dumps(manifest))


def test_the_comparison_ignores_timings_and_where_it_ran_but_sees_one_ulp(tmp_path):
    value = 8999.691150647544
    _write_run(tmp_path / "serial", value, 1.5)
    _write_run(tmp_path / "dask", value, 2.5)
    _write_run(tmp_path / "other", float(np.nextafter(value, math.inf)), 1.5)
    serial, dask, other = (
        dask_cluster.stored_numbers(tmp_path / name) for name in ("serial", "dask", "other")
    )
    assert dask_cluster.differences(serial, dask) == []
    found = dask_cluster.differences(serial, other)
    assert sorted(line.split(":")[0] for line in found) == ["designs/seed=1.json", "log.csv"]


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
    for key in ("python", "machine", "numpy", "pybullet", "source:tooldesign_env"):
        assert identity[key] not in ("", "not installed", "not importable"), key
    assert differences(identity, dict(identity)) == []
    assert differences(identity, {**identity, "numpy": "1.0"}) == [
        f"numpy: client {identity['numpy']!r}, worker '1.0'"
    ]


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
