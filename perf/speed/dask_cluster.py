"""The optimizers suite on a Dask cluster started with Dask's own commands, against a local run.

In one run, this script:

1. starts a cluster as separate processes with Dask's command line, on this machine's loopback
   address: ``dask scheduler --port P`` and ``--workers`` (default 2) times
   ``dask worker tcp://127.0.0.1:P --nworkers 1 --nthreads 1``, and waits until every worker
   is connected;
2. runs the ``optimizers`` suite with ``tooldesign bench`` (as ``python -m benchmarks``) once
   with each local executor of ``--local`` (default ``serial``) and once with ``--executor dask
   --scheduler tcp://127.0.0.1:P``, each into its own run folder under ``--out``;
3. compares what the runs stored to the last bit: the rows of the evaluation log and of its
   parts, the design files, the report's tables (CSV) and the manifest's config and counts,
   leaving out only the fields that record times, checksums of files that hold times, the
   machine and the code's provenance, each by its exact name (:data:`ROW_TIMES`,
   :data:`MANIFEST_RUNTIME`, :data:`EXTRA_RUNTIME` and the suite's ``RUNTIME_FIELDS``); a
   difference in the git commit, the packages or the host is printed as a note, not counted;
4. prints the wall times side by side with the load average before and after each run, and the
   speed-up of the cluster over the first local run; and, before and after everything, how
   much parallelism the machine gives ``--workers`` CPU-bound processes (a busy machine is not
   a slow cluster).

The cluster is shut down whatever happens (an error, Ctrl-C, SIGTERM): each Dask command runs in
its own process group, which is sent SIGTERM, then SIGKILL; the script checks that no process of
those groups is left. The cluster's processes also die with this script if it is killed
(``PR_SET_PDEATHSIG`` on Linux; a worker whose scheduler is gone exits after
``--death-timeout``).

The cluster's processes get a ``PYTHONPATH`` that starts with the folder this script imported
the project from, so that they run the same code as the client (the executor checks that, see
:mod:`benchmarks.execution.dask_client`).

Run (a few minutes; ``--size full`` is the paper's suite, about 4,800 evaluations)::

    python -m perf.speed.dask_cluster [--size reduced|smoke|full] [--seeds N]
        [--iterations N] [--batch-size N] [--workers 2] [--local serial [--local process]]
        [--out DIR] [--port P] [--timeout S]

Every argument is checked before anything starts (a bad one is an argparse error naming it,
exit code 2), including the suite it makes: its seeds, iterations and batch size must be ones
``tooldesign bench`` accepts for each optimizer.

Exit code: 0 if every run stored the same numbers, 1 if they differ, 2 if an argument is bad, a
run or the cluster failed or a process of the cluster was left behind. Linux only (process
groups, ``/proc``).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import IO, Any

import pandas as pd

import benchmarks
from benchmarks.execution import WORKERS_MAX
from benchmarks.execution._parent_death import die_with_parent
from benchmarks.suites import (
    RUNTIME_FIELDS,
    SuiteConfig,
    builtin_suite,
    check_optimizers,
    save_suite,
)
from perf import _args

#: Sizes of the optimizers suite: ``reduced`` (default) takes a few minutes on 2 cores.
SIZES: dict[str, dict[str, int]] = {
    "smoke": {"n_seeds": 2, "iterations": 2, "batch_size": 4},
    "reduced": {"n_seeds": 4, "iterations": 4, "batch_size": 8},
    "full": {"n_seeds": 10, "iterations": 15, "batch_size": 8},
}

#: Columns of the evaluation log, its parts and the report's tables, and keys of a design file,
#: that hold times (s): the only values of the results that may differ between executors.
ROW_TIMES: frozenset[str] = frozenset({"eval_time", "opt_time", "test_time"})

#: Top-level keys of ``manifest.json`` that say when, where and from which code the run was made,
#: not what it found: its times, the host, the packages' versions and the git commit (a commit
#: may land between two runs of this script).
MANIFEST_RUNTIME: frozenset[str] = frozenset(
    {
        "start_time",
        "end_time",
        "wall_time",
        "simulation_time",
        "optimizer_time",
        "host",
        "packages",
        "git_commit",
        "git_dirty",
    }
)

#: Keys of the manifest's ``extra`` of the same kind: checksums of files that hold times, the
#: sessions' times, the final tests' time and the machine's load.
EXTRA_RUNTIME: frozenset[str] = frozenset(
    {"file_sha256", "part_sha256", "sessions", "test_time", "load_average_at_end"}
)

#: Manifest keys whose difference is printed as a note: the runs should come from one code.
PROVENANCE: tuple[str, ...] = ("git_commit", "git_dirty", "packages")


_DASK = [sys.executable, "-m", "dask"]


# --- the cluster -------------------------------------------------------------------------------


def project_root() -> Path:
    """The folder the project's packages were imported from (the cluster imports them there)."""
    return Path(benchmarks.__file__).resolve().parents[1]


