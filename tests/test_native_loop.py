"""The control loop in C (tooldesign_env.native) gives the Python loop's results, bit for bit.

The two loops run in one process here, so the comparison holds on any machine (the fixture of
tests/test_perf_bit_identical.py pins both against the code before the performance work, per
platform).
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

import tooldesign_env.native as native
from tooldesign_env import ObjectiveSpec, SceneSpec, ToolDesignEnv, ToolSpec, make_tool
from tooldesign_env.simulation import ToolSimulator

DESIGNS = (
    (0.0, 0.0, 0.0),  # straight: pushes
    (0.0, 1.5, 0.0),  # hook: captures and pulls
    (1.2, -1.4, 0.45),  # misses or grazes
)

needs_plugin = pytest.mark.skipif(
    native.library_path() is None, reason="the C loop was not built (no C compiler at install?)"
)


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    return a == b


def _rollouts(native_loop: bool, **kwargs: object) -> list[object]:
    """Each design with and without the contact log, and the layout of its snapshots."""
    sim = ToolSimulator(native_loop=native_loop, scene=kwargs.get("scene"))
    try:
        out: list[object] = []
        for design in DESIGNS:
            geometry = make_tool(np.asarray(design), kwargs.get("tool"))
            for record in (True, False):
                sim.build(geometry, box_mass=0.3)
                out.append(sim.run(record_mobility=record, snapshot_every=97))
                snapshots = sim._snapshots
                assert snapshots is not None
                out.append((sorted(snapshots.ids), snapshots.rest_from))
                sim.release_snapshots()
        assert sim.native_status == ("native" if native_loop else "Python loop: native_loop=False")
        return out
    finally:
        sim.close()


def test_the_c_loop_is_built_where_ci_runs():
    # Without this, a CI machine without a C compiler would compare the Python loop with itself
    # below and pass.
    if not os.environ.get("CI"):
        pytest.skip("checked in CI only (CI=true)")
    assert native.library_path() is not None, native.status()


@needs_plugin
@pytest.mark.slow
@pytest.mark.parametrize(
    ("section", "merge"), [("round", False), ("square", False), ("round", True)]
)
def test_every_recorded_series_is_the_same_bit_for_bit(section, merge):
    tool = ToolSpec(section_shape=section)
    scene = SceneSpec(merge_fixed_links=merge)
    fast_forwarded = 0
    for c_run, python_run in zip(
        _rollouts(True, tool=tool, scene=scene),
        _rollouts(False, tool=tool, scene=scene),
        strict=True,
    ):
        if isinstance(c_run, tuple):  # the steps with a snapshot, and the rest state's
            assert c_run == python_run, f"{section} snapshots differ"
            fast_forwarded += c_run[1] is not None
            continue
        for field in dataclasses.fields(c_run):
            a, b = getattr(c_run, field.name), getattr(python_run, field.name)
            assert _same(a, b), f"{section} {field.name} differs"
    assert fast_forwarded > 0  # the rest snapshot was compared too
    logged = _rollouts(True, tool=tool, scene=scene)[0]
    assert logged.contact_mobility is not None and np.any(logged.contact_mobility)


@pytest.mark.slow
@pytest.mark.parametrize("every", [0, -3, True, 2.5, "10"])
def test_snapshot_every_must_be_none_or_a_positive_int(every):
    sim = ToolSimulator()
    try:
        sim.build(make_tool(np.zeros(3)))
        with pytest.raises(ValueError, match=r"snapshot_every must be None or an int >= 1, got"):
            sim.run(snapshot_every=every)  # type: ignore[arg-type]
    finally:
        sim.close()


@pytest.mark.slow
@needs_plugin
def test_a_failed_rollout_leaves_no_snapshots_behind(monkeypatch):
    geometry = make_tool(np.zeros(3))
    sim = ToolSimulator(native_loop=True)
    try:
        sim.build(geometry)
        sim.run(snapshot_every=200)
        assert sim._snapshots is not None and 0 in sim._snapshots.ids

        def refuse(self, text, args):
            raise native.NativeLoopError("refused")

        monkeypatch.setattr(native.NativeLoop, "_command", refuse)
        sim.build(geometry)
        with pytest.raises(native.NativeLoopError, match="refused"):
            sim.run(snapshot_every=200)
        with pytest.raises(ValueError, match="no snapshot at control step 0"):
            sim.replay_responses(0, 5, np.zeros((1, 7)))
    finally:
        sim.close()


def test_the_controller_stores_its_numbers_as_python_floats():
    from tooldesign_env import ControllerSpec

    spec = ControllerSpec(
        kp=np.float32(400.0), kd=np.int64(40), torque_limits=(np.float32(87),) * 7
    )
    assert type(spec.kp) is float and type(spec.kd) is float
    assert all(type(v) is float for v in spec.torque_limits)


@needs_plugin
@pytest.mark.slow
def test_the_resimulation_estimator_gets_the_same_snapshots():
    # The reference estimator restores snapshots that the C loop takes inside the server.
    values = {}
    for flag in ("1", "0"):
        os.environ[native.ENV_SWITCH] = flag
        try:
            env = ToolDesignEnv(objective=ObjectiveSpec(estimator="resimulation"))
            env.reset(seed=0)
            info = env.step(np.array([0.0, 1.5, 0.0]))[4]
            values[flag] = (info["free_energy"], info["confidence"])
            env.close()
        finally:
            del os.environ[native.ENV_SWITCH]
    assert values["1"] == values["0"]


@needs_plugin
@pytest.mark.slow
def test_the_open_loop_floor_is_the_same_in_both_loops():
    geometry = make_tool(np.array([0.0, 1.5, 0.0]))
    boxes = []
    for flag in (True, False):
        sim = ToolSimulator(native_loop=flag)
        try:
            torques = sim.rollout(geometry).torques[:400]
            boxes.append(sim.replay_open_loop(geometry, torques))
        finally:
            sim.close()
    assert _same(boxes[0], boxes[1]) and boxes[0].shape == (400, 3)


@needs_plugin
@pytest.mark.slow
def test_the_c_loop_follows_the_world_to_a_new_server():
    # Every RECONNECT_EVERY builds the world replaces its physics server; the plugin is loaded
    # into the new one.
    geometry = make_tool(np.array([0.0, 1.5, 0.0]))
    sim = ToolSimulator(native_loop=True)
    try:
        first = sim.rollout(geometry)
        sim.world.reconnect()
        again = sim.rollout(geometry)
    finally:
        sim.close()
    assert _same(first.box_position, again.box_position)
    assert _same(first.contact_mobility, again.contact_mobility)


@pytest.mark.slow
@pytest.mark.parametrize("value", ["yes", 1, 0, "auto", np.bool_(True)])
def test_native_loop_must_be_none_true_or_false(value):
    with pytest.raises(TypeError, match=r"native_loop must be None, True or False, got"):
        ToolSimulator(native_loop=value)  # type: ignore[arg-type]


@pytest.mark.slow
def test_a_rendered_world_cannot_require_the_c_loop():
    with pytest.raises(ValueError, match=r"native_loop=True needs render_mode=None"):
        ToolSimulator(native_loop=True, render_mode="rgb_array")


@pytest.mark.slow
def test_without_the_plugin_the_python_loop_runs_and_says_why(monkeypatch):
    monkeypatch.setattr(native, "library_path", lambda: None)
    geometry = make_tool(np.zeros(3))
    sim = ToolSimulator()
    try:
        sim.build(geometry)
        sim.run()
        assert sim.native_status == "Python loop: the plugin was not built"
    finally:
        sim.close()
    strict = ToolSimulator(native_loop=True)
    try:
        strict.build(geometry)
        for _ in range(2):  # every time: never the Python loop in its place
            with pytest.raises(native.NativeLoopError, match="the plugin was not built"):
                strict.run()
    finally:
        strict.close()


@pytest.mark.slow
def test_the_environment_switch_turns_it_off(monkeypatch):
    monkeypatch.setenv(native.ENV_SWITCH, "0")
    assert native.status().startswith(f"off ({native.ENV_SWITCH}=0)")
    sim = ToolSimulator()
    try:
        sim.build(make_tool(np.zeros(3)))
        sim.run()
        assert sim.native_status == f"Python loop: switched off by {native.ENV_SWITCH}=0"
    finally:
        sim.close()


@pytest.mark.slow
@needs_plugin
def test_a_plugin_built_from_another_version_is_refused(monkeypatch):
    monkeypatch.setattr(native, "LOOP_VERSION", native.LOOP_VERSION + 1)
    sim = ToolSimulator(native_loop=True)
    try:
        sim.build(make_tool(np.zeros(3)))
        with pytest.raises(native.NativeLoopError, match="reinstall the package to rebuild it"):
            sim.run()
    finally:
        sim.close()


@pytest.mark.slow
@needs_plugin
def test_the_plugin_refuses_bad_commands_with_a_named_error():
    sim = ToolSimulator(native_loop=True)
    try:
        sim.build(make_tool(np.zeros(3)))
        loop = native.NativeLoop(sim.world)
        with pytest.raises(native.NativeLoopError, match=r"'nonsense' failed: unknown command"):
            loop._command("nonsense", native.LoopArgs())
        with pytest.raises(native.NativeLoopError, match=r"'rollout' failed: bad arguments"):
            loop._command("rollout", native.LoopArgs())  # period 0
        with pytest.raises(native.NativeLoopError, match=r"'contacts' failed: bad arguments"):
            loop._command("contacts", np.zeros((3, 6)))  # the plugin keeps no 3 rows
        with pytest.raises(ValueError, match=r"torques must be an \(n, 7\) array"):
            loop.replay(robot=0, box=0, slots=((7,) * 7, (6,) * 7), period=2, torques=np.zeros(7))
        with pytest.raises(ValueError, match=r"q must be an \(m, 7\) array"):
            loop.arm_matrices(robot=0, tool_link=0, q=np.zeros((3, 6)))
        with pytest.raises(native.NativeLoopError, match=r"'replay' failed: bad arguments"):
            loop.replay(
                robot=0, box=0, slots=((-1,) * 7, (6,) * 7), period=2, torques=np.zeros((2, 7))
            )
        with pytest.raises(ValueError, match=r"references must be \(5, 7\) arrays"):
            loop.rollout(
                robot=0, box=0, ee_link=0, tool_link=0, slots=((0,) * 7, (0,) * 7), period=2,
                qdd_ref=np.zeros((5, 7)), q_ref=np.zeros((5, 7)), qd_ref=np.zeros((5, 6)),
                kp=1.0, kd=1.0, torque_limits=(1.0,) * 7, phase=np.zeros(5), hold_phase=4,
                hold_from=5, fast_forward=False, rest_speed=0.0, rest_needed=1,
                record_mobility=False, snapshot_every=None,
            )  # fmt: skip
    finally:
        sim.close()


def test_addresses_travel_as_two_c_ints():
    for address in (0, 1, 2**31 - 1, 2**31, 2**32 - 1, 2**32, 0x7FFF_FFFF_F000):
        low, high = native._halves(address)
        assert -(2**31) <= low < 2**31 and 0 <= high < 2**31
        assert ((high << 32) | (low & 0xFFFFFFFF)) == address
