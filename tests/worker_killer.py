"""Test helper: work functions that SIGKILL their own worker process for a chosen item.

The functions are bound to their settings with :func:`functools.partial`, which pickles, so a
process-pool worker receives the settings with each item (a worker started by the forkserver
does not see changes made to the test process after the server started). Every call records the
worker's pid, and every start of the chosen item a numbered file, in ``starts_dir``.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path
from typing import Any


def _start(starts_dir: str, is_victim: bool, deaths: int | None) -> None:
    folder = Path(starts_dir)
    (folder / f"pid-{os.getpid()}").touch()
    if not is_victim:
        return
    earlier = len(list(folder.glob("start-*")))
    (folder / f"start-{earlier}-{os.getpid()}").touch()
    if deaths is None or earlier < deaths:
        # What the kernel's out-of-memory killer does: no exception, no cleanup.
        os.kill(os.getpid(), signal.SIGKILL)


def die_or_eval(text: str, *, victim: str, deaths: int | None, starts_dir: str) -> Any:
    """``eval(text)``, after killing this worker if ``text`` is the victim.

    Args:
        text: A Python expression.
        victim: The item whose worker dies.
        deaths: How many of its starts die (the later ones succeed); ``None``: every one.
        starts_dir: Where pids and starts are recorded.
    """
    _start(starts_dir, text == victim, deaths)
    return eval(text)  # noqa: S307  (test expressions)


def die_or_evaluate(
    request: Any, *, victim: tuple[float, ...], deaths: int | None, starts_dir: str
) -> dict[str, Any]:
    """``evaluate_design(request)``, after killing this worker if the design is ``victim``."""
    from benchmarks.execution.evaluator import evaluate_design

    _start(starts_dir, tuple(request.coeffs) == tuple(victim), deaths)
    return evaluate_design(request)


def starts(starts_dir: str | os.PathLike[str]) -> int:
    """How many times the victim started."""
    return len(list(Path(starts_dir).glob("start-*")))


def worker_pids(starts_dir: str | os.PathLike[str]) -> set[int]:
    """Every worker process that ran an item."""
    return {int(p.name.split("-")[1]) for p in Path(starts_dir).glob("pid-*")}
