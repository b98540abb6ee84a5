"""SIGKILL of a pooled design run leaves no process and no shared-memory entry behind (#10)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

ROOT = Path(__file__).resolve().parents[1]
GRACE = 5.0  # s the helpers may take to notice the death of the main process


def _cmdline(p: psutil.Process) -> str:
    try:
        return " ".join(p.cmdline())
    except psutil.Error:
        return ""


def _alive(p: psutil.Process) -> bool:
    try:
        return p.is_running() and p.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def _shm() -> set[str]:
    return set(os.listdir("/dev/shm")) if os.path.isdir("/dev/shm") else set()


def _mapped_shm() -> set[str]:
    """Names of the ``/dev/shm`` entries that some live process has mapped (all processes)."""
    names = set()
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/maps", encoding="utf-8", errors="replace") as maps:
                for line in maps:
                    if "/dev/shm/" in line:
                        names.add(line.rsplit("/dev/shm/", 1)[1].split()[0])
        except OSError:  # the process ended, or is not ours to read
            continue
    return names


def _leaked_shm(before: set[str]) -> set[str]:
    """New ``/dev/shm`` entries of multiprocessing or loky that no live process uses.

    /dev/shm is shared by the whole machine: other tests and jobs create semaphores there while
    this test runs. Theirs are mapped by a live process (or gone a moment later); one left by
    the killed run is mapped by nobody and stays. So an entry counts as leaked only if it is
    new, unmapped, and still there a second later.
    """

    def candidates() -> set[str]:
        new = {n for n in _shm() - before if n.startswith(("sem.", "psm_", "loky"))}
        return new - _mapped_shm()

    first = candidates()
    if not first:
        return first
    time.sleep(1.0)
    return first & candidates()


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("kill_point", ["pool started", "first part written"])
def test_sigkill_of_a_pooled_run_leaves_nothing(tmp_path: Path, kill_point: str) -> None:
    out = tmp_path / "run"
    shm_before = _shm()
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    args = ["design", "--iterations", "50", "--batch-size", "2", "--workers", "2"]
    process = subprocess.Popen(
        [sys.executable, "-c", code, *args, "--executor", "process", "--out", str(out)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    main = psutil.Process(process.pid)
    deadline = time.monotonic() + 300
    helpers: set[psutil.Process] = set()
    while time.monotonic() < deadline:
        # Polling the process tree; the run itself takes seconds.
        helpers = set(main.children(recursive=True))
        parts = list((out / "parts").rglob("*.*")) if (out / "parts").exists() else []
        if kill_point == "pool started" and len(helpers) >= 4:  # server, tracker, 2 workers
            break
        if kill_point == "first part written" and parts:
            break
        assert process.poll() is None, "the run ended before the kill point"
        time.sleep(0.05)
    else:
        pytest.fail(f"{kill_point} not reached")
    helpers = set(main.children(recursive=True))
    assert len(helpers) >= 3, [_cmdline(p) for p in helpers]
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    end = time.monotonic() + GRACE
    alive = helpers
    while alive and time.monotonic() < end:
        alive = {p for p in alive if _alive(p)}
        time.sleep(0.05)
    survivors = [_cmdline(p)[:80] for p in alive]
    for p in alive:  # do not leave them to the next test
        with contextlib.suppress(psutil.Error):
            p.kill()
    assert not survivors, f"{len(survivors)} of {len(helpers)} helpers outlived the kill"
    leaked = _leaked_shm(shm_before)
    assert not leaked, f"left in /dev/shm: {sorted(leaked)}"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
def test_sigterm_stops_a_pooled_run_as_ctrl_c_does(tmp_path: Path) -> None:
    out = tmp_path / "run"
    shm_before = _shm()
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    args = ["design", "--iterations", "50", "--batch-size", "2", "--workers", "2"]
    process = subprocess.Popen(
        [sys.executable, "-c", code, *args, "--executor", "process", "--out", str(out)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    main = psutil.Process(process.pid)
    deadline = time.monotonic() + 300
    while not ((out / "parts").exists() and list((out / "parts").rglob("*.*"))):
        assert process.poll() is None, "the run ended before its first part"
        assert time.monotonic() < deadline, "no part written"
        time.sleep(0.05)  # polling a folder; the run itself takes seconds
    helpers = set(main.children(recursive=True))
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 143, stderr
    assert stderr.strip().splitlines()[-1] == (
        "terminated (SIGTERM); continue with the same command and --resume"
    )
    assert "Traceback" not in stderr and "leaked" not in stderr, stderr
    end = time.monotonic() + GRACE
    alive = helpers
    while alive and time.monotonic() < end:
        alive = {p for p in alive if _alive(p)}
        time.sleep(0.05)
    for p in alive:
        with contextlib.suppress(psutil.Error):
            p.kill()
    assert not alive, [_cmdline(p)[:80] for p in alive]
    assert not _leaked_shm(shm_before)
