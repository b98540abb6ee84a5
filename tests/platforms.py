"""Which platform a run of the physics is on: its results' last bits depend on it.

PyBullet's physics is deterministic on one machine, but glibc and NumPy pick their maths routines
by the CPU's features at run time (an FMA ``sin`` or ``cos`` rounds differently), so the same code
gives other last bits on another kind of CPU. The fixtures that pin results bit for bit
(``fixtures/perf_reference.json``, ``fixtures/smoke-results.json.gz``) keep one set of values per
platform, keyed by :func:`platform_id`.
"""

from __future__ import annotations

from benchmarks.storage import platform_id

__all__ = ["platform_id", "skip_reason"]


def skip_reason(fixture: str, recorded: int, command: str) -> str:
    """Why a bit-for-bit test cannot judge this platform, and how to record it."""
    return (
        f"no {fixture} recorded for this platform ({platform_id()}), and none of the {recorded} "
        f"recorded sets matches: the last bits of the physics depend on the CPU. Record this "
        f"platform's with the code before your change: {command}"
    )
