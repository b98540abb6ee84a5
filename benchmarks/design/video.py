"""Rollout videos: a GIF of a design using its tool, rendered headless.

PIL (Pillow, a dependency of Matplotlib) writes the GIF; PyBullet's software renderer draws the
frames, so no display and no video codec are needed.
"""

from __future__ import annotations

import io
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.storage import atomic_write_bytes
from benchmarks.storage.atomic import check_file_target

__all__ = ["caption_frame", "rollout_gif", "write_gif"]


def write_gif(
    frames: Sequence[np.ndarray], path: str | os.PathLike[str], *, fps: float = 8.0
) -> Path:
    """Write RGB frames as a looping GIF.

    Args:
        frames: at least one (height, width, 3) uint8 array, all of the same shape.
        path: the file to write (parent folders are created).
        fps: frames per second, > 0.

    Returns:
        The path written.

    Raises:
        ValueError: no frames, frames of different or wrong shapes or dtypes, or a bad ``fps``.
        IsADirectoryError: ``path`` is a folder.
        NotADirectoryError: a file stands where one of its parent folders would be.
    """
    from PIL import Image

    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not 0 < fps < 1000:
        raise ValueError(f"fps must be a number in (0, 1000), got {fps!r}")
    frames = list(frames)
    if not frames:
        raise ValueError("frames is empty: a GIF needs at least one frame")
    shape = np.shape(frames[0])
    for i, frame in enumerate(frames):
        arr = np.asarray(frame)
        if arr.ndim != 3 or arr.shape[2] != 3 or arr.dtype != np.uint8 or arr.shape != shape:
            raise ValueError(
                f"frame {i} must be a (height, width, 3) uint8 array of shape {shape}, got "
                f"{arr.shape} {arr.dtype}"
            )
    path = check_file_target(path)  # before the frames are encoded
    images = [Image.fromarray(np.asarray(f)) for f in frames]
    data = io.BytesIO()
    images[0].save(
        data,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=int(round(1000.0 / fps)),
        loop=0,
    )
    return atomic_write_bytes(path, data.getvalue())


def rollout_gif(
    coeffs: Any,
    path: str | os.PathLike[str],
    *,
    frames: int = 30,
    fps: float = 8.0,
    **env_kwargs: Any,
) -> Path:
    """Simulate a design once in a rendering env and write its rollout as a GIF.

    The rollout is simulated in its own env (``render_mode="rgb_array"``), so the scores a
    caller computed elsewhere are untouched. The frames are a kinematic replay of the recorded
    joint and box positions (see ``ToolDesignEnv.render_rollout``), with the goal (green sphere,
    ringed and named) and the box path so far (blue line); each frame has a caption strip (the
    design, its F and the time shown, s) and a key (:func:`caption_frame`). About 0.5 s of
    rendering a frame on one core.

    Args:
        coeffs: the design (c1, ..., cn), highest power first, within the env's bounds.
        path: the GIF to write.
        frames: number of frames, >= 2.
        fps: frames per second.
        **env_kwargs: arguments of ``ToolDesignEnv`` (goal, goal_precision, box_mass, bounds,
            tool, ...).

    Returns:
        The path written.

    Raises:
        ValueError: a bad design, ``frames`` or ``fps`` (before anything is simulated).
    """
    from tooldesign_env import ToolDesignEnv

    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 2:
        raise ValueError(f"frames must be an int >= 2, got {frames!r}")
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not 0 < fps < 1000:
        raise ValueError(f"fps must be a number in (0, 1000), got {fps!r}")
    env = ToolDesignEnv(render_mode="rgb_array", **{**env_kwargs, "info_series": True})
    try:
        env.reset(seed=0)
        info = env.step(env.check_action(coeffs))[4]
        images = env.render_rollout(frames=frames)
    finally:
        env.close()
    goal = tuple(float(v) for v in np.asarray(info["goal"], dtype=float))
    times = np.asarray(info.get("times", ()), dtype=np.float64)
    if len(images) > 1 and len(times):
        # The frames render_rollout picks: evenly spaced control steps.
        steps = np.unique(np.linspace(0, len(times) - 1, int(frames)).round().astype(int))
        shown = times[steps] if len(steps) == len(images) else np.zeros(len(images))
    else:
        shown = np.zeros(len(images))
    end = float(times[-1]) if len(times) else 0.0
    text = ", ".join(f"{float(c):.3g}" for c in np.atleast_1d(np.asarray(coeffs, dtype=float)))
    head = f"tool C = ({text}), F = {float(info['free_energy']):,.0f}"
    captioned = [
        caption_frame(image, f"{head}   t = {t:.1f} s of {end:.1f} s", goal)
        for image, t in zip(images, shown, strict=True)
    ]
    return write_gif(captioned, path, fps=fps)


