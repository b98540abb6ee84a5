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

__all__ = ["rollout_gif", "write_gif"]


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
    joint and box positions (see ``ToolDesignEnv.render_rollout``), with the goal (green sphere)
    and the box path so far (blue line). About 0.5 s of rendering a frame on one core.

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
    env = ToolDesignEnv(render_mode="rgb_array", **env_kwargs)
    try:
        env.reset(seed=0)
        env.step(env.check_action(coeffs))
        images = env.render_rollout(frames=frames)
    finally:
        env.close()
    return write_gif(images, path, fps=fps)