def cluster_env() -> dict[str, str]:
    """This process's environment with the project's folder first on ``PYTHONPATH``."""
    env = dict(os.environ)
    paths = [str(project_root()), *filter(None, env.get("PYTHONPATH", "").split(os.pathsep))]
    env["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
    return env


@dataclass
class DaskCluster:
    """A scheduler and workers started with Dask's own commands, as separate process groups.

    Use as a context manager: the scheduler is started and, once it listens, the workers;
    every process is stopped on exit, whatever happened.

    Attributes:
        workers: Number of ``dask worker`` commands (one single-threaded worker each).
        logs: Folder of the commands' output (``scheduler.log``, ``worker-<i>.log``).
        port: The scheduler's TCP port on 127.0.0.1; 0 lets the scheduler choose a free one
            (a port picked here could be taken before the scheduler binds it).
        death_timeout: s a worker waits for a lost scheduler before it exits.
        timeout: s to wait for the scheduler to listen.
    """

    workers: int
    logs: Path
    port: int = 0
    death_timeout: float = 60.0
    timeout: float = 60.0
    address: str = ""
    processes: list[tuple[str, subprocess.Popen[bytes]]] = field(default_factory=list)
    _files: list[IO[bytes]] = field(default_factory=list)

    def scheduler_command(self) -> list[str]:
        """``dask scheduler``'s argv (``python -m dask`` is the ``dask`` command of this Python)."""
        return [
            *_DASK,
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            str(self.port),
            "--no-dashboard",
            "--dashboard-address",
            "127.0.0.1:0",  # its HTTP routes (health, metrics) stay on loopback too
            "--scheduler-file",
            str(self.logs / "scheduler.json"),
        ]

    def worker_command(self) -> list[str]:
        """``dask worker``'s argv, once the scheduler's address is known."""
        return [
            *_DASK,
            "worker",
            self.address,
            "--nworkers",
            "1",
            "--nthreads",
            "1",
            "--host",
            "127.0.0.1",
            "--no-dashboard",
            "--death-timeout",
            f"{self.death_timeout:g}",
            "--local-directory",
            str(self.logs),
        ]

    def __enter__(self) -> DaskCluster:
        return self.start()

    def start(self) -> DaskCluster:
        """Start the scheduler, wait until it listens, then start the workers.

        Raises:
            RuntimeError: The scheduler exited or did not listen within ``timeout``.
        """
        self.logs.mkdir(parents=True, exist_ok=True)
        (self.logs / "scheduler.json").unlink(missing_ok=True)
        try:
            self._start("scheduler", self.scheduler_command())
            self.address = self._scheduler_address()
            for i in range(self.workers):
                self._start(f"worker-{i}", self.worker_command())
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _start(self, name: str, argv: list[str]) -> None:
        print(f"$ dask {' '.join(argv[len(_DASK) :])}", flush=True)
        log = (self.logs / f"{name}.log").open("wb")
        self._files.append(log)
        process = subprocess.Popen(
            argv,
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            env=cluster_env(),
            # `python -m` puts the working folder first on sys.path: not a checkout, so that the
            # cluster imports the project from PYTHONPATH as this script did.
            cwd=self.logs,
            start_new_session=True,  # its own process group, stopped as one
            # In the child before exec: if this script is SIGKILLed, the kernel kills the Dask
            # command too (the request survives exec).
            preexec_fn=die_with_parent,
        )
        self.processes.append((name, process))

    def _scheduler_address(self) -> str:
        path = self.logs / "scheduler.json"
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            self._check_alive()
            with contextlib.suppress(OSError, ValueError, KeyError):
                return str(json.loads(path.read_text())["address"])
            time.sleep(0.2)
        raise RuntimeError(f"the scheduler did not start in {self.timeout:g} s; see {self.logs}")

    def wait_for_workers(self, timeout: float) -> float:
        """Wait until every worker is connected to the scheduler; the seconds it took.

        Raises:
            RuntimeError: A Dask command exited, or the workers did not connect in time.
        """
        from distributed import Client

        start = time.monotonic()
        with Client(self.address, timeout=timeout) as client:
            while len(client.nthreads()) < self.workers:
                self._check_alive()
                if time.monotonic() - start > timeout:
                    raise RuntimeError(
                        f"{self.workers} workers did not connect to {self.address} within "
                        f"{timeout:g} s; see the logs in {self.logs}"
                    )
                time.sleep(0.2)
        return time.monotonic() - start

    def _check_alive(self) -> None:
        for name, process in self.processes:
            if process.poll() is not None:
                raise RuntimeError(
                    f"dask {name} exited with code {process.returncode}; see "
                    f"{self.logs / (name + '.log')}"
                )

    def stop(self, grace: float = 10.0) -> list[int]:
        """Stop the workers, then the scheduler: SIGTERM to each group, SIGKILL after ``grace`` s.

        Workers go first, so that none of them logs a lost scheduler.

        Returns:
            PIDs still alive afterwards (empty when the cluster is gone).
        """
        workers = [p.pid for name, p in self.processes if name != "scheduler"]
        scheduler = [p.pid for name, p in self.processes if name == "scheduler"]
        for groups in (workers, scheduler):
            for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, 5.0)):
                for group in groups:
                    with contextlib.suppress(ProcessLookupError, PermissionError):
                        os.killpg(group, sig)
                deadline = time.monotonic() + wait
                while _alive_groups(groups) and time.monotonic() < deadline:
                    for _, process in self.processes:
                        process.poll()  # reap the group leaders
                    time.sleep(0.1)
                if not _alive_groups(groups):
                    break
        for _, process in self.processes:
            with contextlib.suppress(subprocess.TimeoutExpired):
                process.wait(timeout=1)
        for log in self._files:
            log.close()
        self._files.clear()
        self.processes.clear()
        return _alive_groups(workers + scheduler)


