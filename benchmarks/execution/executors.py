"""Executors: where a batch of work items runs, serially, on a local process pool or on Dask.

The designer of Algorithm 1 asks for a batch of tools; each tool is simulated and scored
independently, so a batch is spread over workers through a :class:`concurrent.futures.Executor`:

- ``"serial"``: :class:`SerialExecutor`, in the calling process (debugging, tiny runs, tests);
- ``"process"`` (default): a local :class:`~concurrent.futures.ProcessPoolExecutor` whose workers
  are started with ``forkserver`` (or ``spawn`` where there is none), never ``fork``: a forked
  PyBullet client shares its parent's physics server and breaks;
- ``"dask"``: a ``dask.distributed`` cluster, a :class:`~distributed.LocalCluster` or the
  scheduler at ``--scheduler ADDRESS`` (``pip install 'tooldesign[dask]'``).

This module knows nothing of tools: the work function is a parameter
(:func:`map_robust`), and :mod:`benchmarks.execution.evaluator` supplies the one that simulates a
design.

A worker process that dies (``BrokenProcessPool``) takes its pool down, and with it every item in
flight, whose worker it was or not: the pool cannot say which item killed it. The pool is
restarted and :func:`run_alone` runs each lost item again, alone, so the item that kills its
worker is found and the others get their own results. An item whose worker dies while it runs
alone is run again, alone in a fresh pool, up to ``max_retries`` times (default 0: the
simulation is deterministic, so a design that kills its worker kills it again; retries help when
something outside, such as the kernel's out-of-memory killer, killed it), then its outcome is a
:class:`WorkerDied` error and the run goes on. ``max_retries`` is set where the executor is made
(:func:`make_executor`) and applies to the local process pool only: a Dask scheduler retries a
task whose worker died by itself (its ``distributed.scheduler.allowed-failures`` setting).

A worker of the process pool does not inherit how its parent writes warnings
(:data:`warnings.formatwarning`). If the parent's format has a string ``line_prefix`` attribute
when the pool is made (the command line's one-line format, ``PREFIX: warning: MESSAGE``, has),
each worker writes its warnings as that same line; otherwise in Python's format. Dask workers
keep Python's format.
"""

from __future__ import annotations

import ast
import contextlib
import functools
import multiprocessing
import os
import signal
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, NamedTuple

import numpy as np

from benchmarks.execution._parent_death import die_with_parent
from benchmarks.execution._stale_ipc import remove_stale_ipc

#: Largest ``max_retries``: each retry starts a fresh pool and evaluates the item again.
MAX_RETRIES_MAX = 100

#: Most worker processes: a mistyped count (10^6) would start that many processes.
WORKERS_MAX = 1024


