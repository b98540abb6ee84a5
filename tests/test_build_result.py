"""ToolSimulator.build answers with a typed result: a failure is never a bare True."""

from __future__ import annotations

import numpy as np
import pytest

from tooldesign_env import make_tool
from tooldesign_env.simulation import BuildResult, ToolSimulator


def test_a_build_result_says_whether_the_tool_is_usable_and_why_not():
    fine, overlapping = BuildResult(overlaps_box=False), BuildResult(overlaps_box=True)
    assert fine.usable and fine.reason == ""
    assert not overlapping.usable
    assert overlapping.reason == "overlaps the box at the start of the sweep"


@pytest.mark.parametrize("overlaps", [False, True])
def test_a_build_result_refuses_a_truth_test(overlaps):
    # build() returned True for an overlapping tool before: an old `if sim.build(...)` must
    # fail loudly, not read the answer the other way round.
    with pytest.raises(TypeError, match=r"read \.usable or \.overlaps_box"):
        bool(BuildResult(overlaps_box=overlaps))


@pytest.mark.slow
def test_build_tells_an_overlapping_tool_from_a_usable_one():
    sim = ToolSimulator()
    try:
        # y = 4.35 u^2 passes through the box centre at the start of the sweep.
        assert sim.build(make_tool(np.array([0.0, 4.35, 0.0]))).overlaps_box
        straight = sim.build(make_tool(np.zeros(3)))
        assert isinstance(straight, BuildResult) and straight.usable
        assert len(sim.run()) == len(sim.reference.times)  # the world it built is used
    finally:
        sim.close()


def test_record_takes_a_recording_only():
    sim = ToolSimulator()
    try:
        with pytest.raises(TypeError, match="recording must be a Recording or None, got str"):
            sim.record("contact")  # type: ignore[arg-type]
    finally:
        sim.close()
