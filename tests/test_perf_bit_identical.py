"""Speed-ups that claim to leave results bit for bit the same are checked against a fixture.

``tests/fixtures/perf_reference.json`` holds, for a few fixed designs, F and its terms (as exact
float64 hex strings) and SHA-256 digests of the recorded arrays, computed with the code as it
was before the performance work (commit a23515b on main). A speed-up of the simulation loop must
reproduce them exactly; a change of the physics must not pass this test and needs its own,
documented, side-by-side comparison instead (benchmarks/perf/physics_options.py).

Regenerate (only when the physics is meant to change, and say so in the commit):
``PYTHONPATH=$PWD python tests/test_perf_bit_identical.py --record``.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from tooldesign_env import ToolDesignEnv

FIXTURE = Path(__file__).parent / "fixtures" / "perf_reference.json"

#: The straight tool, a hook, and three others that touch the box in different ways.
DESIGNS = (
    (0.0, 0.0, 0.0),
    (0.0, 1.5, 0.0),
    (0.3, -0.7, 0.2),
    (-1.1, 0.4, -0.3),
    (0.9, 1.2, 0.45),
)
ESTIMATORS = ("contact", "trajectory")
SCALARS = ("free_energy", "goal_error", "confidence", "final_distance")
ARRAYS = (
    "box_trajectory",
    "torques",
    "joint_positions",
    "tool_position",
    "tool_yaw",
    "contact",
    "confidence_t",
    "jacobian_norm_t",
)


def _digest(array: np.ndarray) -> str:
    a = np.ascontiguousarray(array)
    return hashlib.sha256(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes()).hexdigest()


def outcomes() -> dict[str, dict[str, object]]:
    """What the fixture records, computed with the code as it is now."""
    out: dict[str, dict[str, object]] = {}
    for estimator in ESTIMATORS:
        env = ToolDesignEnv(estimator=estimator, info_series=True)
        env.reset(seed=0)
        try:
            for design in DESIGNS:
                info = env.step(np.asarray(design))[4]
                row: dict[str, object] = {"valid": bool(info["valid"])}
                row.update({k: float(info[k]).hex() for k in SCALARS})
                row["fast_forward_from"] = int(info["fast_forward_from"])
                row.update({k: _digest(np.asarray(info[k])) for k in ARRAYS})
                out[f"{estimator} {design}"] = row
        finally:
            env.close()
    return out


@pytest.mark.slow
def test_fixed_designs_give_bit_identical_results():
    expected = json.loads(FIXTURE.read_text(encoding="utf-8"))
    actual = outcomes()
    assert actual.keys() == expected.keys()
    for key, row in expected.items():
        for name, value in row.items():
            assert actual[key][name] == value, f"{key}: {name} changed"


@pytest.mark.slow
def test_keeping_the_arm_off_the_floor_changes_nothing_in_the_default_scene():
    # The arm and the tool stay >= 5 cm above the floor with the default plan, so dropping
    # their collision tests against it must leave every bit of the outcome as it was.
    from dataclasses import replace

    from tooldesign_env import SceneSpec

    expected = json.loads(FIXTURE.read_text(encoding="utf-8"))
    env = ToolDesignEnv(scene=replace(SceneSpec(), arm_floor_contacts=False), info_series=True)
    env.reset(seed=0)
    try:
        for design in DESIGNS[:3]:
            info = env.step(np.asarray(design))[4]
            row = expected[f"contact {design}"]
            assert float(info["free_energy"]).hex() == row["free_energy"]
            assert _digest(np.asarray(info["box_trajectory"])) == row["box_trajectory"]
    finally:
        env.close()


def test_the_arm_passes_through_the_floor_only_when_asked():
    import pybullet

    from tooldesign_env import SceneSpec, ToolSimulator, make_tool

    counts = {}
    for flag in (True, False):
        sim = ToolSimulator(scene=SceneSpec(arm_floor_contacts=flag))
        try:
            sim.build(make_tool(np.zeros(3)))
            robot, cid = sim._robot, sim.world.client_id
            q = np.array(sim.reference.q0)
            q[1] += 0.6  # lean forward: the tool goes into the floor
            q[3] += 0.3
            sim.world.set_joint_positions(robot, q)
            sim.world.step(1)
            floor = 0  # the first body of every build
            arm = len(pybullet.getContactPoints(floor, robot.body, physicsClientId=cid))
            box = len(pybullet.getContactPoints(floor, sim._box, physicsClientId=cid))
            counts[flag] = (arm, box)
        finally:
            sim.close()
    assert counts[True][0] > 0 and counts[False][0] == 0
    assert counts[True][1] > 0 and counts[False][1] > 0  # the box rests on the floor either way


def test_arm_floor_contacts_must_be_a_bool():
    from tooldesign_env import SceneSpec

    with pytest.raises(TypeError, match="arm_floor_contacts"):
        SceneSpec(arm_floor_contacts="no")


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        raise SystemExit("usage: python tests/test_perf_bit_identical.py --record")
    FIXTURE.write_text(json.dumps(outcomes(), indent=1, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {FIXTURE}")
