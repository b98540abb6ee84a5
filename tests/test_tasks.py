"""Tasks (issue 35): the registry, each task's ids and both checkers, success, bad input, the CLI.

Parametrized over the registry, so a task registered later is tested without new test code.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import tooldesign_env
from tooldesign_env import ToolDesignEnv
from tooldesign_env.specs import SceneSpec
from tooldesign_env.tasks import (
    BUILTIN_TASKS,
    Obstacle,
    footprints_overlap,
    get_task,
    register_task,
    task_names,
    unregister_task,
)
from tooldesign_env.tasks.registry import env_ids

NEW_TASKS = [name for name in BUILTIN_TASKS if name != "push"]


# ------------------------------------------------------------------ the registry (fast)
def test_at_least_three_tasks_beside_push_are_registered_with_their_ids():
    assert task_names()[: len(BUILTIN_TASKS)] == BUILTIN_TASKS
    assert {"push", "hook", "obstacle"} <= set(BUILTIN_TASKS) and len(NEW_TASKS) >= 3
    for name in task_names():
        env_id, rl_id = env_ids(name)
        assert env_id in gym.registry and rl_id in gym.registry
        if name != "push":
            assert gym.registry[env_id].kwargs == {"task": name}
            assert gym.registry[rl_id].kwargs == {"task": name}
    assert env_ids("push") == ("ToolDesign-v0", "ToolDesignRL-v0")
    assert env_ids("hook") == ("ToolDesign-Hook-v0", "ToolDesignRL-Hook-v0")
    assert gym.registry["ToolDesign-v0"].kwargs == {}  # the paper's id takes nothing new


@pytest.mark.parametrize("name", BUILTIN_TASKS)
def test_every_task_is_defined_in_full(name):
    task = get_task(name)
    assert task.name == name and task.title and task.plan_reason
    assert 0 < task.tolerance <= 1.0
    task.check_goal(task.goal)
    low, high = np.asarray(task.goal_low), np.asarray(task.goal_high)
    assert np.all(low <= high)
    # Every goal of the range is farther from the box's start than the success radius: leaving
    # the box alone never succeeds.
    nearest = np.clip(task.box_start(), low, high)
    assert np.linalg.norm(nearest - task.box_start()) > task.tolerance


def test_the_push_task_is_the_papers_defaults():
    from tooldesign_env.schema import DEFAULT_GOAL, GOAL_HIGH, GOAL_LOW
    from tooldesign_env.specs import PlanSpec

    push = get_task("push")
    assert push.scene == SceneSpec() and push.plan == PlanSpec() and push.obstacles == ()
    assert push.goal == DEFAULT_GOAL and push.goal_low == GOAL_LOW and push.goal_high == GOAL_HIGH
    assert push.accepts_any_goal and push.object_shape == "box"
    push.check_goal((2.0, -2.0, 0.5))  # ToolDesign-v0 always took any goal in the workspace


def test_an_unknown_task_names_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown task 'pushh'; known tasks: push, hook, obst"):
        get_task("pushh")
    with pytest.raises(TypeError, match="task must be a task name"):
        get_task(3)


def test_a_goal_outside_the_range_is_refused_in_one_line():
    hook = get_task("hook")
    with pytest.raises(ValueError, match=r"outside the hook task's goal range \(x in") as err:
        hook.check_goal((0.0, 1.5, 0.1))
    assert "\n" not in str(err.value)


def test_registering_a_task_refuses_duplicates_and_mismatched_names():
    mine = replace(get_task("hook"), name="my-hook")
    register_task("my-hook", mine)
    try:
        assert get_task("my-hook") is mine
        with pytest.raises(ValueError, match="registered already"):
            register_task("my-hook", mine)
        tooldesign_env.register_envs()
        assert gym.registry["ToolDesign-MyHook-v0"].kwargs == {"task": "my-hook"}
    finally:
        unregister_task("my-hook")
        gym.registry.pop("ToolDesign-MyHook-v0", None)
        gym.registry.pop("ToolDesignRL-MyHook-v0", None)
    with pytest.raises(ValueError, match="named 'hook'"):
        register_task("other", get_task("hook"))
    with pytest.raises(TypeError, match="needs a TaskDefinition"):
        register_task("other", 42)
    with pytest.raises(ValueError, match="cannot be unregistered"):
        unregister_task("push")


def test_two_tasks_never_share_a_gymnasium_id():
    walled = replace(get_task("hook"), name="walled-hook")
    register_task("walled-hook", walled)
    try:
        for twin in ("walled_hook", "Walled-hook", "walled-Hook"):
            with pytest.raises(ValueError, match=rf"'{twin}' would have the Gymnasium id "
                               r"ToolDesign-WalledHook-v0, which is the task 'walled-hook'"):
                register_task(twin, replace(walled, name=twin))
            assert twin not in task_names()
        tooldesign_env.register_envs()
        assert gym.registry["ToolDesign-WalledHook-v0"].kwargs == {"task": "walled-hook"}
    finally:
        unregister_task("walled-hook")
        gym.registry.pop("ToolDesign-WalledHook-v0", None)
        gym.registry.pop("ToolDesignRL-WalledHook-v0", None)
    with pytest.raises(ValueError, match="which is the task 'hook'"):
        register_task("Hook", replace(get_task("hook"), name="Hook"))


def test_register_envs_refuses_an_id_that_makes_another_env():
    gym.register(id="ToolDesign-Stray-v0", entry_point="tooldesign_env.env:ToolDesignEnv",
                 kwargs={"task": "hook"})
    register_task("stray", replace(get_task("hook"), name="stray"))
    try:
        with pytest.raises(ValueError, match=r"ToolDesign-Stray-v0 of the task 'stray' is "
                           r"registered already for 'hook'"):
            tooldesign_env.register_envs()
    finally:
        unregister_task("stray")
        gym.registry.pop("ToolDesign-Stray-v0", None)
        gym.registry.pop("ToolDesignRL-Stray-v0", None)


def test_footprints_overlap_by_the_separating_axes():
    square = ((0.0, 0.0), (0.1, 0.1), 0.0)
    assert footprints_overlap(square, ((0.09, 0.0), (0.1, 0.1), 0.0))
    assert not footprints_overlap(square, ((0.11, 0.0), (0.1, 0.1), 0.0))
    # A diamond whose corner reaches 0.0707 m from its centre: apart at 0.125, touching at 0.12.
    assert not footprints_overlap(square, ((0.125, 0.0), (0.1, 0.1), math.pi / 4))
    assert footprints_overlap(square, ((0.12, 0.0), (0.1, 0.1), math.pi / 4))
    assert footprints_overlap(square, ((0.11, 0.0), (0.1, 0.1), 0.0), clearance=0.02)


def test_footprints_that_touch_overlap_as_check_scene_says():
    square = ((0.0, 0.0), (0.1, 0.1), 0.0)
    # Edge to edge, exactly (0.1 - 0.05 is 0.05 in binary): touching, no gap.
    assert footprints_overlap(square, ((0.1, 0.0), (0.1, 0.1), 0.0))
    assert footprints_overlap(square, ((0.0, -0.1), (0.1, 0.1), 0.0))
    assert not footprints_overlap(square, ((0.1 + 1e-9, 0.0), (0.1, 0.1), 0.0))
    # The box's start, turned with the obstacle task's curb and end to end against it (to
    # within 1e-9 m): refused; 1e-6 m beyond its end: accepted.
    obstacle = get_task("obstacle")
    (curb,) = obstacle.obstacles
    along = np.array([math.cos(curb.yaw), math.sin(curb.yaw)])
    reach = (curb.size[0] + obstacle.scene.box_size[0]) / 2
    for gap, refused in ((-1e-9, True), (1e-6, False)):
        x, y = np.asarray(curb.position) + (reach + gap) * along
        scene = replace(obstacle.scene, box_position=(float(x), float(y)), box_yaw=curb.yaw)
        if refused:
            with pytest.raises(ValueError, match="overlaps the box's start"):
                obstacle.check_scene(scene)
        else:
            obstacle.check_scene(scene)


def test_an_obstacle_overlapping_the_box_start_is_refused():
    hook = get_task("hook")
    post = Obstacle(name="post", position=(-0.42, 1.2), size=(0.1, 0.1, 0.3))
    with pytest.raises(ValueError, match=r"obstacle 0 \(post at \[-0.42, 1.2\].*overlaps the box"):
        replace(hook, obstacles=(post,))
    obstacle = get_task("obstacle")
    where = obstacle.obstacles[0].position
    with pytest.raises(ValueError, match="overlaps the box's start"):
        obstacle.check_scene(replace(obstacle.scene, box_position=where))


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"name": "post", "position": (0, 0), "size": (0.1, 0.1, 0.0)}, ValueError, "extents"),
        ({"name": "post", "position": (3.0, 0), "size": (0.1, 0.1, 0.3)}, ValueError, "workspace"),
        ({"name": "post", "position": (0, 0), "size": (0.1, 0.1, 0.3), "yaw": 30}, ValueError,
         "yaw"),
        ({"name": "", "position": (0, 0), "size": (0.1, 0.1, 0.3)}, ValueError, "name"),
        ({"name": "post", "position": {0, 1}, "size": (0.1, 0.1, 0.3)}, TypeError, "in order"),
        ({"name": "post", "position": (0, math.nan), "size": (0.1, 0.1, 0.3)}, ValueError,
         "finite"),
    ],
)
def test_an_obstacle_refuses_bad_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        Obstacle(**kwargs)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"tolerance": 0.0}, "tolerance"),
        ({"tolerance": 2.0}, "tolerance"),
        ({"height_tolerance": 0.0}, r"height_tolerance must be a number of metres .* got 0\.0"),
        ({"height_tolerance": -0.01}, r"height_tolerance .* got -0\.01"),
        ({"height_tolerance": 2.0}, r"height_tolerance .* got 2\.0"),
        ({"height_tolerance": float("nan")}, "height_tolerance must be a finite number"),
        ({"max_tilt": 0.0}, r"max_tilt must be an angle in \(0, pi/2\] rad, got 0\.0"),
        ({"max_tilt": 2.0}, r"max_tilt .* got 2\.0"),
        ({"max_tilt": float("inf")}, "max_tilt must be a finite number"),
        ({"goal_low": (0.0, 1.0, 0.1), "goal_high": (-0.1, 1.0, 0.1)}, "low <= high"),
        ({"goal": (0.0, 0.0, 0.1)}, "outside the hook task's goal range"),
        ({"object_shape": "sphere"}, "object_shape"),
        ({"name": "two words"}, "name"),
    ],
)
def test_a_task_definition_refuses_bad_fields(change, match):
    with pytest.raises(ValueError, match=match):
        replace(get_task("hook"), **change)


def test_a_task_definition_refuses_a_height_tolerance_that_is_not_a_number():
    with pytest.raises(TypeError, match="height_tolerance must be a real number, got '0.01'"):
        replace(get_task("hook"), height_tolerance="0.01")


@pytest.mark.parametrize("name", BUILTIN_TASKS)
def test_success_needs_the_box_standing_at_the_goal(name):
    task = get_task(name)
    rest = task.box_start()[2]  # half the box's height: 0.1 m
    assert task.height_tolerance == 0.01
    assert task.succeeded(task.tolerance, rest)
    assert task.succeeded(0.0, rest + task.height_tolerance)
    assert not task.succeeded(task.tolerance + 1e-9, rest)
    # Lying on its side (0.05 m) or tipped onto a curb (about 0.08 m): not at the goal,
    # however near its centre is.
    for height in (0.05, 0.08, rest - task.height_tolerance - 1e-9):
        assert not task.succeeded(0.0, height)
    # The resting height is the scene's box's: a taller box rests higher.
    tall = replace(task.scene, box_size=(0.1, 0.1, 0.3))
    assert task.succeeded(0.0, 0.15, tall) and not task.succeeded(0.0, rest, tall)
    # Leaning by 45 degrees its centre is 0.106 m high, within the height tolerance: the tilt
    # tells it from a standing box.
    assert task.max_tilt == pytest.approx(math.radians(10.0))
    assert task.succeeded(0.0, rest, final_tilt=task.max_tilt)
    assert not task.succeeded(0.0, 0.106, final_tilt=math.radians(45.0))
    assert not task.succeeded(0.0, rest, final_tilt=math.nextafter(task.max_tilt, 4.0))


def test_the_final_tilt_is_the_angle_of_the_box_up_axis():
    from tooldesign_env.rollout import Trajectory

    def tilt(quaternion: tuple[float, ...] | None) -> float | None:
        empty = np.zeros(1)
        return Trajectory(
            times=empty, box_position=np.zeros((1, 3)), torques=np.zeros((1, 7)),
            joint_positions=np.zeros((1, 7)), tool_position=np.zeros((1, 3)), tool_yaw=empty,
            contact=np.zeros(1, dtype=bool), phase=np.zeros(1, dtype=np.int8),
            tracking_error=empty, fast_forward_from=1, box_final_orientation=quaternion,
        ).box_final_tilt

    half = math.sqrt(0.5)
    assert tilt(None) is None
    assert tilt((0.0, 0.0, 0.0, 1.0)) == 0.0
    assert tilt((0.0, 0.0, half, half)) == 0.0  # a turn about z is no tilt
    assert tilt((half, 0.0, 0.0, half)) == pytest.approx(math.pi / 2)  # on its side
    assert tilt((0.0, 1.0, 0.0, 0.0)) == pytest.approx(math.pi)  # upside down


# ------------------------------------------------------------------ the envs
def test_the_env_refuses_bad_task_input_before_simulating():
    with pytest.raises(ValueError, match="unknown task 'nope'; known tasks: push"):
        ToolDesignEnv(task="nope")
    with pytest.raises(ValueError, match="outside the hook task's goal range"):
        ToolDesignEnv(task="hook", goal=(0.0, 1.5, 0.1))
    obstacle = get_task("obstacle")
    with pytest.raises(ValueError, match="overlaps the box's start"):
        ToolDesignEnv(
            task="obstacle",
            scene=replace(obstacle.scene, box_position=obstacle.obstacles[0].position),
        )


@pytest.mark.slow
def test_a_reset_goal_outside_the_task_range_is_refused():
    env = ToolDesignEnv(task="hook")
    try:
        with pytest.raises(ValueError, match=r"options\['goal'\] .* outside the hook task"):
            env.reset(options={"goal": (0.0, 1.5, 0.1)})
        obs, _ = env.reset(seed=3)
        np.testing.assert_array_equal(obs, get_task("hook").goal)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", BUILTIN_TASKS)
def test_randomized_goals_come_from_the_task_range(name):
    task = get_task(name)
    env = ToolDesignEnv(task=name, randomize_goal=True)
    try:
        for seed in range(4):
            obs, _ = env.reset(seed=seed)
            assert np.all(obs >= task.goal_low) and np.all(obs <= task.goal_high)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", NEW_TASKS)
def test_both_checkers_pass_on_the_task_env(name):
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env_id, _ = env_ids(name)
    env = gym.make(env_id)
    try:
        # As ToolDesign-v0's (tests/test_env.py): its physical action box draws SB3's advice
        # to normalize, which the RL variant follows.
        gym_check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", NEW_TASKS)
def test_both_checkers_pass_on_the_rl_variant(name):
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    _, rl_id = env_ids(name)
    env = gym.make(rl_id, randomize_goal=True)
    try:
        task = get_task(name)
        np.testing.assert_array_equal(env.unwrapped.goal_range[0], task.goal_low)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            gym_check_env(env.unwrapped)  # render check included: rgb_array is headless
            sb3_check_env(env.unwrapped, warn=True)
        obs, _ = env.reset(seed=0)
        _, reward, _, _, info = env.step(np.zeros(3, np.float32))
        assert info["task"] == name and isinstance(info["success"], bool)
        assert -1.0 <= reward < 2.0  # REWARD_FLOOR, REWARD_CEILING
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", BUILTIN_TASKS)
def test_success_is_the_final_distance_within_the_tolerance_standing(name):
    task = get_task(name)
    env = ToolDesignEnv(task=name)
    try:
        env.reset(seed=0)
        info = env.step(np.zeros(3))[4]
        assert info["task"] == name
        standing = (
            abs(info["final_height"] - task.box_start()[2]) <= task.height_tolerance
            and info["final_tilt"] <= task.max_tilt
        )
        assert info["success"] is (
            info["valid"] and info["final_distance"] <= task.tolerance and standing
        )
        # The tilt is read from the box itself: the obstacle task's straight tool leaves it
        # tipped onto the curb (90 to 112 degrees, docs/results/tasks/walls-output.txt), the
        # other tasks' leave it upright.
        tipped = name == "obstacle"
        assert (info["final_tilt"] > math.radians(45.0)) is tipped, info["final_tilt"]
        assert standing is not tipped
        assert env.success(task.tolerance, True) and not env.success(task.tolerance, False)
        assert not env.success(task.tolerance + 1e-9, True)
        rest = task.box_start()[2]
        assert env.success(task.tolerance, True, rest)
        assert not env.success(0.0, True, 0.079)  # tipped: not a success at the goal itself
        assert not env.success(0.0, True, rest, math.radians(45.0))  # leaning
        # The tilt alone is checked too, not dropped for want of a height.
        assert not env.success(0.0, True, final_tilt=math.radians(45.0))
        assert env.success(0.0, True, final_tilt=0.0)
    finally:
        env.close()


@pytest.mark.slow
def test_the_push_task_is_toolDesign_v0_to_the_bit():
    """ToolDesign-v0, and envs made with task='push', give the F recorded before tasks existed.

    The reference is tests/fixtures/perf_reference.json (the bit-for-bit fixture of
    tests/test_perf_bit_identical.py, recorded with the code before tasks existed), in today's
    default scene (its "merged round contact" rows): comparing the new code with itself would
    pass whatever the task registry did to push.
    """
    sys.path.insert(0, str(Path(__file__).parent))
    from platforms import platform_id, skip_reason
    from test_perf_bit_identical import recorded

    designs = ((0.0, 1.5, 0.0), (0.3, -0.7, 0.2))
    scalars = ("free_energy", "goal_error", "confidence", "final_distance")
    routes = (
        lambda: gym.make("ToolDesign-v0"),
        lambda: gym.make("ToolDesign-v0", task="push"),
        lambda: gym.make("ToolDesign-v0", task=get_task("push")),
        lambda: ToolDesignEnv(task="push"),
    )
    actual = []
    for make in routes:
        env = make()
        try:
            env.reset(seed=0)
            rows = {}
            for design in designs:
                info = env.step(np.asarray(design))[4]
                rows[f"merged round contact {design}"] = {k: float(info[k]).hex() for k in scalars}
            actual.append(rows)
        finally:
            env.close()
    variants = {
        name: {key: {k: rows[key][k] for k in scalars} for key in actual[0]}
        for name, rows in recorded().items()
        if all(key in rows for key in actual[0])
    }
    expected = variants.get(platform_id())
    if expected is None:
        if not any(actual[0] == rows for rows in variants.values()):
            pytest.skip(skip_reason("outcomes", len(variants),
                                    "python tests/test_perf_bit_identical.py --record"))
        expected = actual[0]
    for rows in actual:
        assert rows == expected


@pytest.mark.slow
def test_a_tool_overlapping_an_obstacle_is_unusable_and_never_succeeds():
    obstacle = get_task("obstacle")
    # A post where the straight tool lies at the start of the sweep: along +x at y = 0.
    post = Obstacle(name="post", position=(1.3, 0.0), size=(0.1, 0.1, 0.4))
    env = ToolDesignEnv(task=replace(obstacle, name="blocked", obstacles=(post,)))
    try:
        env.reset(seed=0)
        info = env.step(np.zeros(3))[4]
        assert info["valid"] is False and info["success"] is False  # never a success
        assert info["invalid_reason"] == "overlaps a fixed obstacle at the start of the sweep"
    finally:
        env.close()


# ------------------------------------------------------------------ the command line
def _tooldesign(*argv: str) -> subprocess.CompletedProcess[str]:
    """``tooldesign ARGV`` in a fresh process (the dispatcher of the console script)."""
    code = "from benchmarks.cli import main; raise SystemExit(main())"
    return subprocess.run(
        [sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=900
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--task", "pushh"], "--task: unknown task 'pushh'; known tasks: push, hook"),
        (["--task", "hook", "--goal", "0", "1.5", "0.1"], "--goal x must be a finite number in "
         "[-0.6, -0.4] m (the hook task's goal range"),
    ],
)
@pytest.mark.parametrize("command", ["design", "evaluate"])
def test_the_cli_refuses_bad_task_input_in_one_line(tmp_path, command, argv, message):
    extra = ["--coeffs", "0", "0", "0"] if command == "evaluate" else []
    out = _tooldesign(command, *extra, "--out", str(tmp_path / "run"), *argv)
    assert out.returncode != 0
    assert message in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1, out.stderr


@pytest.mark.slow
def test_tooldesign_evaluate_takes_a_task(tmp_path):
    out = _tooldesign(
        "evaluate", "--coeffs", "0", "1.5", "0", "--task", "hook", "--out", str(tmp_path / "e")
    )
    assert out.returncode == 0, out.stderr
    assert "on the hook task" in out.stdout
    terms = json.loads((tmp_path / "e" / "terms.json").read_text())
    assert terms["task"] == "hook" and terms["settings"]["task"] == "hook"
    assert terms["goal"] == list(get_task("hook").goal)


@pytest.mark.slow
def test_tooldesign_design_takes_a_task(tmp_path):
    out = _tooldesign(
        "design", "--task", "obstacle", "--iterations", "1", "--batch-size", "2",
        "--workers", "1", "--no-video", "--no-progress", "--out", str(tmp_path / "d"),
    )
    assert out.returncode == 0, out.stderr
    assert "task obstacle: " in out.stdout
    manifest = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert manifest["config"]["task_name"] == "obstacle"


# ------------------------------------------------------------------ the design config
def test_a_design_config_records_its_task_only_when_it_is_not_push():
    from benchmarks.design import DesignConfig

    push = DesignConfig()
    assert "task_name" not in push.to_json()  # a push run's manifest is as before
    assert "task" not in dict(push.task().env_kwargs)
    hook = DesignConfig(task_name="hook", goal=get_task("hook").goal)
    assert hook.to_json()["task_name"] == "hook"
    # The definition itself, which the workers need not look up (review 43, item 1).
    assert dict(hook.task().env_kwargs)["task"] is get_task("hook")
    assert "scene" not in dict(hook.task().env_kwargs)  # the task's own scene
    moved = DesignConfig(
        task_name="hook", goal=get_task("hook").goal, scene={"box_position": [-0.45, 1.2]}
    )
    assert dict(moved.task().env_kwargs)["scene"].box_position == (-0.45, 1.2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"task_name": "nope"}, "unknown task 'nope'; known tasks: push"),
        (
            {"task_name": "hook", "goal": (0.0, 1.5, 0.1)},
            r"goal \[0.0, 1.5, 0.1\] is outside the hook task's goal range",
        ),
        (
            {"task_name": "obstacle", "goal": (-0.25, 0.75, 0.1),
             "scene": {"box_position": [0.75, 1.3]}},  # on the curb
            "overlaps the box's start",
        ),
    ],
)
def test_a_design_config_refuses_bad_task_input(kwargs, match):
    from benchmarks.design import DesignConfig

    with pytest.raises(ValueError, match=match):
        DesignConfig(**kwargs)


def test_design_with_a_policy_refuses_another_task(tmp_path, capsys):
    from benchmarks.cli import main

    argv = ["design", "--policy", str(tmp_path / "card.json"), "--task", "hook", "--out",
            str(tmp_path / "run")]
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert "--policy designs for the push task" in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow  # importing the study (the suites' retest, the optimizers) takes about 1 s
def test_the_tier_rule_of_docs_tasks():
    from perf.studies.task_baselines import tier

    assert [tier(p) for p in (0.0, 0.009, 0.01, 0.0999, 0.10, 0.5)] == [
        "hard", "hard", "medium", "medium", "easy", "easy"
    ]


@pytest.mark.slow  # importing the studies takes about 1 s
def test_the_studies_refuse_bad_input_and_merge_one_task(tmp_path):
    import argparse

    from perf.studies.task_baselines import merge_results
    from perf.studies.task_pictures import main as pictures
    from perf.studies.task_placements import _wall

    assert _wall("60:1.3:1.7:0.04") == (60.0, 1.3, 1.7, 0.04, 0.5)
    assert _wall("60:1.3:1.7:0.04:1.0")[-1] == 1.0
    for text in ("60:1.3:1.7", "60:1.7:1.3:0.04", "60:1.3:1.7:0", "60:1.3:1.7:0.04:-1",
                 "60:a:1.7:0.04"):
        with pytest.raises(argparse.ArgumentTypeError, match="a wall"):
            _wall(text)
    # --merge replaces the measured task's entry in place and keeps the others as they were.
    path = tmp_path / "baselines.json"
    path.write_text(json.dumps([{"task": "push", "x": 1}, {"task": "obstacle", "x": 2},
                                {"task": "puck", "x": 3}]))
    merged = merge_results(str(path), [{"task": "obstacle", "x": 9}, {"task": "new", "x": 4}])
    assert merged == [{"task": "push", "x": 1}, {"task": "obstacle", "x": 9},
                      {"task": "puck", "x": 3}, {"task": "new", "x": 4}]
    assert merge_results(str(tmp_path / "none.json"), [{"task": "a"}]) == [{"task": "a"}]
    path.write_text(json.dumps({"task": "push"}))
    with pytest.raises(ValueError, match="--merge: .* is not a list of task entries"):
        merge_results(str(path), [])
    path.write_text(json.dumps([{"task": "push"}]))
    with pytest.raises(SystemExit, match="--task: nope not in"):
        pictures(["--baselines", str(path), "--out", str(tmp_path / "out"), "--task", "nope"])
    assert not (tmp_path / "out").exists()  # refused before anything is written
