"""Evaluations per second of the optimizers suite: serial, a process pool and a Dask cluster.

Issue 31, item 4. In one run, on this machine (2 cores for the issue's figure):

1. starts a Dask cluster with Dask's own commands on loopback, ``dask scheduler`` and
   ``--workers`` (default 2) ``dask worker --nworkers 1 --nthreads 1`` processes
   (``dask_cluster.DaskCluster``, which also stops it, whatever happens);
2. runs the ``optimizers`` suite (``--size full`` is the paper's, 4,800 evaluations; or a fixed
   slice of it: ``--size reduced`` or ``smoke``, or ``--seeds``, ``--iterations``,
   ``--batch-size``) with ``tooldesign bench`` three times, each into its own run folder:
   ``--executor serial`` (one process), ``--executor process --workers W`` (the pool) and
   ``--scheduler tcp://127.0.0.1:P`` (the cluster);
3. prints, per run, the suite's wall time from its manifest, its evaluations per second
   (evaluations in the suite / suite wall time) and its speed-up over the serial run; the pool's
   speed-up at W workers is the issue's target (>= 1.85x at 2); and, before and after, how fast
   W CPU-bound processes run at once here (the machine's own parallelism, which bounds every
   speed-up: on a shared machine it is below W).

``dask_cluster.py`` runs the same suite on the same kind of cluster and checks that every stored
number is the same bit for bit; this script measures only the throughput.

Run::

    python -m perf.speed.suite_throughput [--size full|reduced|smoke] [--workers 2]
        [--seeds N] [--iterations N] [--batch-size N] [--out DIR]

Exit code 0, or 2 if an argument is bad, a run or the cluster failed, or a process of the
cluster was left behind. Linux only (as ``dask_cluster.py``).
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from benchmarks.execution import WORKERS_MAX
from benchmarks.suites import SuiteConfig, save_suite
from perf import _args
from perf.speed import dask_cluster  # the cluster, the runs and the suite's sizes
from perf.speed.dask_cluster import DaskCluster, Run, run_bench


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked before a process is started (a bad value: exit code 2)."""
    doc = __doc__ or ""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--size", choices=tuple(dask_cluster.SIZES), default="full")
    parser.add_argument("--seeds", type=_args.count(1), default=None, help="overrides --size")
    parser.add_argument("--iterations", type=_args.count(1), default=None, help="overrides --size")
    parser.add_argument("--batch-size", type=_args.count(1), default=None, help="overrides --size")
    parser.add_argument(
        "--workers",
        type=_args.count(2, WORKERS_MAX),
        default=2,
        help="pool workers and dask worker commands (default 2)",
    )
    parser.add_argument("--out", type=Path, default=None, help="folder of the runs (new)")
    parser.add_argument(
        "--timeout",
        type=_args.number(0.0, 86400.0, above=True, unit="s"),
        default=120.0,
        help="s to wait for the workers (default 120)",
    )
    args = parser.parse_args(argv)
    dask_cluster.check_suite_args(parser, args)
    return args


def _stop_on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit(f"stopped by signal {signum}")


def main(argv: list[str] | None = None) -> int:
    """Run the suite three ways and print the throughput."""
    args = parse_args(argv)
    if importlib.util.find_spec("distributed") is None:
        print("error: this needs dask.distributed: pip install 'tooldesign[dask]'", file=sys.stderr)
        return 2
    config: SuiteConfig = args.config
    evaluations = config.evaluations()
    out = (args.out or Path(tempfile.mkdtemp(prefix="tooldesign-throughput-"))).resolve()
    out.mkdir(parents=True, exist_ok=True)
    suite_file = save_suite(config, out / "suite.toml")
    signal.signal(signal.SIGTERM, _stop_on_sigterm)
    print(
        f"optimizers suite: {config.n_seeds} seeds x {len(config.optimizers)} optimizers x "
        f"{config.iterations} iterations x batch {config.batch_size} = {evaluations} "
        f"evaluations; {args.workers} workers; CPUs here: {os.cpu_count()}; runs in {out}"
    )
    dask_cluster._print_machine("before", args.workers)
    runs: list[Run] = []
    cluster = DaskCluster(workers=args.workers, logs=out / "cluster", port=0)
    started = 0.0
    try:
        cluster.start()
        started = cluster.wait_for_workers(args.timeout)
        print(f"{args.workers} dask workers connected to {cluster.address} in {started:.1f} s")
        runs.append(run_bench("serial", suite_file, out, ["--executor", "serial"]))
        pool = ["--executor", "process", "--workers", str(args.workers)]
        runs.append(run_bench("process", suite_file, out, pool))
        runs.append(run_bench("dask", suite_file, out, ["--scheduler", cluster.address]))
    except (RuntimeError, OSError, subprocess.SubprocessError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    finally:
        left = cluster.stop()
        print("cluster stopped, no process left" if not left else f"LEFT BEHIND: {left}")
    if left:
        return 2
    serial = runs[0].suite
    head = f"{'run':<8} {'suite wall':>11} {'evaluations/s':>14} {'speed-up':>9}  load before/after"
    print(f"\n{head}")
    for run in runs:
        rate = evaluations / run.suite if run.suite > 0 else math.nan
        speed = serial / run.suite if run.suite > 0 else math.nan
        print(
            f"{run.label:<8} {run.suite:>9.1f} s {rate:>14.2f} {speed:>8.2f}x  "
            f"{run.load_before:.2f} / {run.load_after:.2f}"
        )
    pool_speed = serial / runs[1].suite if runs[1].suite > 0 else math.nan
    print(
        f"the pool's speed-up at {args.workers} workers: {pool_speed:.2f}x (issue 31: >= 1.85x "
        f"at 2); suite wall = the manifest's, without imports and the report; the cluster took "
        f"{started:.1f} s to start (not in its times)"
    )
    dask_cluster._print_machine("after", args.workers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