def check_max_retries(value: Any) -> int:
    """``value`` as a number of retries after a worker death: an int from 0 to 100.

    Raises:
        TypeError: If it is not an int (booleans and strings are refused).
        ValueError: If it is negative or above :data:`MAX_RETRIES_MAX`.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(
            f"max_retries must be an int from 0 to {MAX_RETRIES_MAX}, "
            f"got {type(value).__name__} {value!r}"
        )
    if not 0 <= value <= MAX_RETRIES_MAX:
        raise ValueError(f"max_retries must be from 0 to {MAX_RETRIES_MAX}, got {value}")
    return int(value)


class WorkerDied(BrokenProcessPool):
    """The worker process of an item died each time the item ran alone, retries included.

    Attributes:
        runs: How many times the item ran alone (``1 + max_retries``).
    """

    def __init__(self, runs: int) -> None:
        retries = runs - 1
        super().__init__(
            f"the worker process died on each of {runs} run(s) of this item alone in a fresh "
            f"pool ({retries} retr{'y' if retries == 1 else 'ies'}, max_retries={retries})"
        )
        self.runs = runs


class Outcome(NamedTuple):
    """What became of one work item.

    Attributes:
        result: What the work function returned (``None`` if it raised).
        error: The exception it raised, or that killed its worker; ``None`` on success.
        seconds: Wall time from the batch's submission until this outcome was known.
    """

    result: Any
    error: BaseException | None
    seconds: float


EXECUTORS: tuple[str, ...] = ("serial", "process", "dask")

"""Executor kinds accepted by :func:`make_executor`."""


_DASK_EXTRA = "pip install 'tooldesign[dask]'"


class SerialExecutor(Executor):
    """An executor that runs each call at once in the calling thread.

    Exceptions are stored in the returned future, as a pool would, so callers handle every
    executor the same way.
    """

    def __init__(self) -> None:
        self._shutdown = False

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Run ``fn(*args, **kwargs)`` now and return its finished future."""
        if self._shutdown:
            raise RuntimeError("cannot schedule new futures after shutdown")
        future: Future[Any] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # KeyboardInterrupt is not stored: it stops the run
            future.set_exception(exc)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Refuse further calls."""
        self._shutdown = True


class _RestartingProcessPool(Executor):
    """A process pool that replaces itself after a worker died, so the run can go on.

    Args:
        workers: Worker processes.
        context: The multiprocessing context (forkserver or spawn).
        max_retries: Further runs of an item whose worker died while it ran alone (see
            :func:`run_alone`).
        warning_prefix: Workers write each warning as one ``PREFIX: warning: MESSAGE`` line;
            ``None``: in Python's format.
    """

    def __init__(
        self,
        workers: int,
        context: Any,
        max_retries: int = 0,
        warning_prefix: str | None = None,
    ) -> None:
        self._workers = workers
        self._context = context
        self.max_retries = check_max_retries(max_retries)
        self._warning_prefix = warning_prefix
        self._pool = self._new_pool()

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self._workers,
            mp_context=self._context,
            initializer=_init_worker,
            initargs=(self._warning_prefix,),
        )

    @property
    def max_workers(self) -> int:
        """Number of worker processes."""
        return self._workers

    def restart(self) -> None:
        """Drop the current pool (broken or not) and start a fresh one."""
        _stop_leftover_workers(self._pool)
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._new_pool()

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Submit to the pool, restarting it first if a worker died since the last call."""
        try:
            return self._pool.submit(fn, *args, **kwargs)
        except BrokenProcessPool:
            self.restart()
            return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Shut the pool down."""
        _stop_leftover_workers(self._pool)
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)


def _stop_leftover_workers(pool: ProcessPoolExecutor) -> None:
    """Terminate the worker processes a broken pool still has, so that its threads can end.

    A broken pool terminates its workers itself, but CPython 3.11's pool can start one more
    worker in a ``submit`` that races with the breakage; that worker waits on the call queue
    forever, the pool's management thread waits to join it, and the interpreter, which joins
    that thread at exit, never exits (seen once at the end of a test session). Workers of a
    broken pool hold no work that can still be delivered, so stopping them loses nothing. Call
    it before ``shutdown``, which drops the pool's list of processes.
    """
    if not getattr(pool, "_broken", False):
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.terminate()


def _ignore_sigint() -> None:
    # Ctrl-C reaches the whole process group. Workers ignore it and finish their evaluation;
    # the main process stops the run and shuts the pool down, so no half-told batch is logged.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _init_worker(warning_prefix: str | None = None) -> None:
    _ignore_sigint()
    die_with_parent()
    if warning_prefix is not None:
        warnings.formatwarning = functools.partial(_warning_line, warning_prefix)


def _parent_warning_prefix() -> str | None:
    """The ``line_prefix`` of this process's warning format, or None if it has none.

    Read by attribute, so that this module imports nothing of the command line (whose
    ``warnings_as_lines`` installs such a format).
    """
    prefix = getattr(warnings.formatwarning, "line_prefix", None)
    return prefix if isinstance(prefix, str) else None


def _warning_line(
    prefix: str,
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    line: str | None = None,
) -> str:
    """A worker's warning as one line, as the command line writes it in the parent."""
    return f"{prefix}: warning: {message}\n"


def _process_context() -> Any:
    # What an earlier pool killed with its process group left in /dev/shm and the temporary
    # folder (its resource tracker died with it) goes before this pool adds its own.
    remove_stale_ipc()
    # forkserver forks workers from a clean server process that never made a PyBullet client
    # (and is faster to start than spawn); plain fork would copy the parent's client.
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    if hasattr(context, "set_forkserver_preload"):
        # The forkserver imports this module first, which makes it die with the main process:
        # a SIGKILLed run would otherwise leave the server and its workers running.
        context.set_forkserver_preload(["__main__", "benchmarks.execution._forkserver_preload"])
    return context


