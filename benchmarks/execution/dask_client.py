"""What the Dask executor adds to a client so that results do not depend on where they ran.

- **The same code on every worker.** A suite's results do not depend on where a design was
  evaluated only if every worker simulates it with the same code: the same
  ``tooldesign_env``/``optimizers``/``benchmarks`` sources, the same NumPy, SciPy, PyBullet,
  Gymnasium and trimesh, the same Python and machine type. On a cluster nothing enforces that:
  a worker may have another release installed, or an editable install of another checkout.
  :class:`IdentityCheck` is a worker plugin that compares the worker's :func:`code_identity`
  with the client's; :func:`check_workers` registers it when the executor connects. A worker
  that differs makes the run fail at once with a message that names it and what differs, and
  shuts itself down (its log says why), also when it joins while a run is going on, so it never
  evaluates a design.
- **A lost cluster stops the run.** When the scheduler goes away, Dask cancels every task in
  flight. A cancelled task is not an outcome of its design: logged as a failed evaluation, it
  would be told to the optimizer and kept on resume, and the run would differ from an
  uninterrupted one. :class:`DaskExecutor` turns the cancellation into :class:`ClusterLost`,
  which ends the run with nothing of the unfinished batches logged; the same command resumes it.

This module needs ``dask.distributed`` (``pip install 'tooldesign[dask]'``); the executor
imports it only for ``--executor dask``.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import importlib.util
import platform
from collections.abc import Callable
from concurrent.futures import Executor, Future
from pathlib import Path
from typing import Any

from distributed import Client, WorkerPlugin

from benchmarks.execution.errors import ClusterLost, ClusterMismatch

__all__ = [
    "PLUGIN_NAME",
    "ClusterLost",
    "DaskExecutor",
    "IdentityCheck",
    "check_workers",
    "code_identity",
    "differences",
    "forget_check",
]

#: The project's packages whose sources a worker must share with the client.
PACKAGES: tuple[str, ...] = ("tooldesign_env", "optimizers", "benchmarks")

#: The libraries a worker's evaluation runs on (distribution names).
LIBRARIES: tuple[str, ...] = ("numpy", "scipy", "pybullet", "gymnasium", "trimesh")

#: Name of the plugin on the scheduler; registering again replaces it.
PLUGIN_NAME = "tooldesign-code-identity"


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def _source_digest(package: str) -> str:
    """SHA-256 of a package's modules: every ``.py`` file of its regular (sub)packages.

    Folders without ``__init__.py`` (scripts such as ``benchmarks/perf``) are not part of an
    installed wheel, so they are left out: a wheel and an editable install of the same commit
    give the same digest.
    """
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return "not importable"
    root = Path(next(iter(spec.submodule_search_locations)))
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        relative = path.relative_to(root)
        folders = [root.joinpath(*relative.parts[:i]) for i in range(len(relative.parts))]
        if "__pycache__" in relative.parts or not all(
            (folder / "__init__.py").is_file() for folder in folders
        ):
            continue
        digest.update(relative.as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


@functools.cache
def code_identity() -> dict[str, str]:
    """What this process's evaluations depend on, besides their inputs.

    Returns:
        ``python`` (major.minor), ``machine`` (e.g. ``x86_64``), the installed ``tooldesign``
        version, the version of each of :data:`LIBRARIES`, and ``source:<package>``: a SHA-256
        of each of :data:`PACKAGES` as imported here.
    """
    identity = {
        "python": ".".join(platform.python_version_tuple()[:2]),
        "machine": platform.machine(),
        "tooldesign": _version("tooldesign"),
    }
    identity.update({name: _version(name) for name in LIBRARIES})
    identity.update({f"source:{p}": _source_digest(p) for p in PACKAGES})
    return identity


def differences(expected: dict[str, str], found: dict[str, str]) -> list[str]:
    """``"name: expected X, found Y"`` for every entry that differs."""
    keys = sorted(set(expected) | set(found))
    return [
        f"{key}: client {expected.get(key)!r}, worker {found.get(key)!r}"
        for key in keys
        if expected.get(key) != found.get(key)
    ]


class IdentityCheck(WorkerPlugin):
    """A worker plugin: the worker's :func:`code_identity` must equal the client's.

    Args:
        expected: The client's :func:`code_identity`.
    """

    def __init__(self, expected: dict[str, str]) -> None:
        self.expected = dict(expected)

    def setup(self, worker: Any) -> None:
        """Raise, and close the worker, if it runs other code or libraries than the client.

        A worker that joins while a run is going on is not seen by the client; Dask only logs
        the plugin's error and would go on to give it designs to evaluate, so the worker closes
        itself (and its nanny, so that it is not restarted).

        Raises:
            RuntimeError: Naming the worker and every difference.
        """
        found = differences(self.expected, code_identity())
        if found:
            worker.loop.add_callback(worker.close, nanny=True, reason=PLUGIN_NAME)
            raise RuntimeError(
                f"Dask worker {getattr(worker, 'address', '?')} runs other code than the client, "
                f"so its results could differ; it is shut down: {'; '.join(found)}. Install the "
                "same tooldesign release and libraries on every worker (see docs/performance.md)"
            )


def check_workers(client: Client) -> None:
    """Make every worker of ``client``'s cluster, present and future, run the client's code.

    Args:
        client: A connected client.

    Raises:
        ClusterMismatch: A connected worker differs (or cannot import this project at all).
    """
    try:
        client.register_plugin(IdentityCheck(code_identity()), name=PLUGIN_NAME)
    except OSError:
        # A worker died while the check was sent to it (CommClosedError is an OSError). The
        # scheduler keeps the plugin, so a restarted worker is checked when it registers.
        pass
    except Exception as err:  # the worker's error, sent back by the scheduler
        raise ClusterMismatch(
            f"a worker of the Dask cluster cannot evaluate designs for this process: {err} "
            "(every worker needs the same tooldesign and libraries as this machine)"
        ) from err


def forget_check(client: Client) -> None:
    """Remove the check from the cluster (the next client registers its own)."""
    try:
        client.unregister_worker_plugin(PLUGIN_NAME)
    except Exception:  # the scheduler may be gone already; nothing is left to undo then
        pass


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
            ClusterLost(
                "the Dask cluster was lost while designs were being evaluated (its scheduler "
                "stopped or could not be reached): nothing of the unfinished batches was "
                "logged; run the same command again to resume"
            )
        )
    elif (exc := task.exception()) is not None:
        future.set_exception(exc)
    else:
        future.set_result(task.result())