_GOAL_RGB = (0.1, 0.75, 0.2)  # the colour of the goal sphere BulletWorld.render draws
_PATH_RGB = (30, 80, 220)  # the colour of its box path


def _goal_pixels(frame: np.ndarray) -> tuple[int, int, int] | None:
    """Centre (x, y) and radius in pixels of the green goal sphere in a frame, if it shows."""
    rgb = frame.astype(np.int16)
    red, green, blue = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    mask = (green > 90) & (green > red + 50) & (green > blue + 50)
    if mask.sum() < 6:
        return None
    ys, xs = np.nonzero(mask)
    radius = max(int(xs.max() - xs.min()), int(ys.max() - ys.min())) // 2 + 3
    return int(xs.mean()), int(ys.mean()), radius


def caption_frame(
    frame: np.ndarray, caption: str, goal: Sequence[float] | None = None
) -> np.ndarray:
    """A frame with a caption strip above and a key below; the goal sphere ringed and named.

    Args:
        frame: (height, width, 3) uint8, a frame of ``ToolDesignEnv.render``.
        caption: One line: the design, its F and the time shown.
        goal: X^g (x, y, z) in m, named in the key; None names no coordinates.

    Returns:
        (height + 44, width, 3) uint8.
    """
    from PIL import Image, ImageDraw, ImageFont

    height, width = frame.shape[:2]
    strip = 22
    canvas = Image.new("RGB", (width, height + 2 * strip), (255, 255, 255))
    canvas.paste(Image.fromarray(np.ascontiguousarray(frame)), (0, strip))
    draw = ImageDraw.Draw(canvas)
    try:  # Pillow >= 10.1 scales its built-in font
        font: Any = ImageFont.load_default(size=13)
    except TypeError:
        font = ImageFont.load_default()
    draw.text((6, 4), caption, fill=(0, 0, 0), font=font)
    found = _goal_pixels(frame)
    if found is not None:
        x, y, r = found
        y += strip
        draw.ellipse((x - r, y - r, x + r, y + r), outline=(200, 0, 0), width=2)
        box = draw.textbbox((x + r + 4, y - r - 14), "goal", font=font)
        draw.rectangle((box[0] - 2, box[1] - 1, box[2] + 2, box[3] + 1), fill=(255, 255, 255))
        draw.text((x + r + 4, y - r - 14), "goal", fill=(200, 0, 0), font=font)
    green = tuple(int(255 * v) for v in _GOAL_RGB)
    base = height + strip + 6
    draw.ellipse((6, base, 16, base + 10), fill=green)
    where = "" if goal is None else " X^g = (" + ", ".join(f"{v:g}" for v in goal) + ") m"
    draw.text((20, base - 2), f"goal{where}", fill=(0, 0, 0), font=font)
    left = 40 + int(draw.textlength(f"goal{where}", font=font))
    draw.line((left, base + 5, left + 18, base + 5), fill=_PATH_RGB, width=3)
    draw.text((left + 22, base - 2), "box path so far", fill=(0, 0, 0), font=font)
    return np.asarray(canvas, dtype=np.uint8)
