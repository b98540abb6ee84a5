"""SIGKILL of a pooled design run leaves no process and no shared-memory entry behind (#10)."""

from __future__ import annotations

import contextlib
import json
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


def _tmp_pymp() -> set[str]:
    import tempfile

    return {n for n in os.listdir(tempfile.gettempdir()) if n.startswith("pymp-")}


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/dev/shm semaphores are Linux")
def test_sigkill_of_the_process_group_leaves_nothing_after_the_next_start(tmp_path: Path) -> None:
    """Issue 33: the group's SIGKILL kills the resource tracker too, so nothing unlinked the
    pool's semaphores (5 ``sem.mp-*`` per kill) or its forkserver folder; the next pool of the
    user removes them before it starts, and the resumed manifest marks the killed session."""
    out = tmp_path / "run"
    shm_before, tmp_before = _shm(), _tmp_pymp()
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    args = ["design", "--iterations", "4", "--batch-size", "2", "--workers", "2"]
    command = [sys.executable, "-c", code, *args, "--executor", "process", "--out", str(out)]
    process = subprocess.Popen(
        command,
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    main = psutil.Process(process.pid)
    deadline = time.monotonic() + 300
    while not ((out / "parts").exists() and list((out / "parts").rglob("*.csv"))):
        assert process.poll() is None, "the run ended before its first part"
        assert time.monotonic() < deadline, "no part written"
        time.sleep(0.05)  # polling a folder; the run itself takes seconds
    helpers = set(main.children(recursive=True))
    os.killpg(process.pid, signal.SIGKILL)  # the whole group: the resource tracker too
    process.wait(timeout=30)
    end = time.monotonic() + GRACE
    alive = helpers
    while alive and time.monotonic() < end:
        alive = {p for p in alive if _alive(p)}
        time.sleep(0.05)
    assert not alive, [_cmdline(p)[:80] for p in alive]
    left = _leaked_shm(shm_before)
    # The next start of a pool (here: the resume) removes them before it adds its own.
    resumed = subprocess.run(
        [*command, "--resume"], cwd=ROOT, capture_output=True, text=True, timeout=600
    )
    assert resumed.returncode == 0, resumed.stderr
    assert not (left & _shm()), f"still in /dev/shm after the next start: {sorted(left & _shm())}"
    assert not _leaked_shm(shm_before)
    import tempfile

    stale = {
        n
        for n in _tmp_pymp() - tmp_before
        if not os.listdir(Path(tempfile.gettempdir()) / n)
        or all(
            (Path(tempfile.gettempdir()) / n / e).is_socket()
            for e in os.listdir(Path(tempfile.gettempdir()) / n)
        )
    }
    from benchmarks.execution._stale_ipc import _bound_sockets

    bound = _bound_sockets()
    unbound = {
        n
        for n in stale
        if not any(
            str(Path(tempfile.gettempdir()) / n / e) in bound
            for e in os.listdir(Path(tempfile.gettempdir()) / n)
        )
        and os.listdir(Path(tempfile.gettempdir()) / n)
    }
    assert not unbound, f"forkserver folders left: {sorted(unbound)}"
    sessions = json.loads((out / "manifest.json").read_text())["extra"]["sessions"]
    assert sessions[0].get("interrupted") is True, sessions
    assert "interrupted" not in sessions[-1]


def test_stale_ipc_removes_only_what_no_process_uses(tmp_path: Path, monkeypatch) -> None:
    import socket

    from benchmarks.execution import _stale_ipc

    monkeypatch.setattr(_stale_ipc, "_SHM", tmp_path / "shm")
    monkeypatch.setattr(_stale_ipc.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    (tmp_path / "shm").mkdir()
    (tmp_path / "tmp").mkdir()
    stale = tmp_path / "shm" / "sem.mp-stale000"
    stale.write_bytes(b"\0" * 32)
    other = tmp_path / "shm" / "sem.someone-else"  # not multiprocessing's: never touched
    other.write_bytes(b"\0" * 32)
    used = tmp_path / "shm" / "sem.mp-inuse000"
    used.write_bytes(b"\0" * 32)
    monkeypatch.setattr(_stale_ipc, "_mapped", lambda: {"sem.mp-inuse000"})
    dead = tmp_path / "tmp" / "pymp-dead"
    dead.mkdir()
    gone = socket.socket(socket.AF_UNIX)
    gone.bind(str(dead / "listener-1"))
    gone.close()  # the socket file stays, nobody listens: what a SIGKILL leaves
    live = tmp_path / "tmp" / "pymp-live"
    live.mkdir()
    listener = socket.socket(socket.AF_UNIX)
    listener.bind(str(live / "listener-2"))
    listener.listen()
    busy = tmp_path / "tmp" / "pymp-busy"  # holds a file: not what a forkserver leaves
    busy.mkdir()
    (busy / "data").write_text("x")
    try:
        removed = _stale_ipc.remove_stale_ipc(force=True)
        assert sorted(removed) == sorted([stale, dead])
        assert other.exists() and used.exists() and live.exists() and busy.exists()
    finally:
        listener.close()