def _alive_groups(groups: list[int]) -> list[int]:
    """PIDs of the processes, not zombies, in any of the process groups ``groups``."""
    alive = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        state, pgid = fields[0], int(fields[2])
        if pgid in groups and state != "Z":
            alive.append(int(entry.name))
    return alive


# --- the runs ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Run:
    """One ``tooldesign bench`` run and its times.

    Attributes:
        label: ``serial``, ``process`` or ``dask``.
        folder: Its run folder.
        command: s, wall time of the command (imports, the suite, the report).
        suite: s, the suite's wall time from its manifest (the suite only).
        load_before: 1-minute load average before the run.
        load_after: 1-minute load average after it.
    """

    label: str
    folder: Path
    command: float
    suite: float
    load_before: float
    load_after: float


def run_bench(label: str, suite_file: Path, out: Path, options: list[str]) -> Run:
    """Run the suite of ``suite_file`` with ``tooldesign bench`` into ``out / label``.

    Raises:
        RuntimeError: The command failed; its output is in ``out / (label + '.log')``.
    """
    folder = out / label
    argv = [sys.executable, "-m", "benchmarks", "--config", str(suite_file), "--out", str(folder)]
    argv += [*options, "--no-progress"]
    print(f"$ {' '.join(argv[1:])}", flush=True)
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    with (out / f"{label}.log").open("wb") as log:
        code = subprocess.run(
            argv,
            stdout=log,
            stderr=subprocess.STDOUT,
            env=cluster_env(),
            cwd=out,
            preexec_fn=die_with_parent,  # a SIGKILLed script leaves no run going on
        ).returncode
    seconds = time.perf_counter() - start
    if code != 0:
        raise RuntimeError(f"{label} run failed (exit {code}); see {out / (label + '.log')}")
    manifest = json.loads((folder / "manifest.json").read_text())
    return Run(
        label, folder, seconds, float(manifest["wall_time"]), load_before, os.getloadavg()[0]
    )


