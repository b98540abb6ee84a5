"""The evaluation-cost and throughput scripts of perf/speed run end to end with tiny arguments.

Their figures are not checked (they are measured on a quiet machine, docs/performance.md).

``evaluation_at_floor.py`` measures this tree against itself as the baseline; the Dask scripts
start a real two-worker cluster on loopback and must leave no process behind.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(script: str, *argv: str, timeout: float = 600) -> str:
    out = subprocess.run(
        [sys.executable, "-m", f"perf.speed.{script}", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    return out.stdout


@pytest.mark.slow
def test_evaluation_at_floor_prints_each_variant_against_the_baseline():
    text = _run("evaluation_at_floor", str(ROOT), "--designs", "1", "--rounds", "1")
    assert "round 1: [baseline]" in text
    table = text.split("-" * 20)[-1].splitlines()
    for row in ("baseline", "this tree, defaults", "this tree, lower-floor"):
        assert any(line.startswith(row) for line in table), text
    baseline = next(line for line in table if line.startswith("baseline "))
    # The baseline against itself, round by round: 1 by wall and by CPU time.
    assert baseline.split()[-2:] == ["1.000", "1.000"], baseline


@pytest.mark.slow
def test_dask_task_overhead_measures_and_stops_its_cluster():
    pytest.importorskip("distributed")
    text = _run("dask_task_overhead", "--tasks", "10", "--sequential", "2", "--repeats", "1")
    assert "cluster stopped, no process left" in text
    assert "ms per task" in text and "ms per round trip" in text


@pytest.mark.slow
def test_suite_throughput_prints_evaluations_per_second_of_each_executor(tmp_path):
    pytest.importorskip("distributed")
    text = _run(
        "suite_throughput",
        "--size",
        "smoke",
        "--seeds",
        "1",
        "--iterations",
        "1",
        "--out",
        str(tmp_path / "runs"),
    )
    assert "cluster stopped, no process left" in text
    assert "16 evaluations" in text
    for run in ("serial", "process", "dask"):
        assert any(line.startswith(run + " ") for line in text.splitlines()), text
    assert "the pool's speed-up at 2 workers" in text
