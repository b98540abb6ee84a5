"""The noise-floor and convergence studies of issue 8: their outputs and cost figure.

``perf/studies/confidence_noise.py`` prints the targets' measurements (docs/model.md). The
wording of their argparse errors is theirs, not pinned here.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(script: str, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", f"perf.studies.{script.removesuffix('.py')}", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=600,
        check=False,
    )


def _noise_module(monkeypatch: pytest.MonkeyPatch):  # noqa: ANN202 (a module)
    from perf.studies import confidence_noise

    return confidence_noise


def test_the_cost_is_the_median_of_per_pair_shares(monkeypatch: pytest.MonkeyPatch) -> None:
    noise = _noise_module(monkeypatch)
    # (plain, evaluation) CPU times of three pairs: shares 50 %, 10 % and 20 %. The median
    # share is 20 %; a difference of medians, (2.0 - 1.8) / 2.0, would say 10 %.
    pairs = [(1.0, 2.0), (1.8, 2.0), (8.0, 10.0)]
    line = noise.cost_line(pairs)
    assert "contact estimator cost: 20.0 % of an evaluation" in line
    assert "median over 3 pairs" in line
    # A pair slowed down as a whole by the machine's load (both runs 3x) keeps its share.
    loaded = noise.cost_line([(1.0, 2.0), (5.4, 6.0), (8.0, 10.0)])
    assert "cost: 20.0 %" in loaded


@pytest.mark.slow
def test_pure_confidence_says_f_spread_is_the_confidence_spread() -> None:
    out = _run(
        "confidence_noise.py",
        *("--designs", "1", "--nudges", "2", "--settings", "contact", "--goal-precision", "0"),
    )
    assert out.returncode == 0, out.stderr
    row = next(line for line in out.stdout.splitlines() if line.startswith("contact "))
    f_spread, conf_spread = row.split()[1:3]
    assert f_spread == conf_spread
    assert "p^X = 0 (pure confidence): F = -confidence, so F's spread is the confidence's" in (
        out.stdout
    )
    assert "contact estimator cost:" in out.stdout and "median over 2 pairs" in out.stdout


@pytest.mark.slow
def test_no_pure_confidence_line_at_the_default_precision() -> None:
    out = _run("confidence_noise.py", "--designs", "1", "--nudges", "2", "--settings", "contact")
    assert out.returncode == 0, out.stderr
    assert "pure confidence" not in out.stdout


def _convergence_module(monkeypatch: pytest.MonkeyPatch):  # noqa: ANN202 (a module)
    from perf.studies import confidence_convergence

    return confidence_convergence


def test_the_convergence_figure_is_named_after_the_section(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    convergence = _convergence_module(monkeypatch)
    images = ROOT / "docs" / "images"
    # The committed figures, each shown in docs/model.md: running one section's study must not
    # overwrite the other's figure.
    square = convergence.default_figure("square")
    round_ = convergence.default_figure("round")
    assert square == images / "confidence_convergence.png" and square.is_file()
    assert round_ == images / "confidence_convergence_round.png" and round_.is_file()
    model = (ROOT / "docs" / "model.md").read_text()
    assert "images/confidence_convergence.png" in model
    assert "images/confidence_convergence_round.png" in model
    # Another scene gets a figure of its own.
    other = convergence.default_figure("round", {"merge_fixed_links": False})
    assert other == images / "confidence_convergence_round_merge_fixed_links-False.png"
    assert convergence.default_figure("round", {}) == round_
    with pytest.raises(ValueError, match="section_shape must be one of"):
        convergence.default_figure("hexagonal")
