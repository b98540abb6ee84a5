"""Headless rendering: a useful frame after reset and after a step, rollout frames, the GIF."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.design.video import rollout_gif, write_gif
from tooldesign_env.bullet import BulletWorld, _project
from tooldesign_env.env import ToolDesignEnv

GREEN = np.array([0.1, 0.75, 0.2]) * 255
BLUE = np.array([30, 80, 220])


def _share_near(frame, rgb, tol=40):
    return float(np.mean(np.all(np.abs(frame.astype(float) - rgb) < tol, axis=2)))


@pytest.fixture(scope="module")
def env():
    env = ToolDesignEnv(render_mode="rgb_array")
    yield env
    env.close()


@pytest.mark.slow
def test_frame_after_reset_shows_the_scene_and_the_goal(env):
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (360, 480, 3) and frame.dtype == np.uint8
    assert np.mean(np.all(frame == 255, axis=2)) < 0.5  # not a blank white frame
    assert _share_near(frame, GREEN) > 1e-4  # the goal marker
    assert _share_near(frame, BLUE, tol=10) == 0  # no path before a step


@pytest.mark.slow
def test_frame_after_a_step_draws_the_box_path_and_rollout_frames_differ(env, tmp_path):
    env.reset(seed=0)
    env.step([0.0, 0.0, 0.0])
    frame = env.render()
    assert _share_near(frame, BLUE, tol=10) > 1e-3
    frames = env.render_rollout(frames=3)
    assert len(frames) == 3
    assert not np.array_equal(frames[0], frames[-1])
    gif = write_gif(frames, tmp_path / "a" / "r.gif", fps=4)
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 3 and im.size == (480, 360)


DARK_GREEN = np.array([10, 80, 30])


@pytest.mark.slow
def test_a_rollout_frame_outlines_the_tasks_goal_range_when_asked():
    env = ToolDesignEnv(task="hook", render_mode="rgb_array")
    try:
        env.reset(seed=0)
        env.step([0.0, 0.0, 0.0])
        plain = env.render_rollout(frames=2)[0]
        outlined = env.render_rollout(frames=2, show_goal_range=True)[0]
        assert _share_near(plain, DARK_GREEN, tol=2) == 0
        assert _share_near(outlined, DARK_GREEN, tol=2) > 1e-4  # the outline is drawn
        with pytest.raises(TypeError, match="show_goal_range must be True or False"):
            env.render_rollout(frames=2, show_goal_range="yes")
    finally:
        env.close()


def test_render_refuses_a_bad_region():
    world = BulletWorld(render_mode="rgb_array")
    try:
        for bad in (((0, 0), (1,)), ((1.0, 0.0), (0.0, 1.0)), ((0, float("nan")), (1, 1))):
            with pytest.raises(ValueError, match="region must be"):
                world.render(region=bad)
    finally:
        world.close()


@pytest.mark.slow
def test_render_without_rgb_array_mode_returns_none():
    env = ToolDesignEnv()
    try:
        env.reset(seed=0)
        assert env.render() is None
        with pytest.raises(RuntimeError, match="render_mode='rgb_array'"):
            env.render_rollout()
    finally:
        env.close()


@pytest.mark.slow
def test_render_rollout_bad_input(env):
    env.reset(seed=0)
    with pytest.raises(RuntimeError, match="call step"):
        env.render_rollout()
    for bad in (1, 0, 2.5, True, "3"):
        with pytest.raises(ValueError, match="frames"):
            env.render_rollout(frames=bad)


@pytest.mark.slow
def test_world_render_bad_input():
    world = BulletWorld(render_mode="rgb_array")
    try:
        with pytest.raises(ValueError, match="width"):
            world.render(width=0)
        with pytest.raises(ValueError, match="goal"):
            world.render(goal=(0.0, np.nan, 0.0))
        with pytest.raises(ValueError, match="path"):
            world.render(path=np.zeros((4, 2)))
    finally:
        world.close()


@pytest.mark.slow
def test_projection_puts_the_camera_target_at_the_image_centre():
    world = BulletWorld(render_mode="rgb_array")
    try:
        c = world.client
        target = (0.4, 0.7, 0.0)
        view = c.computeViewMatrixFromYawPitchRoll(target, 2.4, 200.0, -50.0, 0.0, 2)
        proj = c.computeProjectionMatrixFOV(50.0, 480 / 360, 0.05, 20.0)
    finally:
        world.close()
    np.testing.assert_allclose(_project(np.array([target]), view, proj, 480, 360), [[240, 180]])


@pytest.mark.parametrize(
    "frames, fps",
    [
        ([], 8),
        ([np.zeros((4, 4, 3), np.uint8), np.zeros((5, 4, 3), np.uint8)], 8),
        ([np.zeros((4, 4), np.uint8)], 8),
        ([np.zeros((4, 4, 3), float)], 8),
        ([np.zeros((4, 4, 3), np.uint8)], 0),
        ([np.zeros((4, 4, 3), np.uint8)], True),
    ],
)
def test_write_gif_bad_input(frames, fps, tmp_path):
    with pytest.raises(ValueError):
        write_gif(frames, tmp_path / "x.gif", fps=fps)
    assert not (tmp_path / "x.gif").exists()


@pytest.mark.slow
def test_rollout_gif_refuses_bad_input_before_simulating(tmp_path):
    with pytest.raises(ValueError, match="outside the action space"):
        rollout_gif([0.0, 0.0, 3.0], tmp_path / "x.gif")
    with pytest.raises(ValueError, match="frames"):
        rollout_gif([0.0, 0.0, 0.0], tmp_path / "x.gif", frames=1)
    assert not (tmp_path / "x.gif").exists()


@pytest.mark.slow
def test_a_design_run_passes_its_task_to_the_video_and_survives_a_failing_one(
    tmp_path, monkeypatch
):
    import benchmarks.design.video
    from benchmarks.design import DesignConfig
    from benchmarks.design.loop import _video

    seen = {}

    def fake(coeffs, path, **kwargs):
        seen.update(kwargs)
        ToolDesignEnv(**{k: v for k, v in kwargs.items() if k != "frames"}).close()
        raise RuntimeError("no renderer")

    monkeypatch.setattr(benchmarks.design.video, "rollout_gif", fake)
    config = DesignConfig(goal=(0.2, 1.2, 0.1), goal_precision=40.0, box_mass=0.5)
    with pytest.warns(UserWarning, match="rollout.gif not written: RuntimeError: no renderer"):
        _video(config, np.zeros(3), tmp_path / "rollout.gif")
    assert seen["goal"] == (0.2, 1.2, 0.1) and seen["goal_precision"] == 40.0
    assert seen["box_mass"] == 0.5


def test_write_gif_into_a_folder_is_refused_and_leaves_no_temporary_file(tmp_path):
    # It wrote a fixed-name x.gif.tmp, then failed renaming it onto the folder and left it.
    target = tmp_path / "video.gif"
    target.mkdir()
    frames = [np.zeros((4, 4, 3), np.uint8)] * 2
    with pytest.raises(IsADirectoryError, match="is a folder"):
        write_gif(frames, target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["video.gif"]
    assert list(target.iterdir()) == []


def test_caption_frame_names_the_design_and_rings_the_goal(env):
    from benchmarks.design.video import caption_frame

    env.reset(seed=0)
    frame = env.render()
    captioned = caption_frame(
        frame, "tool C = (0, 0, 0), F = 8,611   t = 0.0 s of 14.2 s", (0.0, 1.5, 0.1)
    )
    assert captioned.shape == (360 + 44, 480, 3) and captioned.dtype == np.uint8
    # The frame itself is kept, but for the ring and the word "goal".
    assert np.mean(np.all(captioned[22:-22] == frame, axis=2)) > 0.95
    # The caption strip and the key hold dark text; the goal is ringed in red on the frame.
    assert np.mean(captioned[:22] < 100) > 0.01 and np.mean(captioned[-22:] < 100) > 0.01
    ring = np.all(np.abs(captioned[22:-22].astype(int) - (200, 0, 0)) < 30, axis=2)
    assert ring.sum() > 20
    # A frame without the goal is captioned, with nothing ringed.
    empty = caption_frame(np.full((360, 480, 3), 200, np.uint8), "x", None)
    assert not np.any(np.all(np.abs(empty[22:-22].astype(int) - (200, 0, 0)) < 30, axis=2))


@pytest.mark.slow
def test_rollout_gif_frames_carry_the_caption(tmp_path):
    from PIL import Image

    gif = rollout_gif([0.0, 0.0, 0.0], tmp_path / "r.gif", frames=2)
    with Image.open(gif) as im:
        assert im.size == (480, 404) and im.n_frames == 2