_GUARD = "'if __name__ == \"__main__\":' guard"


def _guard_example(function: str, serial: str) -> str:
    return (
        f'Put the call under that guard, e.g.\n\n    if __name__ == "__main__":\n'
        f"        {function}(...)\n\nor evaluate in this process with {serial}."
    )


def check_main_guard(
    kind: str = "process",
    scheduler: str | None = None,
    *,
    function: str = "make_executor",
    serial: str = "executor='serial'",
) -> None:
    """Refuse to start worker processes from a script without a ``__main__`` guard.

    Worker processes (``forkserver`` or ``spawn``) import the main script again. A call that
    starts workers outside the guard is re-run by each worker, which would start a pool of its
    own: the run fails after seconds or minutes with a RuntimeError from deep inside
    multiprocessing. This check fails at once, before anything is written:

    - in the script, when the call that starts workers is on a line of the script's top level
      that is not under its guard (or, called from elsewhere, when the script has no guard);
    - in a worker process still importing the main script (as ``__mp_main__``).

    It looks only at a main module that is a Python file (not ``python -c``, a notebook, an
    interactive session or ``python -m``). A guard is ``if __name__ == "__main__":``, also
    joined with ``and`` to other conditions.

    Args:
        kind: The executor that would start workers (``"serial"`` starts none, nor does
            ``"dask"`` with a ``scheduler``: the check then passes).
        scheduler: Address of a running Dask scheduler, if any.
        function: The function the script called (``"run_suite"``), named in the example of
            the message.
        serial: The argument that runs the work in the calling process instead, named in the
            message (``"workers=1"`` for :func:`~benchmarks.rl.run_rl_suite`).

    Raises:
        RuntimeError: the call is outside the guard; the message says what to do.
    """
    if kind == "serial" or (kind == "dask" and scheduler is not None):
        return
    example = _guard_example(function, serial)
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # A worker (or the forkserver) importing the main script: the call is outside the
        # guard. multiprocessing's own check (spawn._check_not_importing_main) reads this flag.
        script = getattr(sys.modules.get("__mp_main__"), "__file__", None) or "the main script"
        raise RuntimeError(
            f"this worker process is importing {script} (as __mp_main__) and was asked to "
            f"start worker processes: the script starts them outside its {_GUARD}, so each "
            f"worker re-runs that call. {example}"
        )
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or getattr(main, "__spec__", None) is not None:
        return  # -c, interactive, notebook, or python -m (a module, imported under its name)
    if not str(path).endswith(".py") or not os.path.isfile(path):
        return
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read(), filename=str(path))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return
    guards = [node for node in tree.body if _is_main_guard(node)]
    line = _top_level_line(main.__dict__)
    if not guards:
        raise RuntimeError(
            f"{path} starts worker processes but has no {_GUARD}; each worker would re-run the "
            f"script. {example}"
        )
    if line is not None and not any(g.lineno <= line <= (g.end_lineno or g.lineno) for g in guards):
        raise RuntimeError(
            f"{path}, line {line}, starts worker processes outside its {_GUARD}; each worker "
            f"would re-run that line. {example}"
        )


