"""What the Dask executor adds to a client so that results do not depend on where they ran.

- **The same code on every worker.** A suite's results do not depend on where a design was
  evaluated only if every worker simulates it with the same code: the same worker code
  (:data:`WORKER_CODE`: ``tooldesign_env`` and ``benchmarks.execution``, all a worker imports
  to evaluate a design), the same NumPy, SciPy, PyBullet, Gymnasium and trimesh, the same Python
  and machine type. On a cluster nothing enforces that: a worker may have another release
  installed, or an editable install of another checkout. :func:`check_workers` asks every
  connected worker for its :func:`code_identity` when the executor connects: if one differs,
  the client is refused with :class:`ClusterMismatch` (naming the workers and what differs) and
  the cluster is left as it is, since the workers may be right and the client wrong. Otherwise
  it registers :class:`IdentityCheck`, a worker plugin for the workers that join during the run:
  one that differs shuts itself down (its log says why) before it evaluates a design.
- **A lost cluster stops the run.** When the scheduler goes away, Dask cancels every task in
  flight. A cancelled task is not an outcome of its design: logged as a failed evaluation, it
  would be told to the optimizer and kept on resume, and the run would differ from an
  uninterrupted one. :class:`DaskExecutor` turns the cancellation into :class:`ClusterLost`,
  which ends the run with nothing of the unfinished batches logged; the same command resumes it.
  From the check on, the client's tracebacks of the lost connection (Dask logs one per call in
  flight) are left out of the log: :class:`ClusterLost` says what happened.

- **An unreachable scheduler is refused soon.** :func:`connect` gives up after
  :data:`CONNECT_TIMEOUT` s (Dask's own default, 30 s plus retries, kept a dead address waiting
  34-40 s), naming the address; ``TOOLDESIGN_DASK_CONNECT_TIMEOUT`` (seconds) or the
  ``connect_timeout`` of :func:`benchmarks.execution.make_executor` sets another.

This module needs ``dask.distributed`` (``pip install 'tooldesign[dask]'``); the executor
imports it only for ``--executor dask``.
"""

from __future__ import annotations

import asyncio
import functools
import hashlib
import importlib.metadata
import importlib.util
import logging
import math
import os
import platform
from collections.abc import Callable
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

from distributed import Client, WorkerPlugin

from benchmarks.execution.errors import ClusterLost, ClusterMismatch

__all__ = [
    "PLUGIN_NAME",
    "WORKER_CODE",
    "ClusterLost",
    "DaskExecutor",
    "IdentityCheck",
    "CONNECT_TIMEOUT",
    "CONNECT_TIMEOUT_ENV",
    "check_workers",
    "code_identity",
    "connect",
    "connect_timeout",
    "differences",
    "end_quiet",
    "forget_check",
    "plugin_name",
    "quiet_lost_connections",
    "tree_digest",
]

#: The project's code a worker runs to evaluate a design: the packages its tasks import
#: (``tests/test_dask_cluster.py`` checks that a worker imports nothing else of the project).
#: ``optimizers`` and the rest of ``benchmarks`` (command line, reports, suites, RL) run in the
#: client only, so a change there does not make a worker's results differ.
WORKER_CODE: tuple[str, ...] = ("tooldesign_env", "benchmarks.execution")

#: The files of :data:`WORKER_CODE` that are code: Python modules and the C control loop's
#: source (both are in a wheel, so a wheel and a checkout of one commit give the same digest).
SOURCE_SUFFIXES: tuple[str, ...] = (".py", ".c")

#: The libraries a worker's evaluation runs on (distribution names).
LIBRARIES: tuple[str, ...] = ("numpy", "scipy", "pybullet", "gymnasium", "trimesh")

#: Name of the plugin on the scheduler; registering again replaces it.
PLUGIN_NAME = "tooldesign-code-identity"

#: Seconds a client waits for the scheduler at ``--scheduler ADDRESS`` before it refuses it: an
#: unreachable address is refused within 10 s with the start-up (8.4 s in all on an idle 2-core
#: machine; a wait of 8 s made it 10.8 s), while a scheduler across a slow network still has
#: time to answer.
CONNECT_TIMEOUT = 5.0

#: The environment variable that sets another :data:`CONNECT_TIMEOUT` (seconds).
CONNECT_TIMEOUT_ENV = "TOOLDESIGN_DASK_CONNECT_TIMEOUT"