_SPIN = "t = 0\nfor i in range(4_000_000):\n    t += i * i"


def parallelism(processes: int) -> float:
    """Speed-up of ``processes`` CPU-bound loops run at once over the same loops one by one.

    About ``processes`` on an idle machine with that many cores; lower while other work holds
    the cores. No executor can beat it, so it is printed next to the speed-ups.
    """
    argv = [sys.executable, "-c", _SPIN]
    start = time.perf_counter()
    for _ in range(processes):
        subprocess.run(argv, check=True)
    alone = time.perf_counter() - start
    start = time.perf_counter()
    for process in [subprocess.Popen(argv) for _ in range(processes)]:
        process.wait()
    return alone / (time.perf_counter() - start)


# --- the comparison ----------------------------------------------------------------------------


def _exact(value: Any, drop: frozenset[str] = frozenset()) -> Any:
    """Floats as their ``repr`` (bit for bit), containers recursively, keys in ``drop`` left out."""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, dict):
        return {k: _exact(v, drop) for k, v in sorted(value.items()) if str(k) not in drop}
    if isinstance(value, list | tuple):
        return [_exact(v, drop) for v in value]
    return value


def _frame(frame: pd.DataFrame) -> list[dict[str, Any]]:
    frame = frame[[c for c in frame.columns if str(c) not in ROW_TIMES]]
    rows = [_exact(row) for row in frame.to_dict("records")]
    return sorted(rows, key=lambda r: json.dumps(r, sort_keys=True, default=str))


def _manifest(data: dict[str, Any]) -> dict[str, Any]:
    """The manifest without the fields of how, when and where the run was made.

    Those are :data:`MANIFEST_RUNTIME`, :data:`EXTRA_RUNTIME` and the config's
    ``RUNTIME_FIELDS`` (executor, workers, scheduler, retries), each by its exact name and place.
    """
    kept = {k: v for k, v in data.items() if k not in MANIFEST_RUNTIME}
    if isinstance(kept.get("config"), dict):
        kept["config"] = {k: v for k, v in kept["config"].items() if k not in RUNTIME_FIELDS}
    if isinstance(kept.get("extra"), dict):
        kept["extra"] = {k: v for k, v in kept["extra"].items() if k not in EXTRA_RUNTIME}
    return dict(_exact(kept))


def stored_numbers(folder: Path) -> dict[str, Any]:
    """What a run folder stores of its results, by file, with its times and run settings left out.

    CSV files are read as text (the digits as written), Parquet and JSON files with floats as
    their ``repr``. The report's Markdown holds the same tables as its CSV files, written for
    reading, and is not compared; nor are images and logs.
    """
    out: dict[str, Any] = {}
    for path in sorted(folder.rglob("*")):
        name = path.relative_to(folder).as_posix()
        if path.suffix == ".csv":
            out[name] = _frame(pd.read_csv(path, dtype=str, keep_default_na=False))
        elif path.suffix == ".parquet":
            out[name] = _frame(pd.read_parquet(path))
        elif path.suffix == ".json":
            data = json.loads(path.read_text())
            if path.name == "manifest.json" and isinstance(data, dict):
                out[name] = _manifest(data)
            else:
                out[name] = _exact(data, ROW_TIMES)
    return out


