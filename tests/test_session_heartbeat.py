"""A killed session's wall time is kept by its heartbeat and counted on resume (#10)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchmarks.storage import read_manifest
from benchmarks.storage.session import HEARTBEAT, RunSession

ROOT = Path(__file__).resolve().parents[1]
CONFIG = {"name": "heartbeat-test", "iterations": 3}
BEAT = 0.05  # s between heartbeats in the unit tests


def _session(out: Path, *, resume: bool) -> RunSession:
    return RunSession(out, kind="test", config=CONFIG, resume=resume, heartbeat_interval=BEAT)


def _killed_session(out: Path, seconds: float) -> float:
    """A session that checkpoints once, runs ``seconds`` more, then stops as a kill would.

    Returns the wall time its manifest records (the time up to its only checkpoint).
    """
    session = _session(out, resume=False)
    session.checkpoint()
    recorded = read_manifest(out)["wall_time"]
    time.sleep(seconds)
    session.close()  # the thread stops, its last heartbeat stays: what SIGKILL leaves
    return float(recorded)


def test_the_heartbeat_gives_a_killed_session_its_time_on_resume(tmp_path: Path) -> None:
    out = tmp_path / "run"
    recorded = _killed_session(out, 0.4)
    beat = json.loads((out / HEARTBEAT).read_text())
    # the heartbeat kept counting for the 0.4 s after the manifest's last write
    assert beat["wall_time"] - recorded >= 0.4 - 2 * BEAT

    resumed = _session(out, resume=True)
    first = resumed.sessions[0]
    assert first["interrupted"] is True
    assert first["wall_time"] == pytest.approx(beat["wall_time"])
    assert first["start_time"] == beat["start_time"]
    resumed.checkpoint()  # the recovered time is on disk before anything else happens
    assert read_manifest(out)["extra"]["sessions"][0]["wall_time"] == first["wall_time"]

    time.sleep(0.1)
    manifest = resumed.finish(None)
    assert not (out / HEARTBEAT).exists()
    sessions = manifest["extra"]["sessions"]
    assert [s.get("interrupted", False) for s in sessions] == [True, False]
    assert manifest["wall_time"] == pytest.approx(sum(s["wall_time"] for s in sessions))
    assert manifest["wall_time"] >= 0.4 + 0.1 - 2 * BEAT


def test_a_finished_session_leaves_no_heartbeat_and_no_interruption(tmp_path: Path) -> None:
    out = tmp_path / "run"
    session = _session(out, resume=False)
    session.checkpoint()
    assert session._heartbeat is not None and session._heartbeat.is_alive()
    heartbeat = session._heartbeat
    session.finish(None)
    assert not heartbeat.is_alive()
    assert not (out / HEARTBEAT).exists()
    again = _session(out, resume=True)
    assert "interrupted" not in again.sessions[0]
    again.close()


def test_a_closed_session_starts_no_new_heartbeat(tmp_path: Path) -> None:
    out = tmp_path / "run"
    session = _session(out, resume=False)
    session.close()
    session.checkpoint()
    assert session._heartbeat is None
    assert not (out / HEARTBEAT).exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "text",
    [
        "{not json",
        '{"start_time": "x"}',
        '{"start_time": 3, "wall_time": 1.0}',
        '{"start_time": "x", "wall_time": true}',
        '{"start_time": "x", "wall_time": -1.0}',
        '{"start_time": "x", "wall_time": NaN}',
        '{"start_time": "x", "wall_time": Infinity}',
        "[1, 2]",
    ],
)
def test_an_unreadable_heartbeat_is_reported_and_adds_no_time(tmp_path: Path, text: str) -> None:
    out = tmp_path / "run"
    _killed_session(out, 0.1)
    before = read_manifest(out)["extra"]["sessions"]
    (out / HEARTBEAT).write_text(text)
    with pytest.warns(RuntimeWarning, match="cannot be read"):
        resumed = _session(out, resume=True)
    # No time is added, but the run had no end: its session was interrupted all the same.
    assert resumed.sessions[:-1] == [{**before[0], "interrupted": True}]
    resumed.close()


def test_a_heartbeat_of_a_session_the_manifest_does_not_record_is_reported(
    tmp_path: Path,
) -> None:
    out = tmp_path / "run"
    _killed_session(out, 0.1)
    before = read_manifest(out)["extra"]["sessions"]
    (out / HEARTBEAT).write_text('{"start_time": "2020-01-01T00:00:00+00:00", "wall_time": 9.0}')
    with pytest.warns(RuntimeWarning, match="does not record"):
        resumed = _session(out, resume=True)
    assert resumed.sessions[:-1] == [{**before[0], "interrupted": True}]
    resumed.close()


def test_a_heartbeat_never_lowers_the_recorded_time(tmp_path: Path) -> None:
    out = tmp_path / "run"
    _killed_session(out, 0.1)
    start = read_manifest(out)["extra"]["sessions"][0]["start_time"]
    recorded = read_manifest(out)["extra"]["sessions"][0]["wall_time"]
    (out / HEARTBEAT).write_text(json.dumps({"start_time": start, "wall_time": 0.0}))
    resumed = _session(out, resume=True)
    assert resumed.sessions[0]["wall_time"] == recorded
    # Killed with its process group right after a checkpoint, a session's last beat may count
    # no more than its manifest: it was interrupted all the same (issue 33).
    assert resumed.sessions[0]["interrupted"] is True
    resumed.close()


def test_a_session_killed_before_its_first_beat_is_marked_interrupted(tmp_path: Path) -> None:
    out = tmp_path / "run"
    _killed_session(out, 0.0)
    (out / HEARTBEAT).unlink()  # killed before the thread wrote it
    resumed = _session(out, resume=True)
    assert resumed.sessions[0]["interrupted"] is True
    resumed.close()


@pytest.mark.parametrize("interval", [0, -1.0, float("nan"), float("inf"), True, "2", None])
def test_a_bad_heartbeat_interval_is_refused(tmp_path: Path, interval: object) -> None:
    with pytest.raises(ValueError, match="heartbeat_interval must be a positive finite"):
        RunSession(
            tmp_path / "run",
            kind="test",
            config=CONFIG,
            resume=False,
            heartbeat_interval=interval,  # type: ignore[arg-type]
        )


@pytest.mark.slow
def test_sigkill_mid_iteration_keeps_the_interrupted_time(tmp_path: Path) -> None:
    """A real run killed 4.5 s into its second iteration: the resumed manifest counts them."""
    out = tmp_path / "run"
    code = "import sys; from benchmarks.cli import main; sys.exit(main(sys.argv[1:]))"
    # 256 designs an iteration, serial: an iteration takes at least 10 s (0.04-0.1 s per
    # design on the fastest cores seen), so no part is written between the first one and the
    # kill. With 64 a fast core finished the second iteration within the 4.5 s.
    args = ["design", "--iterations", "5", "--batch-size", "256", "--executor", "serial"]
    process = subprocess.Popen(
        [sys.executable, "-c", code, *args, "--no-video", "--out", str(out)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 300

    def parts() -> list[Path]:
        return list((out / "parts").rglob("*.csv")) if (out / "parts").is_dir() else []

    while not parts():
        assert process.poll() is None, process.stderr.read().decode()  # type: ignore[union-attr]
        assert time.monotonic() < deadline, "no part within 300 s"
        time.sleep(0.02)  # polling a file; the run takes a minute
    seen = time.monotonic()
    time.sleep(4.5)
    slept = time.monotonic() - seen  # more than 4.5 s on a busy machine
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    process.stderr.close()  # type: ignore[union-attr]
    assert len(parts()) == 1, "a second part was written before the kill"

    manifest = read_manifest(out)
    recorded = manifest["extra"]["sessions"][0]["wall_time"]
    resumed = RunSession(
        out, kind=manifest["extra"]["kind"], config=manifest["config"], resume=True
    )
    resumed.close()
    first = resumed.sessions[0]
    assert first["interrupted"] is True
    # The manifest was last written with the first part, `slept` s (and the poll's delay) before
    # the kill; the heartbeat at most 2 s (HEARTBEAT_INTERVAL) before it.
    assert first["wall_time"] - recorded >= 4.5 - 2.0 - 0.2, (first, recorded)
    assert first["wall_time"] - recorded <= slept + 1.0, (first, recorded, slept)


_HOLDER = """
import sys, time
from benchmarks.storage.session import RunSession
session = RunSession(sys.argv[1], kind="test", config={"name": "lock"}, resume=True)
session.checkpoint()
print("holding", flush=True)
time.sleep(60)
"""


@pytest.mark.slow
def test_a_second_process_cannot_write_a_folder_in_use(tmp_path: Path) -> None:
    """Two sessions on one folder would redo each other's work and fail on the other's parts."""
    out = tmp_path / "run"
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(out)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "holding"
        before = (out / "manifest.json").read_bytes()
        with pytest.raises(ValueError, match="another process is writing"):
            RunSession(out, kind="test", config={"name": "lock"}, resume=True)
        assert (out / "manifest.json").read_bytes() == before
    finally:
        holder.kill()  # SIGKILL: the kernel releases the lock with the process
        holder.wait(timeout=30)
        holder.stdout.close()  # type: ignore[union-attr]
    resumed = RunSession(out, kind="test", config={"name": "lock"}, resume=True)
    resumed.close()
    assert resumed.resumed and len(resumed.sessions) == 2


@pytest.mark.slow
def test_within_one_process_a_new_session_takes_over_an_unclosed_one(tmp_path: Path) -> None:
    out = tmp_path / "run"
    abandoned = _session(out, resume=False)
    abandoned.checkpoint()  # never closed, as after an error the caller did not handle
    taken = _session(out, resume=True)
    taken.checkpoint()
    abandoned.close()  # does not unlock the folder under the new session
    other = [sys.executable, "-c", _TRY, str(out)]
    assert subprocess.run(other, cwd=ROOT, capture_output=True, text=True).stdout == "refused\n"
    taken.close()
    assert subprocess.run(other, cwd=ROOT, capture_output=True, text=True).stdout == "opened\n"


_TRY = """
import sys
from benchmarks.storage.session import RunSession
try:
    RunSession(sys.argv[1], kind="test", config={"name": "heartbeat-test", "iterations": 3},
               resume=True).close()
    print("opened")
