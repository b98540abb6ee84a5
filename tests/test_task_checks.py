"""Checks of task input from review 42-35: a cylinder's size, obstacles over the goals or the base,
a task id's own task, and a scene given with a task (findings 4, 7, 8 and 10)."""

from __future__ import annotations

import math
from dataclasses import replace

import gymnasium as gym
import pytest

import tooldesign_env  # noqa: F401  (registers the ids)
from tooldesign_env import ToolDesignEnv
from tooldesign_env.specs import SceneSpec
from tooldesign_env.tasks import Obstacle, get_task
from tooldesign_env.tasks.base import (
    GOAL_CLEARANCE_BOX_WIDTHS,
    ROBOT_BASE_CLEARANCE,
    distance_to_footprint,
)


def _one_line(error: pytest.ExceptionInfo[BaseException]) -> str:
    text = str(error.value)
    assert "\n" not in text
    return text


# ------------------------------------------------------------------ a cylinder's size (8)
def test_a_cylinder_with_unequal_floor_extents_is_refused_naming_the_size():
    puck = get_task("puck")
    wide = replace(puck.scene, box_size=(0.1, 0.3, 0.2))
    with pytest.raises(ValueError, match=r"cylinder .* box_size \[0\.1, 0\.3, 0\.2\]") as e:
        puck.check_scene(wide)
    _one_line(e)
    with pytest.raises(ValueError, match=r"box_size \[0\.1, 0\.3, 0\.2\]"):
        replace(puck, scene=wide)
    with pytest.raises(ValueError, match=r"box_size \[0\.1, 0\.3, 0\.2\]"):
        ToolDesignEnv(task="puck", scene_overrides={"box_size": (0.1, 0.3, 0.2)})
    puck.check_scene(replace(puck.scene, box_size=(0.15, 0.15, 0.2)))  # a wider puck: taken
    get_task("push").check_scene(wide)  # a box may be any size


def test_the_cli_refuses_a_puck_of_unequal_floor_extents():
    from benchmarks.design import DesignConfig

    with pytest.raises(ValueError, match=r"box_size \[0\.1, 0\.3, 0\.2\]"):
        DesignConfig(
            task_name="puck", goal=get_task("puck").goal, scene={"box_size": [0.1, 0.3, 0.2]}
        )


# ------------------------------------------------------------------ obstacles (10)
def test_the_distance_to_a_footprint():
    square = ((1.0, 0.0), (0.2, 0.2), 0.0)
    assert distance_to_footprint((0.0, 0.0), square) == pytest.approx(0.9)
    assert distance_to_footprint((1.0, 0.05), square) == 0.0
    diamond = ((1.0, 0.0), (0.2, 0.2), math.pi / 4)
    assert distance_to_footprint((0.0, 0.0), diamond) == pytest.approx(1.0 - 0.1 * math.sqrt(2))


def test_an_obstacle_over_the_goal_range_is_refused_in_one_line():
    hook = get_task("hook")
    x1 = hook.goal_high[0]
    post = Obstacle(name="post", position=(-0.5, 0.9), size=(0.05, 0.05, 0.3))
    with pytest.raises(ValueError, match=r"obstacle 0 \(post at \[-0\.5, 0\.9\].*covers part of "
                       r"its goal range \(x in \[-0\.6, -0\.4\]") as e:
        replace(hook, obstacles=(post,))
    _one_line(e)
    # Beside the range: refused within half the box's width of it, taken beyond.
    half_box = GOAL_CLEARANCE_BOX_WIDTHS * hook.scene.box_size[0]
    for gap, refused in ((half_box - 1e-6, True), (half_box + 1e-6, False)):
        beside = Obstacle(name="post", position=(x1 + 0.025 + gap, 0.9), size=(0.05, 0.05, 0.3))
        if refused:
            with pytest.raises(ValueError, match="covers part of its goal range"):
                replace(hook, obstacles=(beside,))
        else:
            assert replace(hook, obstacles=(beside,)).obstacles == (beside,)
    # The push task's single goal (a range of one point) is covered by a post on it.
    push = get_task("push")
    with pytest.raises(ValueError, match="covers part of its goal range"):
        replace(push, accepts_any_goal=False, goal_low=push.goal, goal_high=push.goal,
                obstacles=(Obstacle(name="post", position=(0.0, 1.5), size=(0.1, 0.1, 0.3)),))


def test_an_obstacle_at_the_robot_base_is_refused_in_one_line():
    hook = get_task("hook")
    for position in ((0.0, 0.0), (0.0, -ROBOT_BASE_CLEARANCE + 0.05 + 1e-3)):
        post = Obstacle(name="post", position=position, size=(0.1, 0.1, 0.3))
        with pytest.raises(ValueError, match=r"obstacle 0 \(post at .* from the robot's base axis "
                           r"\(0, 0\), nearer than ROBOT_BASE_CLEARANCE = 0\.2 m") as e:
            replace(hook, obstacles=(post,))
        _one_line(e)
    clear = Obstacle(name="post", position=(0.0, -ROBOT_BASE_CLEARANCE - 0.05 - 1e-3),
                     size=(0.1, 0.1, 0.3))
    assert replace(hook, obstacles=(clear,)).obstacles == (clear,)