#: Workers named in full in a refusal; the rest are counted.
_NAMED_WORKERS = 3

# Ids of the clients whose check is registered: only they remove it (a refused client must not
# remove the check of another client's run on the same cluster).
_REGISTERED: set[str] = set()


def connect_timeout(value: float | None = None) -> float:
    """The seconds to wait for a scheduler: ``value``, else the environment's, else the default.

    Args:
        value: Seconds, or None for ``$TOOLDESIGN_DASK_CONNECT_TIMEOUT`` or
            :data:`CONNECT_TIMEOUT`.

    Raises:
        ValueError: The value (or the variable) is not a positive finite number of seconds.
    """
    where = "connect_timeout"
    if value is None:
        text = os.environ.get(CONNECT_TIMEOUT_ENV)
        if text is None or not text.strip():
            return CONNECT_TIMEOUT
        where = f"${CONNECT_TIMEOUT_ENV}"
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"{where} must be a number of seconds > 0, got {text!r}") from None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where} must be a number of seconds > 0, got {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{where} must be a finite number of seconds > 0, got {value!r}")
    return float(value)


def connect(scheduler: str, timeout: float | None = None) -> Client:
    """A client of the scheduler at ``scheduler``, or an ``OSError`` naming it after ``timeout``.

    Args:
        scheduler: The scheduler's address, e.g. ``tcp://host:8786``.
        timeout: Seconds to wait (:func:`connect_timeout`).

    Raises:
        ValueError: A bad address or timeout.
        OSError: Nothing answered at the address within the timeout.
    """
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ValueError(f"scheduler must be an address like tcp://host:8786, got {scheduler!r}")
    seconds = connect_timeout(timeout)
    try:
        return Client(scheduler, timeout=seconds)
    except OSError as err:  # distributed's "Timed out trying to connect to ..."
        raise OSError(
            f"no Dask scheduler answers at {scheduler} (gave up after {seconds:g} s; "
            f"${CONNECT_TIMEOUT_ENV} sets the wait): start a scheduler with `dask scheduler` "
            "or check the address"
        ) from err


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _source_digest(package: str) -> str:
    """:func:`tree_digest` of ``package`` where this process imports it from."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return "not importable"
    root = Path(next(iter(spec.submodule_search_locations)))
    return tree_digest(root.parents[package.count(".")], package)


def tree_digest(top: Path, package: str) -> str:
    """SHA-256 (first 16 hex digits) of a package's code in the folder ``top``.

    The code is every file of :data:`SOURCE_SUFFIXES` in the package's regular (sub)packages,
    and the ``__init__.py`` of each package it is part of (importing it runs them), each named by
    its path from ``top``. Folders without ``__init__.py`` are not part of an installed wheel, so
    they are left out: a wheel and a checkout of the same commit give the same digest.

    Args:
        top: The folder that holds the top package (a checkout, or ``site-packages``).
        package: Dotted name, e.g. ``"benchmarks.execution"``.
    """
    names = package.split(".")
    root = top.joinpath(*names)
    files = [top.joinpath(*names[:i], "__init__.py") for i in range(1, len(names))]
    for path in root.rglob("*"):
        relative = path.relative_to(root)
        folders = [root.joinpath(*relative.parts[:i]) for i in range(len(relative.parts))]
        if (
            path.suffix in SOURCE_SUFFIXES
            and path.is_file()
            and "__pycache__" not in relative.parts
            and all((folder / "__init__.py").is_file() for folder in folders)
        ):
            files.append(path)
    digest = hashlib.sha256()
    for name, path in sorted((path.relative_to(top).as_posix(), path) for path in files):
        digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


@functools.cache
def code_identity() -> dict[str, str]:
    """What this process's evaluations depend on, besides their inputs.

    Returns:
        ``python`` (major.minor), ``machine`` (e.g. ``x86_64``), the installed ``tooldesign``
        version, the version of each of :data:`LIBRARIES`, and ``source:<package>``: a digest
        of the code of each of :data:`WORKER_CODE` as imported here.
    """
    identity = {
        "python": ".".join(platform.python_version_tuple()[:2]),
        "machine": platform.machine(),
        "tooldesign": _version("tooldesign"),
    }
    identity.update({name: _version(name) for name in LIBRARIES})
    identity.update({f"source:{p}": _source_digest(p) for p in WORKER_CODE})
    return identity


def differences(expected: dict[str, str], found: dict[str, str]) -> list[str]:
    """``"name: client X, worker Y"`` for every entry that differs."""
    keys = sorted(set(expected) | set(found))
    return [
        f"{key}: client {expected.get(key)!r}, worker {found.get(key)!r}"
        for key in keys
        if expected.get(key) != found.get(key)
    ]


class IdentityCheck(WorkerPlugin):
    """A worker plugin: a worker that joins a run must have the client's :func:`code_identity`.

    Registered by :func:`check_workers` once every connected worker has been found equal to the
    client, so it acts on the workers that join during the run.

    Args:
        expected: The client's :func:`code_identity`.
    """

    def __init__(self, expected: dict[str, str]) -> None:
        self.expected = dict(expected)

    def setup(self, worker: Any) -> None:
        """Raise, and close the worker, if it runs other code or libraries than the client.

        Dask only logs a plugin's error and would go on to give the worker designs to evaluate,
        so the worker closes itself (and its nanny, so that it is not restarted).

        Raises:
            RuntimeError: Naming the worker and every difference.
        """
        found = differences(self.expected, code_identity())
        if found:
            worker.loop.add_callback(worker.close, nanny=True, reason=PLUGIN_NAME)
            raise RuntimeError(
                f"Dask worker {getattr(worker, 'address', '?')} runs other code than the run "
                f"it joined, so its results could differ; it shuts down: {'; '.join(found)}. "
                "Install the run's commit and libraries on it (see 'Running on a Dask "
                "cluster' in docs/performance.md)"
            )


def _refusal(workers: int, found: dict[str, list[str]]) -> str:
    """The message that refuses a client: which workers differ, and how."""
    groups: dict[tuple[str, ...], list[str]] = {}
    for address, lines in found.items():
        groups.setdefault(tuple(lines), []).append(address)
    parts = []
    for same, addresses in groups.items():
        named = ", ".join(addresses[:_NAMED_WORKERS])
        if len(addresses) > _NAMED_WORKERS:
            named += f" and {len(addresses) - _NAMED_WORKERS} more"
        parts.append(f"{named}: {'; '.join(same)}")
    return (
        f"{len(found)} of the {workers} workers of the Dask cluster run other code or "
        "libraries than this process, so where a design ran could change its result; this "
        f"run is refused and the cluster is left as it is. {' | '.join(parts)}. Run tooldesign "
        "from the workers' commit, with their Python and libraries, or install this commit on "
        "every worker (see 'Running on a Dask cluster' in docs/performance.md)"
    )


def check_workers(client: Client) -> None:
    """Refuse a cluster whose workers run other code; check the workers that join later.

    Every connected worker reports its :func:`code_identity`. If one differs from this
    process's, nothing is changed on the cluster and the client is refused; otherwise
    :class:`IdentityCheck` is registered, so that a worker that joins during the run and
    differs shuts itself down before it evaluates anything.

    Args:
        client: A connected client.

    Raises:
        ClusterMismatch: A connected worker differs (or cannot import this project at all);
            every worker keeps running.
    """
    expected = code_identity()
    reports = client.run(code_identity, on_error="return")
    found: dict[str, list[str]] = {}
    for address, report in sorted(reports.items()):
        if isinstance(report, OSError):
            # It died while asked (CommClosedError is an OSError); the scheduler keeps the
            # plugin registered below, so it is checked when it comes back.
            continue
        if isinstance(report, BaseException):
            found[address] = [
                f"cannot report its code ({type(report).__name__}: {report}); is this project "
                "installed there?"
            ]
        elif lines := differences(expected, dict(report)):
            found[address] = lines
    if found:
        raise ClusterMismatch(_refusal(len(reports), found))
    _forget_stale_checks(client)
    _REGISTERED.add(str(client.id))
    quiet_lost_connections(client)
    try:
        client.register_plugin(IdentityCheck(expected), name=plugin_name(client))
    except OSError:
        # A worker died while the check was sent to it (CommClosedError is an OSError). The
        # scheduler keeps the plugin, so a restarted worker is checked when it registers.
        pass
    except Exception as err:  # a worker that joined since it was asked, and differs
        raise ClusterMismatch(
            f"a worker joined the Dask cluster while it was checked and runs other code than "
            f"this process: {err}"
        ) from err


def plugin_name(client: Client) -> str:
    """The name of ``client``'s check on the cluster: two runs on one cluster have two."""
    return f"{PLUGIN_NAME}-{client.id}"


def _forget_stale_checks(client: Client) -> None:
    """Remove the checks of runs whose client is gone (killed outright, a lost machine).

    Best effort: a scheduler that cannot be asked keeps them (they shut down a joining worker
    of other code, which is safe).
    """
    prefix = f"{PLUGIN_NAME}-"

    def stale(dask_scheduler: Any) -> list[str]:  # runs on the scheduler, sent by value
        clients = set(dask_scheduler.clients)
        return [
            name
            for name in dask_scheduler.worker_plugins
            if name.startswith(prefix) and name[len(prefix) :] not in clients
        ]

    try:
        for name in client.run_on_scheduler(stale):
            client.unregister_worker_plugin(name)
    except Exception:  # noqa: BLE001 - only a cleanup of other runs' leftovers
        pass


def forget_check(client: Client) -> None:
    """Remove ``client``'s check from the cluster, if it registered one.

    The next run registers its own; a refused client leaves the check of another run alone.
    """
    if str(client.id) not in _REGISTERED:
        return
    _REGISTERED.discard(str(client.id))
    try:
        client.unregister_worker_plugin(plugin_name(client))
    except Exception:  # the scheduler may be gone already; nothing is left to undo then
        pass


class _LostConnection(logging.Filter):
    """Drops the client's tracebacks of a lost connection to the scheduler.

    Dask logs one for each call in flight when the scheduler goes away (a closed comm, a
    cancelled coroutine); the run then stops with :class:`ClusterLost`, which says what
    happened. Records without such a traceback, e.g. "Failed to reconnect to scheduler after
    30.00 seconds, closing client", are kept.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        return not isinstance(error, (OSError, asyncio.CancelledError))


_FILTER = _LostConnection()

#: Where Dask logs them: its client, its comms, and tornado's errors of the client's event
#: loop (``distributed.cfexecutor`` runs each call's result there).
_CLIENT_LOGGERS: tuple[str, ...] = (
    "distributed.client",
    "distributed.core",
    "distributed.utils",
    "tornado.application",
)


#: The clients whose runs keep Dask's tracebacks of a lost connection out; the filter is on
#: while this holds any.
_QUIETED: set[str] = set()


def quiet_lost_connections(client: Client) -> None:
    """Leave out Dask's tracebacks of a lost connection while ``client`` runs.

    Undone by :func:`end_quiet`, after the client is closed: while the run stops after a lost
    scheduler, Dask's event-loop thread may still be logging the calls it cancels.
    """
    if not _QUIETED:
        for name in _CLIENT_LOGGERS:
            logging.getLogger(name).addFilter(_FILTER)
    _QUIETED.add(str(client.id))


def end_quiet(client: Client) -> None:
    """Undo :func:`quiet_lost_connections` for ``client``; the filter goes with the last one."""
    if str(client.id) not in _QUIETED:
        return
    _QUIETED.discard(str(client.id))
    if not _QUIETED:
        for name in _CLIENT_LOGGERS:
            logging.getLogger(name).removeFilter(_FILTER)


class DaskExecutor(Executor):
    """A Dask client's executor: cancelled tasks raise :class:`ClusterLost`; knows its workers.

    Args:
        client: A connected client; closed by its owner, not here.
    """

    def __init__(self, client: Client) -> None:
        self._client = client
        # pure=False: two equal designs are two evaluations (each timed), not one cached task.
        self._executor = client.get_executor(pure=False)

    @property
    def max_workers(self) -> int:
        """Worker threads of the cluster now (workers may join or leave during a run)."""
        return int(sum(self._client.nthreads().values()))

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Submit ``fn(*args, **kwargs)`` as a task of the cluster."""
        task = self._executor.submit(fn, *args, **kwargs)
        future: Future[Any] = Future()
        task.add_done_callback(functools.partial(_forward, future))
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop accepting calls."""
        self._executor.shutdown(wait=wait)


def _forward(future: Future[Any], task: Future[Any]) -> None:
    """Give ``future`` the outcome of the cluster's ``task``."""
    if task.cancelled():
        future.set_exception(
            # Only what happened: the caller says what it means for the run (the command line:
            # nothing of the unfinished batches stored, rerun to resume).
            ClusterLost(
                "the Dask scheduler stopped or could not be reached while designs were being "
                "evaluated"
            )
        )
    elif (exc := task.exception()) is not None:
        future.set_exception(exc)
    else:
        future.set_result(task.result())