except ValueError as err:
    print("refused" if "another process" in str(err) else err)
"""


@pytest.mark.slow
def test_a_session_stopped_by_an_error_frees_the_folder_for_other_processes(tmp_path: Path) -> None:
    """close() then a last checkpoint (what the runners do on an error) must not lock again."""
    out = tmp_path / "run"
    session = _session(out, resume=False)
    session.checkpoint()
    session.close()
    session.checkpoint()  # the runners' `finally:` after an error
    other = [sys.executable, "-c", _TRY, str(out)]
    assert subprocess.run(other, cwd=ROOT, capture_output=True, text=True).stdout == "opened\n"


@pytest.mark.slow
def test_a_session_dropped_without_close_frees_the_folder_when_collected(tmp_path: Path) -> None:
    import gc

    out = tmp_path / "run"
    session = _session(out, resume=False)
    session.checkpoint()
    other = [sys.executable, "-c", _TRY, str(out)]
    assert subprocess.run(other, cwd=ROOT, capture_output=True, text=True).stdout == "refused\n"
    session._heartbeat.stop()  # type: ignore[union-attr]  # the thread holds no session
    del session
    gc.collect()
    assert subprocess.run(other, cwd=ROOT, capture_output=True, text=True).stdout == "opened\n"


@pytest.mark.slow
def test_checksums_are_not_added_while_another_process_writes_the_folder(tmp_path: Path) -> None:
    from benchmarks.storage import update_file_checksums

    out = tmp_path / "run"
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLDER, str(out)], cwd=ROOT, stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "holding"
        with pytest.raises(ValueError, match="another process is writing"):
            update_file_checksums(out, {"designs/x.json": "0" * 64})
    finally:
        holder.kill()
        holder.wait(timeout=30)
        holder.stdout.close()  # type: ignore[union-attr]
    # in the process holding it, a session's own retest goes through
    session = RunSession(out, kind="test", config={"name": "lock"}, resume=True)
    update_file_checksums(out, {"designs/x.json": "0" * 64})
    assert read_manifest(out)["extra"]["file_sha256"] == {"designs/x.json": "0" * 64}
    session.close()