def test_the_builtin_obstacle_task_passes_its_own_checks():
    obstacle = get_task("obstacle")
    assert replace(obstacle, title=obstacle.title) == obstacle


# ------------------------------------------------------------------ a task id's own task (7)
@pytest.mark.parametrize("kind", [0, 1])
def test_a_task_id_refuses_another_task_in_one_line(kind):
    ids = ("ToolDesign-Hook-v0", "ToolDesignRL-Hook-v0")
    other = ("ToolDesign-Puck-v0", "ToolDesignRL-Puck-v0")[kind]
    with pytest.raises(ValueError, match=rf"{ids[kind]} makes the hook task and takes no other, "
                       rf"got task='puck'; for another task use gym.make\('{other}'\)") as e:
        gym.make(ids[kind], task="puck")
    _one_line(e)
    with pytest.raises(ValueError, match=r"got task='nope'"):
        gym.make(ids[kind], task="nope")
    with pytest.raises(ValueError, match=r"takes no other"):
        gym.make(ids[kind], task=replace(get_task("hook"), tolerance=0.2))


def test_a_task_id_spec_stays_plain_data():
    spec = gym.spec("ToolDesign-Hook-v0")
    assert spec.kwargs == {"task": "hook"}
    assert isinstance(spec.entry_point, str) and "hook" in spec.to_json()


@pytest.mark.slow
def test_a_task_id_takes_its_own_task_by_name_or_definition():
    for task in ("hook", get_task("hook")):
        env = gym.make("ToolDesign-Hook-v0", task=task)
        assert env.unwrapped.task_definition.name == "hook"
        assert env.spec is not None and env.spec.id == "ToolDesign-Hook-v0"
        env.close()


# ------------------------------------------------------------------ a scene given with a task (4)
def test_a_scene_that_leaves_the_box_at_the_default_start_is_refused_for_hook():
    with pytest.raises(ValueError, match=r"scene leaves box_position at SceneSpec's default "
                       r"\[1\.1691, 0\.675\] \(the push task's\), but the hook task's is "
                       r"\[-0\.4, 1\.2\]: .*scene_overrides") as e:
        ToolDesignEnv(task="hook", scene=SceneSpec(box_friction=0.3))
    _one_line(e)
    with pytest.raises(ValueError, match="scene leaves box_position"):
        gym.make("ToolDesignRL-Hook-v0", scene=SceneSpec(box_friction=0.3))
    tall = replace(get_task("hook"), name="tall", scene=replace(get_task("hook").scene,
                                                                  box_size=(0.1, 0.1, 0.3)))
    with pytest.raises(ValueError, match=r"scene leaves box_size at SceneSpec's default "
                       r"\[0\.1, 0\.1, 0\.2\].*\[0\.1, 0\.1, 0\.3\]"):
        ToolDesignEnv(task=tall, scene=SceneSpec(box_position=(-0.4, 1.2)))


@pytest.mark.slow
def test_scene_overrides_change_fields_of_the_task_scene_as_the_cli_does():
    from benchmarks.design import DesignConfig

    hook = get_task("hook")
    env = ToolDesignEnv(task="hook", scene_overrides={"box_friction": 0.3})
    config = DesignConfig(task_name="hook", goal=hook.goal, scene={"box_friction": 0.3})
    assert env.simulator.scene == replace(hook.scene, box_friction=0.3) == config.task_scene()
    env.close()
    # A scene that places the box explicitly is taken, and so are the task's own nudged scenes.
    for scene in (SceneSpec(box_position=(-0.3, 1.1)),
                  replace(hook.scene, box_position=(-0.4 + 1e-4, 1.2 - 1e-4), box_yaw=1e-4)):
        env = ToolDesignEnv(task="hook", scene=scene)
        assert env.simulator.scene == scene
        env.close()
    # Push takes any scene, as before (its box start is SceneSpec's default).
    env = ToolDesignEnv(scene=SceneSpec(box_position=(1.0, 0.5)))
    assert env.simulator.scene.box_position == (1.0, 0.5)
    env.close()


@pytest.mark.parametrize(
    ("overrides", "kwargs", "error", "match"),
    [
        ({"box_fricton": 0.3}, {}, ValueError, r"unknown SceneSpec field 'box_fricton'"),
        ([("box_friction", 0.3)], {}, TypeError, r"scene_overrides must be a mapping .* got list"),
        ({"box_mass": 0.2}, {"box_mass": 0.3}, ValueError, r"box_mass \(0\.3\) or "
         r"scene_overrides\['box_mass'\] \(0\.2\), not both"),
        ({"box_friction": -1.0}, {}, ValueError, r"box_friction"),
    ],
)
def test_bad_scene_overrides_are_refused_in_one_line(overrides, kwargs, error, match):
    with pytest.raises(error, match=match) as e:
        ToolDesignEnv(task="hook", scene_overrides=overrides, **kwargs)
    _one_line(e)


def test_the_rl_starting_state_describes_the_task_box_and_range():
    from tooldesign_env.rl import ToolDesignRLEnv

    doc = " ".join((ToolDesignRLEnv.__doc__ or "").split())
    x, y = get_task("hook").scene.box_position
    assert f"for hook at ({x:g}, {y:g}) m" in doc
    assert "default the task's goal range" in doc