def _top_level_line(namespace: dict[str, Any]) -> int | None:
    """The line of the main script's top-level code now running, or None if it is not."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "<module>" and frame.f_globals is namespace:
            return frame.f_lineno
        frame = frame.f_back  # type: ignore[assignment]
    return None


def _is_main_guard(node: ast.stmt) -> bool:
    if not isinstance(node, ast.If):
        return False
    test = node.test
    # ``if __name__ == "__main__" and other:`` runs its body only in the main process too.
    terms = test.values if isinstance(test, ast.BoolOp) and isinstance(test.op, ast.And) else [test]
    return any(_is_main_compare(term) for term in terms)


def _is_main_compare(test: ast.expr) -> bool:
    if not isinstance(test, ast.Compare):
        return False
    if not all(isinstance(op, ast.Eq) for op in test.ops):
        return False
    names = [test.left, *test.comparators]
    has_name = any(isinstance(n, ast.Name) and n.id == "__name__" for n in names)
    has_main = any(isinstance(n, ast.Constant) and n.value == "__main__" for n in names)
    return has_name and has_main


def usable_cpus() -> int:
    """How many CPUs this process may run on: the default number of workers.

    Its CPU affinity (``taskset``, a container's cpuset), which ``os.cpu_count()`` ignores: under
    ``taskset -c 0`` on a 2-core machine this is 1. A CPU quota (a container's ``cpu.max``)
    is not an affinity and is not seen; pass the number of workers explicitly there.
    """
    count = getattr(os, "process_cpu_count", None)  # Python >= 3.13
    if count is not None:
        return int(count() or 1)
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


def _check_workers(workers: int | None) -> int:
    if workers is None:
        return usable_cpus()
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)):
        raise TypeError(f"workers must be an int >= 1 or None, got {type(workers).__name__}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if workers > WORKERS_MAX:
        raise ValueError(f"workers must be <= {WORKERS_MAX}, got {workers}")
    return int(workers)


def _warn_oversubscribed(workers: int) -> None:
    cpus = usable_cpus()
    if workers > cpus:
        warnings.warn(
            f"{workers} worker processes on the {cpus} CPU(s) this process may use: they take "
            f"turns, so the run is no faster than with {cpus} and each evaluation's recorded "
            f"time is longer; pass workers={cpus} (--workers {cpus}) or fewer",
            UserWarning,
            stacklevel=4,
        )


@contextlib.contextmanager
def make_executor(
    kind: str = "process",
    workers: int | None = None,
    scheduler: str | None = None,
    *,
    max_retries: int = 0,
    connect_timeout: float | None = None,
) -> Iterator[Executor]:
    """An executor for :func:`evaluate_batch`, shut down (and its cluster closed) on exit.

    Args:
        kind: ``"serial"``, ``"process"`` or ``"dask"``.
        workers: Worker processes (process pool, Dask ``LocalCluster``); default
            :func:`usable_cpus`. More than that gives a ``UserWarning``. Ignored by
            ``"serial"`` and with a ``scheduler``.
        scheduler: Address of a running Dask scheduler (``"tcp://host:8786"``); only with
            ``kind="dask"``. Without it a ``LocalCluster`` of ``workers`` single-threaded worker
            processes is started.
        max_retries: With ``"process"``: how many more times an item whose worker process died
            while it ran alone is run again, alone in a fresh pool, before its outcome is a
            :class:`WorkerDied` error (see :func:`run_alone`); an int from 0 to 100. The
            ``"serial"`` executor has no worker to lose, and Dask retries by itself.
        connect_timeout: With a ``scheduler``: seconds to wait for it before an ``OSError``
            naming it; default ``$TOOLDESIGN_DASK_CONNECT_TIMEOUT`` or 5 s
            (:func:`benchmarks.execution.dask_client.connect_timeout`).

    The workers of ``"process"`` write warnings as this process does when its warning format
    is the command line's one line (see the module's docstring).

    Yields:
        A :class:`concurrent.futures.Executor`.

    Raises:
        TypeError: If ``workers`` or ``max_retries`` is not an int.
        ValueError: If ``kind`` is unknown, ``workers`` < 1, ``max_retries`` is not from 0 to
            100, or ``scheduler`` is given for a kind other than ``"dask"``.
        ImportError: If ``kind="dask"`` and dask.distributed is not installed; the message names
            the extra ``pip install 'tooldesign[dask]'``.
    """
    if kind not in EXECUTORS:
        raise ValueError(f"executor kind must be one of {EXECUTORS}, got {kind!r}")
    count = _check_workers(workers)
    retries = check_max_retries(max_retries)
    if scheduler is not None and kind != "dask":
        raise ValueError(
            f"scheduler is an address of a Dask scheduler; it needs kind='dask', got {kind!r}"
        )
    if kind == "serial":
        serial = SerialExecutor()
        try:
            yield serial
        finally:
            serial.shutdown()
    elif kind == "process":
        check_main_guard(kind)
        _warn_oversubscribed(count)
        pool = _RestartingProcessPool(
            count, _process_context(), retries, warning_prefix=_parent_warning_prefix()
        )
        try:
            yield pool
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    else:
        check_main_guard(kind, scheduler)  # a LocalCluster starts worker processes here
        if scheduler is None:
            _warn_oversubscribed(count)
        with _dask_executor(count, scheduler, connect_timeout) as executor:
            yield executor


@contextlib.contextmanager
def _dask_executor(
    workers: int, scheduler: str | None, connect_timeout: float | None = None
) -> Iterator[Executor]:
    try:
        from distributed import Client, LocalCluster
    except ImportError as err:
        raise ImportError(
            f"the dask executor needs dask.distributed, which is not installed; "
            f"install it with `{_DASK_EXTRA}` or use --executor process"
        ) from err
    from benchmarks.execution.dask_client import (
        DaskExecutor,
        check_workers,
        connect,
        end_quiet,
        forget_check,
    )

    if scheduler is not None:
        cluster = None
        client = connect(scheduler, connect_timeout)  # refused after seconds, naming it
    else:
        # One thread per worker: the env cache is per thread, and PyBullet is CPU bound.
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=40,  # logging.ERROR: no worker start-up chatter in the progress bar
        )
        client = Client(cluster)
    try:
        try:
            # Every worker, present or joining later, must run this process's code and
            # libraries: otherwise where a design ran could change its result.
            check_workers(client)
            yield DaskExecutor(client)
        finally:
            forget_check(client)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
        end_quiet(client)  # Dask's thread of this client has stopped logging by now


def map_robust(executor: Executor, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Outcome]:
    """Call ``fn`` on every item through ``executor``; collect results and exceptions in order.

    Items whose worker process died (``BrokenProcessPool`` takes every pending call of the pool
    with it) are run again one at a time in a fresh pool (:func:`run_alone`, with the pool's
    ``max_retries``), so one crashing design does not fail its neighbours and the outcome does
    not depend on how the batch was spread over workers.

    Args:
        executor: From :func:`make_executor` (or any executor).
        fn: A picklable function of one argument.
        items: The arguments.

    Returns:
        ``(result, None, seconds)`` or ``(None, exception, seconds)`` per item, in the order of
        ``items``; ``seconds`` is the wall time from submitting the item to its outcome. An item
        whose worker kept dying has a :class:`WorkerDied` error.
    """
    start = time.perf_counter()
    futures = [executor.submit(fn, item) for item in items]
    outcomes = [_outcome(f, start) for f in futures]
    broken = [i for i, (_, exc, _) in enumerate(outcomes) if isinstance(exc, BrokenProcessPool)]
    if broken and isinstance(executor, _RestartingProcessPool):
        again = run_alone(executor, fn, [items[i] for i in broken])
        for index, outcome in zip(broken, again, strict=True):
            outcomes[index] = outcome
    return outcomes


def run_alone(executor: Executor, fn: Callable[[Any], Any], items: Sequence[Any]) -> list[Outcome]:
    """Run each item alone after its pool broke; retry an item whose worker dies again.

    Each item is the only call in the pool while it runs, so a worker that dies now was killed
    by that item (or by something outside). Such an item is run again, alone in a fresh pool,
    up to ``executor.max_retries`` times; if its worker dies every time, its outcome is a
    :class:`WorkerDied` error. The pool is left working for the next batch.

    Args:
        executor: The restarting process pool of :func:`make_executor`; other executors (which
            do not lose items with a dead worker) run the items as :func:`map_robust` does.
        fn: A picklable function of one argument.
        items: The items whose pool broke.

    Returns:
        One outcome per item, in order; ``seconds`` counts from the item's last run alone.
    """
    if not isinstance(executor, _RestartingProcessPool):
        start = time.perf_counter()
        return [_outcome(executor.submit(fn, item), start) for item in items]
    executor.restart()
    outcomes = []
    for item in items:
        for _ in range(1 + executor.max_retries):
            start = time.perf_counter()
            outcome = _outcome(executor.submit(fn, item), start)
            if not isinstance(outcome.error, BrokenProcessPool):
                break
            executor.restart()  # the next run, or the next item, gets a fresh pool
        else:
            outcome = Outcome(None, WorkerDied(1 + executor.max_retries), outcome.seconds)
        outcomes.append(outcome)
    return outcomes


def _outcome(future: Future[Any], start: float) -> Outcome:
    try:
        return Outcome(future.result(), None, time.perf_counter() - start)
    except Exception as exc:  # every failure is the outcome of its item
        return Outcome(None, exc, time.perf_counter() - start)
