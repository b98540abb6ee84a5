"""The cache of the plan's inverse-kinematics knots: hit, miss, corruption, key change."""

from __future__ import annotations

import dataclasses
import os
import warnings

import numpy as np
import pytest

from tooldesign_env import floor_guard, reference, simulation
from tooldesign_env import plan as plan_module
from tooldesign_env.plan import (
    CACHE_ENV,
    cache_dir,
    cache_key,
    knot_times,
    load_knots,
    store_knots,
)
from tooldesign_env.simulation import ToolSimulator, plan_cache_key
from tooldesign_env.specs import PlanSpec

SHAPE = (5, 7)


def _knots() -> np.ndarray:
    return np.arange(35, dtype=float).reshape(SHAPE) / 7.0


def _only_file(folder) -> str:
    files = [f for f in os.listdir(folder) if f.endswith(".npz")]
    assert len(files) == 1, files
    return os.path.join(folder, files[0])


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "c"))
    assert cache_dir() == tmp_path / "c"
    monkeypatch.setenv(CACHE_ENV, "")
    assert cache_dir() is None
    monkeypatch.delenv(CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "tooldesign"


def test_store_then_load_gives_the_same_bits(tmp_path):
    key = cache_key({"a": 1})
    q = _knots()
    assert load_knots(key, SHAPE, tmp_path) is None  # miss
    assert store_knots(key, q, tmp_path)
    back = load_knots(key, SHAPE, tmp_path)
    assert back is not None and back.dtype == np.float64
    assert back.tobytes() == q.tobytes()
    # Nothing but the archive is left behind (the temporary file was renamed).
    assert os.listdir(tmp_path) == [os.path.basename(_only_file(tmp_path))]


def test_the_key_counts_every_bit_of_its_material():
    assert cache_key({"x": 0.1}) != cache_key({"x": 0.1 + 1e-17 + 2e-17})
    assert cache_key({"x": 0.1, "y": 2}) == cache_key({"y": 2, "x": 0.1})
    assert cache_key({"x": 1}) != cache_key({"x": 2})


@pytest.mark.parametrize(
    "corrupt",
    ["garbage", "empty", "truncated", "wrong_key", "wrong_shape", "nan", "wrong_dtype", "pickle"],
)
def test_a_bad_file_is_a_miss_never_an_error(tmp_path, corrupt):
    key = cache_key({"a": 1})
    store_knots(key, _knots(), tmp_path)
    path = _only_file(tmp_path)
    if corrupt == "garbage":
        with open(path, "wb") as f:
            f.write(b"not a numpy archive at all")
    elif corrupt == "empty":
        open(path, "wb").close()
    elif corrupt == "truncated":
        data = open(path, "rb").read()
        with open(path, "wb") as f:
            f.write(data[: len(data) // 2])
    else:
        arrays = {
            "key": np.frombuffer(key.encode("ascii"), dtype=np.uint8),
            "q": _knots(),
        }
        if corrupt == "wrong_key":
            arrays["key"] = np.frombuffer(cache_key({"a": 2}).encode("ascii"), dtype=np.uint8)
        elif corrupt == "wrong_shape":
            arrays["q"] = np.zeros((4, 7))
        elif corrupt == "nan":
            arrays["q"] = _knots()
            arrays["q"][2, 3] = np.nan
        elif corrupt == "wrong_dtype":
            arrays["q"] = _knots().astype(np.float32)
        elif corrupt == "pickle":
            arrays["q"] = np.array([object()] * 35, dtype=object).reshape(SHAPE)
        with open(path, "wb") as f:
            np.savez(f, **arrays)
    assert load_knots(key, SHAPE, tmp_path) is None
    # ... and storing again repairs it.
    assert store_knots(key, _knots(), tmp_path)
    assert load_knots(key, SHAPE, tmp_path) is not None


def test_an_unwritable_folder_warns_once_and_keeps_going(tmp_path, monkeypatch):
    monkeypatch.setattr(plan_module, "_UNWRITABLE", set())
    blocker = tmp_path / "a-file"
    blocker.write_text("in the way")
    with pytest.warns(RuntimeWarning, match="cannot be written") as caught:
        assert not store_knots(cache_key({"a": 1}), _knots(), blocker / "sub")
        assert not store_knots(cache_key({"b": 2}), _knots(), blocker / "sub")  # the sweep's
    assert len(caught) == 1  # one folder, one warning, naming every kind of file it holds
    message = str(caught[0].message)
    for kind in ("inverse kinematics", "joint references", "merged hand", "floor guard"):
        assert kind in message, kind
    assert load_knots(cache_key({"a": 1}), SHAPE, blocker / "sub") is None


def test_the_plan_key_changes_with_what_the_ik_depends_on(monkeypatch):
    base = plan_cache_key(PlanSpec())
    assert plan_cache_key(PlanSpec()) == base
    assert plan_cache_key(dataclasses.replace(PlanSpec(), reach=0.7000001)) != base
    assert plan_cache_key(dataclasses.replace(PlanSpec(), hold_duration=1.0)) != base
    monkeypatch.setattr(reference, "engine_version", lambda: "9.9.9 api 0")
    assert plan_cache_key(PlanSpec()) != base
    monkeypatch.undo()
    monkeypatch.setattr(reference, "robot_model_digest", lambda: "0" * 64)
    assert plan_cache_key(PlanSpec()) != base
    monkeypatch.undo()
    monkeypatch.setattr(reference, "IK_ITERATIONS", 201)
    assert plan_cache_key(PlanSpec()) != base
    monkeypatch.undo()
    monkeypatch.setattr(reference.platform, "machine", lambda: "aarch64-or-other")
    assert plan_cache_key(PlanSpec()) != base  # a home folder shared between architectures


@pytest.fixture
def fresh_memory(monkeypatch):
    """Empty the in-process caches, so only the disk can answer."""
    monkeypatch.setattr(reference, "_KNOTS", {})
    monkeypatch.setattr(reference, "_REFERENCES", {})


def _solved_references(sim: ToolSimulator) -> list[bytes]:
    ref = sim.reference
    arrays = (ref.times, ref.q, ref.qd, ref.qdd, ref.q0, ref.ee_position, ref.yaw)
    assert all(a.flags.c_contiguous for a in arrays)  # the C loop reads them as flat buffers
    return [a.tobytes() for a in arrays]


@pytest.mark.slow
def test_a_new_process_finds_the_plan_on_disk(monkeypatch, tmp_path, fresh_memory):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    sim = ToolSimulator()
    solved = _solved_references(sim)  # miss: solves, splines and writes both files
    path = plan_module._cache_path(tmp_path, plan_cache_key(PlanSpec()))
    assert len([f for f in os.listdir(tmp_path) if f.endswith(".npz")]) == 2  # knots, references
    sim.close()

    # A "new process": nothing in memory, and solving is not allowed.
    monkeypatch.setattr(reference, "_KNOTS", {})
    monkeypatch.setattr(reference, "_REFERENCES", {})

    def refuse(*args):
        raise AssertionError("the inverse kinematics ran although the cache holds the plan")

    def refuse_spline(*args, **kwargs):
        raise AssertionError("the references were splined although the cache holds them")

    monkeypatch.setattr(reference, "_inverse_kinematics", refuse)
    monkeypatch.setattr(reference, "reference_from_knots", refuse_spline)
    sim = ToolSimulator()
    assert _solved_references(sim) == solved  # hit: the same bits
    sim.close()

    # Another version of the code that splines them: the references are splined again.
    splined = []
    monkeypatch.setattr(
        reference,
        "reference_from_knots",
        lambda *args: splined.append(1) or plan_module.reference_from_knots(*args),
    )
    monkeypatch.setattr(reference, "source_digest", lambda module: f"edited {module}")
    monkeypatch.setattr(reference, "_REFERENCES", {})
    sim = ToolSimulator()
    assert _solved_references(sim) == solved and splined == [1]
    sim.close()

    # A corrupt file is ignored, solved again and rewritten; the result is the same.
    monkeypatch.undo()
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.setattr(reference, "_KNOTS", {})
    monkeypatch.setattr(reference, "_REFERENCES", {})
    with open(path, "r+b") as f:
        f.seek(100)
        f.write(b"\x00" * 64)
    sim = ToolSimulator()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _solved_references(sim) == solved
    sim.close()
    shape = (knot_times(PlanSpec()).size, 7)
    assert load_knots(plan_cache_key(PlanSpec()), shape, tmp_path) is not None


@pytest.mark.slow
def test_the_merged_hands_dynamics_are_cached_and_give_the_same_hand(monkeypatch, tmp_path):
    from tooldesign_env import robot_model as bullet  # the robot model moved out of bullet.py

    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    bullet._merged_panda.cache_clear()
    try:
        loaded = bullet.merged_hand_inertia(visuals=False)  # loads the arm, writes the file
        urdf = bullet.panda_urdf_with_tool(None, visuals=False, merge_hand=True)
        assert len(os.listdir(tmp_path)) == 1
        bullet._merged_panda.cache_clear()  # as a new process

        def refuse(*args, **kwargs):
            raise AssertionError("the arm was loaded although the cache holds its hand")

        monkeypatch.setattr(bullet, "BulletWorld", refuse)
        assert bullet.merged_hand_inertia(visuals=False) == loaded  # the same floats
        assert bullet.panda_urdf_with_tool(None, visuals=False, merge_hand=True) == urdf
    finally:
        bullet._merged_panda.cache_clear()


def test_the_disk_cache_can_be_switched_off(monkeypatch, tmp_path, fresh_memory):
    monkeypatch.setenv(CACHE_ENV, "")
    key = plan_cache_key(PlanSpec())
    assert load_knots(key, (3, 7)) is None
    assert not store_knots(key, np.zeros((3, 7)))
    assert os.listdir(tmp_path) == []


@pytest.mark.slow
def test_the_floor_guards_sweep_of_the_plan_is_cached_beside_its_knots(
    monkeypatch, tmp_path, fresh_memory
):
    # The sweep costs about one evaluation: a new process reads it from disk instead.
    from tooldesign_env import make_tool

    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.setattr(floor_guard, "_ARM_FLOOR", {})
    tool = make_tool(np.zeros(3))
    sim = ToolSimulator()
    sim.build(tool)
    swept = sim._guard.arm_floor
    sim.close()
    files = [f for f in os.listdir(tmp_path) if f.endswith(".npz")]
    assert len(files) == 4  # the knots, the sweep, the references, the hand's dynamics
    assert swept is not None and 0.05 < swept[1].min() < 0.5  # (levers, plan floor, fixed)

    # A "new process": nothing in memory; the plan must come from the disk, unswept.
    monkeypatch.setattr(floor_guard, "_ARM_FLOOR", {})
    monkeypatch.setattr(reference, "_KNOTS", {})
    monkeypatch.setattr(reference, "_REFERENCES", {})
    monkeypatch.setattr(reference, "_inverse_kinematics", lambda *a: pytest.fail("solved again"))
    calls = []
    real = simulation.BulletWorld.link_boxes
    monkeypatch.setattr(
        simulation.BulletWorld,
        "link_boxes",
        lambda world, robot, links: calls.append(list(links)) or real(world, robot, links),
    )
    again = ToolSimulator()
    try:
        again.build(tool)
        np.testing.assert_array_equal(again._guard.arm_floor[1], swept[1])
        # The tool's group and the levers at q(0), not the plan's 1,710 steps.
        assert len(calls) == 2
    finally:
        again.close()


def test_joint_reference_is_the_splined_knot_solutions():
    """The uncached path: solve the knots (here a fake IK solver), then spline them."""
    from tooldesign_env.plan import joint_reference, knot_times, reference_from_knots, solve_knots
    from tooldesign_env.specs import PlanSpec

    def fake_ik(position, quaternion, seed):
        return 0.5 * np.asarray(seed) + 0.1 * np.concatenate([position, quaternion])

    plan, dt = PlanSpec(), 1.0 / 120.0
    knots = solve_knots(plan, fake_ik)
    assert knots.shape == (knot_times(plan).size, 7)
    reference = joint_reference(plan, dt, fake_ik)
    expected = reference_from_knots(plan, dt, knots)
    for field in ("times", "q", "qd", "qdd", "q0", "ee_position", "yaw"):
        np.testing.assert_array_equal(getattr(reference, field), getattr(expected, field))
    np.testing.assert_array_equal(reference.q0, knots[0])


def test_source_digest_of_a_module_without_a_file_is_unknown(tmp_path, monkeypatch):
    from tooldesign_env.plan import source_digest

    monkeypatch.chdir(tmp_path)
    (tmp_path / "None").write_text("a file that happens to be called None")
    assert source_digest("tooldesign_env_no_such_module") == "unknown"
    assert source_digest("sys") == "unknown"  # built in: no source file
    assert len(source_digest("tooldesign_env.plan")) == 16
