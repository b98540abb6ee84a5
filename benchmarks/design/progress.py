"""One status line per slow phase after the progress bar, so that a run is never silent long.

After the optimizer's progress bar is full, a design run still simulates the best tools again,
runs the robustness test, renders the GIF and draws the report: up to a minute. Each of those
phases prints ``design cmaes: robustness test of the final tool ... done (8.1 s)`` on stderr,
the stream of the progress bar, one line per phase.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator
from typing import TextIO

__all__ = ["phase"]


@contextlib.contextmanager
def phase(what: str, *, enabled: bool = True, stream: TextIO | None = None) -> Iterator[None]:
    """Say ``what ...`` before the block and ``done (N s)`` after it, on one line.

    Args:
        what: The phase, e.g. ``"design cmaes: rendering rollout.gif"``.
        enabled: False prints nothing (``--no-progress``).
        stream: Where to print; ``sys.stderr`` (as tqdm) if None.
    """
    if not enabled:
        yield
        return
    out = sys.stderr if stream is None else stream
    start = time.perf_counter()
    print(f"{what} ...", end="", file=out, flush=True)
    try:
        yield
    except BaseException:
        print(" stopped", file=out, flush=True)
        raise
    print(f" done ({time.perf_counter() - start:.1f} s)", file=out, flush=True)
