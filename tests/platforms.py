"""Which platform a run of the physics is on: its results' last bits depend on it.

PyBullet's physics is deterministic on one machine, but glibc and NumPy pick their maths routines
by the CPU's features at run time (an FMA ``sin`` or ``cos`` rounds differently), so the same code
gives other last bits on another kind of CPU. The fixtures that pin results bit for bit
(``fixtures/perf_reference.json``, ``fixtures/smoke-results.json.gz``) keep one set of values per
platform, keyed by :func:`platform_id`.
"""

from __future__ import annotations

from typing import Any

from benchmarks.storage import platform_id

__all__ = ["assert_equivalent", "platform_id", "skip_reason"]


def skip_reason(fixture: str, recorded: int, command: str) -> str:
    """Why a bit-for-bit test cannot judge this platform, and how to record it."""
    return (
        f"no {fixture} recorded for this platform ({platform_id()}), and none of the {recorded} "
        f"recorded sets matches: the last bits of the physics depend on the CPU. Record this "
        f"platform's with the code before your change: {command}"
    )


def assert_equivalent(result: Any, reference: dict[str, Any]) -> None:
    """The equivalence rule's verdict a CI test can ask for on this CPU.

    On the CPU that recorded ``reference`` both of tests 1 and 2 must pass. Another CPU rounds
    differently and the pushes diverge like a nudge: test 1 still holds (probability 0.9996 by
    the reference's calibration), but test 2 passes only about 4 nudges in 5
    (``tests/test_equivalence.py::test_the_committed_reference_says_how_often_test_2_passes_a_nudge``),
    so there only test 1 is required; the table printed shows test 2's figures.
    """
    from benchmarks.suites import equivalence as eq

    table = eq.format_comparison(result)
    if platform_id() == reference["platform"]:
        assert result.accepted, table
    else:
        print(table)
        assert result.within_fraction >= eq.WITHIN_FRACTION, table
