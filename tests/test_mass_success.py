"""The mass-perturbation report says at which box masses each design succeeds (issue 35)."""

from __future__ import annotations

import copy
from pathlib import Path

import pandas as pd
import pytest

from benchmarks.reports.suite import _mass_paths
from benchmarks.storage import read_designs, read_manifest
from benchmarks.suites.config import suite_of_manifest

COMMITTED = Path(__file__).parent.parent / "docs" / "results" / "mass-perturbation"


@pytest.mark.slow  # draws the two figures of the report (about 2 s)
def test_the_mass_report_flags_success_at_each_mass_from_the_stored_paths(tmp_path):
    designs = read_designs(COMMITTED)
    config = suite_of_manifest(read_manifest(COMMITTED))
    # One design made to end at the goal, standing, at 0.7 kg; at 0.9 kg 0.2 m off in x; at
    # 0.5 kg at the goal but 5 cm up (not at its resting height: tipped onto something).
    record = next(r for r in designs if r.get("paths") and r["variant"] == "p50")
    changed = copy.deepcopy(record)
    goal = [float(v) for v in changed["goal"]]
    masses = [float(m) for m in changed["paths"]["masses"]]
    perturbed = changed["paths"]["perturbed"]
    perturbed[masses.index(0.7)][-1] = goal
    perturbed[masses.index(0.9)][-1] = [goal[0] + 0.2, goal[1], goal[2]]
    perturbed[masses.index(0.5)][-1] = [goal[0], goal[1], goal[2] + 0.05]
    others = [r for r in designs if r is not record]
    _mass_paths([*others, changed], config, tmp_path, 0, "t")
    table = pd.read_csv(tmp_path / "mass-perturbation.csv")
    row = table[(table["variant"] == "p50") & (table["seed"] == record["seed"])].iloc[0]
    assert row["success_m0.7"] and not row["success_m0.9"] and not row["success_m0.5"]
    assert row["final_distance_m0.7"] == 0.0
    # The committed designs end 0.1 to 0.9 m off: none succeeds at any mass.
    rest = table.drop(index=row.name)
    flags = [c for c in table.columns if c.startswith("success_m")]
    assert len(flags) == 5 and not rest[flags].any(axis=None)
    distances = [c.replace("success", "final_distance") for c in flags]
    assert (rest[distances].to_numpy() > 0.1).all()
    text = (tmp_path / "mass-perturbation.md").read_text()
    assert "| succeeds at (of 5 masses) |" in text and "| 0.7 kg |" in text
    assert text.count("| none |") == len(rest)


def test_the_committed_mass_report_has_its_success_flags():
    """docs/results/mass-perturbation was rebuilt (tooldesign report) with the flags."""
    table = pd.read_csv(COMMITTED / "report" / "mass-perturbation.csv")
    flags = [c for c in table.columns if c.startswith("success_m")]
    assert flags == ["success_m0.1", "success_m0.3", "success_m0.5", "success_m0.7", "success_m0.9"]
    for flag in flags:
        distance = table[flag.replace("success", "final_distance")]
        assert (table[flag] == (distance <= 0.1)).all()  # every box ends upright here
