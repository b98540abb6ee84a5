"""The default number of workers is the CPUs this process may use, and more warn."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings

import pytest

import benchmarks.execution.executors as executors
from benchmarks.execution import make_executor, usable_cpus

needs_affinity = pytest.mark.skipif(
    not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this platform"
)


@pytest.mark.slow
@needs_affinity
def test_usable_cpus_is_the_affinity_not_the_machines_count() -> None:
    assert usable_cpus() == len(os.sched_getaffinity(0))
    one = min(os.sched_getaffinity(0))
    script = (
        f"import os; os.sched_setaffinity(0, {{{one}}})\n"
        "from benchmarks.execution import usable_cpus\n"
        "from benchmarks.suites import builtin_suite\n"
        "from benchmarks.suites.runner import _max_active\n"
        "print(usable_cpus(), os.cpu_count())\n"
        "config = builtin_suite('optimizers', 'smoke').replace(workers=None, batch_size=1)\n"
        "print(_max_active(config))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    ).stdout.split()
    assert out[0] == "1"  # as under `taskset -c 0`, whatever the machine has
    assert out[2] == "3"  # the suite keeps 2 x 1 worker busy, plus one run being told


@pytest.mark.slow
def test_more_workers_than_cpus_warn_and_as_many_do_not(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(executors, "usable_cpus", lambda: 1)
    with pytest.warns(UserWarning, match=r"2 worker processes on the 1 CPU\(s\).*--workers 1"):
        with make_executor("process", workers=2):
            pass
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with make_executor("process", workers=1):
            pass
        with make_executor("serial", workers=4):  # no workers to oversubscribe
            pass
