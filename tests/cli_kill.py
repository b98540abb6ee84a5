"""Test helper: run the ``tooldesign`` command line and SIGKILL it at a chosen moment."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_until(args: list[str], done: Path, timeout: float = 300.0) -> None:
    """Start ``tooldesign ARGS`` and SIGKILL it as soon as the file ``done`` exists."""
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    process = subprocess.Popen(
        [sys.executable, "-c", code, *args],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + timeout
    while not done.exists():
        if process.poll() is not None:
            raise AssertionError(f"finished before {done.name}: {process.stderr.read().decode()}")
        if time.monotonic() > deadline:
            process.kill()
            raise AssertionError(f"{done} did not appear within {timeout} s")
        time.sleep(0.02)  # polling a file; the run itself takes seconds
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    process.stderr.close()
    assert process.returncode == -signal.SIGKILL