def provenance_notes(a: Path, b: Path) -> list[str]:
    """Where the manifests of two run folders differ in :data:`PROVENANCE`.

    Not a difference of results (a commit may land between the runs), but worth a line.
    """
    manifests = [json.loads((folder / "manifest.json").read_text()) for folder in (a, b)]
    return [
        f"{key}: {str(manifests[0].get(key))[:80]} != {str(manifests[1].get(key))[:80]}"
        for key in PROVENANCE
        if manifests[0].get(key) != manifests[1].get(key)
    ]


def count_values(value: Any) -> int:
    """Leaf values (numbers and strings) in a :func:`stored_numbers` structure."""
    if isinstance(value, dict):
        return sum(count_values(v) for v in value.values())
    if isinstance(value, list):
        return sum(count_values(v) for v in value)
    return 1


def differences(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    """The files whose stored numbers differ between two run folders (or exist in one only)."""
    found = [f"{name}: only in one run" for name in sorted(set(a) ^ set(b))]
    for name in sorted(set(a) & set(b)):
        if a[name] != b[name]:
            found.append(f"{name}: {_first_difference(a[name], b[name])}")
    return found


def _first_difference(a: Any, b: Any, where: str = "") -> str:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if a.get(key) != b.get(key):
                return _first_difference(a.get(key), b.get(key), f"{where}.{key}")
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            if x != y:
                return _first_difference(x, y, f"{where}[{i}]")
    return f"{where or 'value'}: {str(a)[:80]} != {str(b)[:80]}"


# --- main --------------------------------------------------------------------------------------


def suite_config(args: argparse.Namespace) -> SuiteConfig:
    """The optimizers suite at the chosen size."""
    size = dict(SIZES[args.size])
    for key, value in (("n_seeds", args.seeds), ("iterations", args.iterations)):
        if value is not None:
            size[key] = value
    if args.batch_size is not None:
        size["batch_size"] = args.batch_size
    return builtin_suite("optimizers", "full").replace(**size)


def _stop_on_sigterm(signum: int, frame: FrameType | None) -> None:
    raise SystemExit(f"stopped by signal {signum}")


def _print_machine(when: str, workers: int) -> None:
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    print(
        f"{when}: load average (1, 5, 15 min) {load}; {workers} CPU-bound processes run at once "
        f"{parallelism(workers):.2f}x as fast as one by one"
    )


def _print_table(runs: list[Run], cluster_start: float, workers: int) -> None:
    base = runs[0]
    head = f"{'run':<8} {'suite wall':>11} {'command wall':>13} {'speed-up':>9}"
    print(f"\n{head}  load before/after")
    for run in runs:
        speed = base.suite / run.suite if run.suite > 0 else math.nan
        print(
            f"{run.label:<8} {run.suite:>9.1f} s {run.command:>11.1f} s {speed:>8.2f}x  "
            f"{run.load_before:.2f} / {run.load_after:.2f}"
        )
    print(
        f"speed-up = {base.label} suite wall / suite wall; the cluster ({workers} workers) took "
        f"{cluster_start:.1f} s to start (not in its times); CPUs here: {os.cpu_count()}"
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked before a process is started.

    A bad value, or a suite that ``tooldesign bench`` would refuse, is an argparse error that
    names it (exit code 2).
    """
    doc = __doc__ or ""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--size", choices=tuple(SIZES), default="reduced")
    parser.add_argument("--seeds", type=_args.count(1), default=None, help="overrides --size")
    parser.add_argument("--iterations", type=_args.count(1), default=None, help="overrides --size")
    parser.add_argument("--batch-size", type=_args.count(1), default=None, help="overrides --size")
    parser.add_argument(
        "--workers",
        type=_args.count(1, WORKERS_MAX),
        default=2,
        help="dask worker commands (default 2)",
    )
    parser.add_argument(
        "--local",
        action="append",
        choices=("serial", "process"),
        default=None,
        help="local executor(s) to compare with (default serial; process uses --workers)",
    )
    parser.add_argument("--out", type=Path, default=None, help="folder of the runs (new)")
    parser.add_argument(
        "--port",
        type=_args.count(0, 65535),
        default=0,
        help="scheduler port on 127.0.0.1 (default 0: any free one)",
    )
    parser.add_argument(
        "--timeout",
        type=_args.number(0.0, 86400.0, above=True, unit="s"),
        default=120.0,
        help="s to wait for the workers (default 120)",
    )
    args = parser.parse_args(argv)
    check_suite_args(parser, args)
    return args


def check_suite_args(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Make ``args.config``, the suite the arguments ask for, or refuse them through ``parser``.

    Also refuses an ``--out`` that is not a new or empty folder (the runs need new folders).
    """
    try:
        args.config = suite_config(args)
        check_optimizers(args.config)  # e.g. CMA-ES needs a batch of 2 or more
    except (TypeError, ValueError) as err:
        parser.error(f"the suite of --size {args.size}, --seeds, --iterations, --batch-size: {err}")
    if args.out is not None:
        out = args.out.resolve()
        if out.exists() and (not out.is_dir() or any(out.iterdir())):
            parser.error(f"--out {out} is not an empty folder; the runs need new folders")


def main(argv: list[str] | None = None) -> int:
    """Measure, compare and print; the exit code says whether the runs agree."""
    args = parse_args(argv)
    if importlib.util.find_spec("distributed") is None:
        print("error: this needs dask.distributed: pip install 'tooldesign[dask]'", file=sys.stderr)
        return 2
    config: SuiteConfig = args.config
    local = args.local or ["serial"]
    out = (args.out or Path(tempfile.mkdtemp(prefix="tooldesign-dask-"))).resolve()
    out.mkdir(parents=True, exist_ok=True)
    suite_file = save_suite(config, out / "suite.toml")
    signal.signal(signal.SIGTERM, _stop_on_sigterm)

    print(
        f"optimizers suite: {config.n_seeds} seeds x {len(config.optimizers)} optimizers x "
        f"{config.iterations} iterations x batch {config.batch_size} = {config.evaluations()} "
        f"evaluations; runs in {out}"
    )
    _print_machine("before", args.workers)
    runs: list[Run] = []
    cluster = DaskCluster(workers=args.workers, logs=out / "cluster", port=args.port)
    started = 0.0
    try:
        cluster.start()
        started = cluster.wait_for_workers(args.timeout)
        print(f"{args.workers} workers connected to {cluster.address} in {started:.1f} s")
        for label in local:
            options = ["--executor", label]
            if label == "process":
                options += ["--workers", str(args.workers)]
            runs.append(run_bench(label, suite_file, out, options))
        runs.append(run_bench("dask", suite_file, out, ["--scheduler", cluster.address]))
    except (RuntimeError, OSError, subprocess.SubprocessError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    finally:
        left = cluster.stop()  # whatever happened: an error, Ctrl-C, SIGTERM
        print("cluster stopped, no process left" if not left else f"LEFT BEHIND: {left}")
    if left:
        return 2

    stored = {run.label: stored_numbers(run.folder) for run in runs}
    base = runs[0].label
    different = False
    for run in runs[1:]:
        found = differences(stored[base], stored[run.label])
        count = sum(count_values(v) for v in stored[base].values())
        if found:
            different = True
            print(f"\n{run.label} vs {base}: DIFFERENT in {len(found)} file(s):")
            print("\n".join(f"  {line}" for line in found[:20]))
        else:
            print(
                f"\n{run.label} vs {base}: identical, {count} stored values in "
                f"{len(stored[base])} files (times and provenance aside), bit for bit"
            )
        for note in provenance_notes(runs[0].folder, run.folder):
            print(f"note: {run.label} vs {base}: the runs' {note} (not compared)")
    _print_table(runs, started, args.workers)
    _print_machine("after", args.workers)
    return 1 if different else 0


if __name__ == "__main__":
    sys.exit(main())
