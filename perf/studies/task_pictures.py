"""The pictures of docs/tasks.md: each task's scene, and its best measured design's rollout.

For every task in ``--baselines`` (the JSON ``perf.studies.task_baselines --json`` writes), this
renders headless (PyBullet's software renderer, as ``tooldesign design`` does):

* ``<task>-scene.png``: the start scene: the arm holding the straight tool, the box, the fixed
  obstacles (grey), the goal (the green sphere) and the task's goal range (outlined in dark
  green), from the env's camera (``ToolDesignEnv.render_rollout``'s first frame);
* ``<task>-best.gif``: the rollout of the CMA-ES design the baselines found, with the goal and
  the box path (``benchmarks.design.video.rollout_gif``, the GIF ``tooldesign design`` writes).

With ``--succeeding FILE`` (the JSON ``perf.studies.task_plans --json`` writes), for every task
in it:

* ``<task>-success.gif``: the rollout, under the task's own plan, of the lowest-F random design
  that succeeds at the task's default goal (F's lowest design fails every task at the
  baselines' budget, so the ``-best`` GIFs show no task solved).

Run: ``python -m perf.studies.task_pictures [--baselines FILE] [--succeeding FILE] --out
docs/images/tasks [--task NAME ...]``, at least one of the two files. About 20 s per task for
the baselines' pictures, 6 s of CPU for a ``-success`` GIF.
"""

from __future__ import annotations

import argparse
import io
import json
from pathlib import Path

from benchmarks.design.video import rollout_gif
from benchmarks.storage import atomic_write_bytes
from tooldesign_env import ToolDesignEnv


def scene_png(task: str, path: Path) -> None:
    """Render the task's start scene and write it as a PNG.

    The first frame of the straight tool's rollout: the arm at its start pose holding the tool,
    the box, the fixed obstacles (grey), the default goal (the green sphere, ringed) and the
    task's goal range outlined on the floor in dark green, with a caption and a key.
    """
    import numpy as np
    from PIL import Image

    from benchmarks.design.video import caption_frame

    env = ToolDesignEnv(task=task, render_mode="rgb_array", info_series=True)
    try:
        env.reset(seed=0)
        info = env.step(np.zeros(env.action_space.shape, dtype=np.float64))[4]
        frame = env.render_rollout(frames=2, show_goal_range=True)[0]
    finally:
        env.close()
    goal = tuple(float(v) for v in np.asarray(info["goal"], dtype=float))
    caption = f"{task}: start, straight tool in hand; goal range outlined in dark green"
    buffer = io.BytesIO()
    Image.fromarray(caption_frame(frame, caption, goal)).save(buffer, format="PNG", optimize=True)
    atomic_write_bytes(path, buffer.getvalue())


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--baselines", type=Path, default=None)
    parser.add_argument(
        "--succeeding",
        type=Path,
        default=None,
        help="task_plans' JSON: render each task's lowest-F succeeding design under pi_0",
    )
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument(
        "--task",
        action="append",
        default=None,
        help="render only this task of --baselines (repeatable; default every one)",
    )
    args = parser.parse_args(argv)
    if args.baselines is None and args.succeeding is None:
        parser.error("give --baselines FILE, --succeeding FILE or both")
    return args


def succeeding_gifs(plans: Path, out: Path, tasks: list[str] | None) -> None:
    """Write ``<task>-success.gif`` for each task of task_plans' JSON ``plans``."""
    results = json.loads(plans.read_text())
    known = [result["task"] for result in results]
    unknown = sorted(set(tasks or ()) - set(known))
    if unknown:
        raise SystemExit(f"--task: {', '.join(unknown)} not in {plans} ({known})")
    out.mkdir(parents=True, exist_ok=True)
    for result in results:
        task = result["task"]
        if tasks and task not in tasks:
            continue
        winner = result["rows"]["pi_0"]["best_success"]
        if winner is None:
            print(f"{task}: no random design succeeds under pi_0, no {task}-success.gif")
            continue
        rollout_gif(winner["design"], out / f"{task}-success.gif", task=task, frames=24)
        print(f"{task}: {out / f'{task}-success.gif'}")


def main(argv: list[str] | None = None) -> int:
    """Write each task's scene still and best design's GIF."""
    args = parse_args(argv)
    if args.succeeding is not None:
        succeeding_gifs(args.succeeding, args.out, args.task)
    if args.baselines is None:
        return 0
    results = json.loads(args.baselines.read_text())
    known = [result["task"] for result in results]
    unknown = sorted(set(args.task or ()) - set(known))
    if unknown:
        raise SystemExit(f"--task: {', '.join(unknown)} not in {args.baselines} ({known})")
    args.out.mkdir(parents=True, exist_ok=True)
    for result in results:
        task = result["task"]
        if args.task and task not in args.task:
            continue
        scene_png(task, args.out / f"{task}-scene.png")
        design = result["cmaes"]["best"]["design"]
        rollout_gif(design, args.out / f"{task}-best.gif", task=task, frames=24)
        print(f"{task}: {args.out / f'{task}-scene.png'}, {args.out / f'{task}-best.gif'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
