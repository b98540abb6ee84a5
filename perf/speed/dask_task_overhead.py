"""The Dask scheduler's overhead per task, from no-op tasks on a loopback cluster.

Issue 31, item 5: what a cluster adds to every evaluation, the figure the scaling estimate of
``docs/performance.md`` ("Past one machine, on paper") rests on. In one run, this script starts
a cluster with Dask's own commands on 127.0.0.1 (``dask scheduler`` and ``--workers`` single-
threaded ``dask worker`` processes: ``dask_cluster.DaskCluster``, which also stops it whatever
happens), then, from a client:

* **throughput**: submits ``--tasks`` no-op tasks at once through the client's
  ``concurrent.futures`` executor (``Client.get_executor().submit``, what the suites'
  ``DaskExecutor`` does, one task per evaluation) and waits for all; the wall time over the
  tasks is the scheduler's cost per task when it is the only work (the workers do nothing);
* **latency**: submits ``--sequential`` no-op tasks one after another, each after the last one's
  result came back: the round trip client -> scheduler -> worker -> scheduler -> client that
  a task that waits for its predecessor pays (an ask/tell optimizer's batch boundary).

Each is repeated ``--repeats`` times; the medians are printed, with the load average, since
on a shared machine the figures are upper bounds.

Run::

    python -m perf.speed.dask_task_overhead [--workers 2] [--tasks 2000]
        [--sequential 200] [--repeats 3]

Exit code 0, or 2 if an argument is bad, the cluster failed or a process was left behind.
Linux only (as ``dask_cluster.py``).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.execution import WORKERS_MAX
from perf import _args
from perf.speed.dask_cluster import DaskCluster  # the cluster as separate processes


def noop(x: int) -> int:
    """The task: returns its argument, so the result travels back as an evaluation's would."""
    return x


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked (a bad value is an argparse error naming it, exit code 2)."""
    doc = __doc__ or ""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument(
        "--workers", type=_args.count(1, WORKERS_MAX), default=2, help="dask workers (default 2)"
    )
    parser.add_argument(
        "--tasks",
        type=_args.count(10),
        default=2000,
        help="no-op tasks submitted at once (default 2000)",
    )
    parser.add_argument(
        "--sequential",
        type=_args.count(1),
        default=200,
        help="no-op tasks one after another (default 200)",
    )
    parser.add_argument("--repeats", type=_args.count(1), default=3, help="(default 3)")
    parser.add_argument(
        "--timeout",
        type=_args.number(0.0, 86400.0, above=True, unit="s"),
        default=120.0,
        help="s to wait for the workers (default 120)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Measure and print."""
    args = parse_args(argv)
    if importlib.util.find_spec("distributed") is None:
        print("error: this needs dask.distributed: pip install 'tooldesign[dask]'", file=sys.stderr)
        return 2
    from distributed import Client

    logs = Path(tempfile.mkdtemp(prefix="tooldesign-dask-overhead-"))
    cluster = DaskCluster(workers=args.workers, logs=logs, port=0)
    burst: list[float] = []
    trip: list[float] = []
    load_before = os.getloadavg()[0]
    try:
        cluster.start()
        started = cluster.wait_for_workers(args.timeout)
        print(f"{args.workers} workers connected to {cluster.address} in {started:.1f} s")
        with Client(cluster.address, timeout=args.timeout) as client:
            executor = client.get_executor(pure=False)
            executor.submit(noop, -1).result()  # warm: the function is sent once
            for _ in range(args.repeats):
                start = time.perf_counter()
                futures = [executor.submit(noop, i) for i in range(args.tasks)]
                for future in futures:
                    future.result()
                burst.append((time.perf_counter() - start) / args.tasks)
                start = time.perf_counter()
                for i in range(args.sequential):
                    executor.submit(noop, i).result()
                trip.append((time.perf_counter() - start) / args.sequential)
    except (RuntimeError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    finally:
        left = cluster.stop()
        print("cluster stopped, no process left" if not left else f"LEFT BEHIND: {left}")
    if left:
        return 2
    med = statistics.median
    print(
        f"throughput: {args.tasks} no-op tasks at once on {args.workers} workers: median "
        f"{1e3 * med(burst):.3f} ms per task ({1 / med(burst):.0f} tasks/s; runs: "
        + ", ".join(f"{1e3 * v:.3f}" for v in burst)
        + " ms)"
    )
    print(
        f"latency: {args.sequential} no-op tasks one after another: median "
        f"{1e3 * med(trip):.3f} ms per round trip (runs: "
        + ", ".join(f"{1e3 * v:.3f}" for v in trip)
        + " ms)"
    )
    print(
        f"load average before {load_before:.2f}, after {os.getloadavg()[0]:.2f}; CPUs here: "
        f"{os.cpu_count()} (the scheduler, the client and the workers share them)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
