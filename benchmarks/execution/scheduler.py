"""A scheduler that keeps many jobs in flight on one executor, from the calling thread.

A suite is many design runs (optimizer x seed x variant), each a sequence of batches: ask,
evaluate the batch, tell, repeat, then test the final design. Run one after another, each
batch's slowest design would leave the other workers idle; :class:`Scheduler` instead keeps up
to ``max_active`` jobs submitted at once, and moves each job on as soon as its batch is back.

The scheduler knows nothing of tools, optimizers or files. A job is anything with two methods
(:class:`Job`): ``start()`` returns its first batch of work items, ``advance(outcomes)`` takes
the outcomes of the last batch and returns the next batch, or ``None`` when the job is done.
The work function that runs an item in a worker is a parameter (for a suite:
:func:`benchmarks.execution.evaluator.evaluate_item`).

A worker that dies takes every pending call of its pool with it. The scheduler then waits for
every in-flight call, restarts the pool, and runs each lost item again alone
(:func:`~benchmarks.execution.executors.run_alone`): an item that kills its worker again is
retried up to the pool's ``max_retries`` times, then gets a ``WorkerDied`` error as its outcome,
and the others are unaffected, so the outcome of an item does not depend on which items shared
the pool with it.

Example:
    >>> with make_executor("process", workers=2) as executor:  # doctest: +SKIP
    ...     Scheduler(executor, evaluate_item, max_active=3).run(jobs)
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Protocol, cast

from benchmarks.execution.executors import WORKERS_MAX, Outcome, run_alone

__all__ = ["MAX_ACTIVE_MAX", "Job", "Scheduler"]

#: Most jobs in flight at once. Each holds its optimizer and its batch in memory; a suite asks
#: about ``2 * workers / batch_size + 1``, and a Dask cluster may have more workers than this
#: machine would start (``WORKERS_MAX``), hence the margin.
MAX_ACTIVE_MAX = 4 * WORKERS_MAX


class Job(Protocol):
    """One sequence of batches: the scheduler calls ``start`` once, then ``advance`` per batch."""

    def start(self) -> Sequence[Any] | None:
        """The first batch of work items, or ``None`` if there is nothing to do."""
        ...

    def advance(self, outcomes: list[Outcome]) -> Sequence[Any] | None:
        """Take the outcomes of the last batch (in item order); the next batch or ``None``."""
        ...


@dataclass(eq=False)
class _Slot:
    job: Job
    items: list[Any] = field(default_factory=list)
    futures: list[Future[Any]] = field(default_factory=list)
    submitted: float = 0.0


def _checked_job(job: Any) -> Job:
    if not (callable(getattr(job, "start", None)) and callable(getattr(job, "advance", None))):
        raise TypeError(
            "a job must have start() and advance(outcomes) methods (benchmarks.execution.Job), "
            f"got {type(job).__name__} {job!r}"
        )
    return cast("Job", job)


def _done_future(result: Any = None, exc: BaseException | None = None) -> Future[Any]:
    future: Future[Any] = Future()
    if exc is not None:
        future.set_exception(exc)
    else:
        future.set_result(result)
    return future


def _broken(future: Future[Any]) -> bool:
    return (
        future.done()
        and not future.cancelled()
        and isinstance(future.exception(), BrokenProcessPool)
    )


class Scheduler:
    """Runs jobs on one executor, at most ``max_active`` at a time (see the module docstring).

    Args:
        executor: Where work items run (:func:`~benchmarks.execution.executors.make_executor`).
        work: The picklable work function, ``work(item) -> result``.
        max_active: Jobs in flight at once, >= 1. Enough to keep every worker busy while one
            job waits for its slowest item: about ``2 * workers / batch_size + 1``.

    Raises:
        TypeError: If ``executor`` has no ``submit`` method or ``work`` is not callable.
        ValueError: If ``max_active`` is not an int from 1 to :data:`MAX_ACTIVE_MAX`.
    """

    def __init__(self, executor: Executor, work: Callable[[Any], Any], max_active: int) -> None:
        if not callable(getattr(executor, "submit", None)):
            hint = (
                "; make_executor is a context manager: with make_executor(...) as executor"
                if getattr(executor, "__name__", None) == "make_executor"
                else ""
            )
            raise TypeError(
                "executor must be an Executor (anything with a submit(fn, item) method, e.g. "
                f"the one make_executor yields), got {type(executor).__name__} {executor!r}{hint}"
            )
        if not callable(work):
            raise TypeError(f"work must be a callable, got {work!r}")
        if (
            isinstance(max_active, bool)
            or not isinstance(max_active, int)
            or not 1 <= max_active <= MAX_ACTIVE_MAX
        ):
            raise ValueError(
                f"max_active must be an int from 1 to {MAX_ACTIVE_MAX}, got {max_active!r}"
            )
        self.executor = executor
        self.work = work
        self.max_active = max_active

    def run(self, jobs: Iterable[Job]) -> None:
        """Run every job to its end; returns when the last one is done."""
        queue = collections.deque(jobs)
        active: list[_Slot] = []
        while queue or active:
            while queue and len(active) < self.max_active:
                slot = _Slot(job=_checked_job(queue.popleft()))
                if self._submit(slot, slot.job.start(), "start"):
                    active.append(slot)
            if not active:
                continue
            # Only the futures still running: `wait` returns at once while any future it is given
            # is done, so passing a job's finished items too would spin this loop (a core's
            # worth of CPU taken from the workers) until the job's last item is done.
            running = [f for slot in active for f in slot.futures if not f.done()]
            if running:
                wait(running, return_when=FIRST_COMPLETED)
            # Which jobs are done is decided first, then whether a pool broke: a future that
            # breaks between the two checks belongs to a job not yet taken as done, so no job
            # is ever handed an outcome that recovery should have replaced.
            finished = [s for s in active if all(f.done() for f in s.futures)]
            if any(_broken(f) for slot in active for f in slot.futures):
                self._recover(active)
                finished = [s for s in active if all(f.done() for f in s.futures)]
            for slot in finished:
                if not self._submit(slot, slot.job.advance(self._outcomes(slot)), "advance"):
                    active.remove(slot)

    def _submit(self, slot: _Slot, items: Sequence[Any] | None, method: str) -> bool:
        """Submit a job's next batch (what its ``method`` returned); whether it is in flight."""
        if items is None:
            return False
        if isinstance(items, (str, bytes)) or not isinstance(items, Iterable):
            raise TypeError(
                f"{type(slot.job).__name__}.{method}() must return a sequence of work items "
                f"(a list; empty for a batch of none) or None when the job is done, got "
                f"{type(items).__name__} {items!r}"
            )
        slot.items = list(items)
        slot.submitted = time.perf_counter()
        slot.futures = [self.executor.submit(self.work, item) for item in slot.items]
        if not slot.futures:
            # An empty batch: hand the job an empty outcome list at once.
            return self._submit(slot, slot.job.advance([]), "advance")
        return True

    @staticmethod
    def _outcomes(slot: _Slot) -> list[Outcome]:
        outcomes: list[Outcome] = []
        for future in slot.futures:
            try:
                result = future.result()
            except Exception as exc:  # every failure is the outcome of its item
                outcomes.append(Outcome(None, exc, time.perf_counter() - slot.submitted))
            else:
                outcomes.append(Outcome(result, None, time.perf_counter() - slot.submitted))
        return outcomes

    def _recover(self, active: list[_Slot]) -> None:
        """Evaluate again, alone in a fresh pool, every item whose worker pool broke."""
        wait([f for slot in active for f in slot.futures])
        broken = [(s, i) for s in active for i, f in enumerate(s.futures) if _broken(f)]
        if not broken or not hasattr(self.executor, "restart"):
            return
        items = [slot.items[i] for slot, i in broken]
        retried = run_alone(self.executor, self.work, items)
        for (slot, i), (result, exc, _) in zip(broken, retried, strict=True):
            slot.futures[i] = _done_future(result, exc)
