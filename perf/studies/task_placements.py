"""How the obstacle task's post and the puck's friction were chosen (docs/tasks.md).

1. **Post placements.** For each placement of the post (``--posts``, radius m and angle degrees
   from the base's x axis; 0.1 x 0.1 x 0.4 m) in the push scene, each design of
   :data:`DESIGNS` (the named ones of ``task_baselines`` and small forward bows): where the box
   ends, its distance to the push goal (0, 1.5) and the obstacle goal (-0.25, 1.3), F, and the
   largest distance of the grasp point from its plan (a tool held up by the post is pushed off
   it by centimetres; a free one tracks within millimetres).
2. **Walls in the box's way** (``--walls``, none by default): a wall 0.05 m thick standing
   radially at an angle (degrees) from radius r0 to r1 (m), of a height (m), in the push scene:
   the same table, with the box's height at the end (0.1 m upright; less, tipped). A wall of
   the post's height in the box's way stops every tool (the tool sweeps every radius it
   reaches); a curb lower than the tool (its section's bottom is 0.065 m above the floor) stops
   the box alone. Kept as a record of what was tried for the obstacle task (docs/tasks.md).
3. **Puck friction.** For each friction of the puck (``--frictions``): the relative range of
   F over the 5 nudged scenes of ``tooldesign retest`` (``RetestConfig().scenes``) for the
   straight tool and 8 random designs (seed 0), median and largest.

Run: ``python -m perf.studies.task_placements [--posts 1.6:55 1.75:45 1.75:60 1.75:70]
[--frictions 0.4 0.2] [--walls 60:1.3:1.7:0.04 ...]``; an option given without values skips its
part (``--posts --frictions --walls 60:1.3:1.7:0.04`` measures that wall alone). About 0.5 s an
evaluation: 2 minutes with the defaults.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from benchmarks.suites.retest import RetestConfig
from tooldesign_env import ToolDesignEnv, default_bounds
from tooldesign_env.tasks import Obstacle, get_task

#: The designs of the placement table, (c1, c2, c3).
DESIGNS: dict[str, tuple[float, float, float]] = {
    "straight": (0.0, 0.0, 0.0),
    "bow (0, 0.2, 0)": (0.0, 0.2, 0.0),
    "bow (0, 0.6, 0)": (0.0, 0.6, 0.0),
    "bow back (0, -0.6, 0)": (0.0, -0.6, 0.0),
    "tilt (0, 0, 0.2)": (0.0, 0.0, 0.2),
    "hook (0.4, 1.4, 0.18)": (0.4, 1.4, 0.18),
    "hook (0, 1.5, 0)": (0.0, 1.5, 0.0),
    "back (-1.4, 0.8, 0)": (-1.4, 0.8, 0.0),
}


def _post(text: str) -> tuple[float, float]:
    radius, _, angle = text.partition(":")
    return float(radius), float(angle)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument(
        "--posts", type=_post, nargs="*", default=[(1.6, 55), (1.75, 45), (1.75, 60), (1.75, 70)]
    )
    parser.add_argument("--frictions", type=float, nargs="*", default=[0.4, 0.2])
    parser.add_argument(
        "--walls", type=_wall, nargs="*", default=[],
        help="walls as angle:r0:r1:height (degrees, m, m, m)",
    )
    return parser.parse_args(argv)


def _wall(text: str) -> tuple[float, float, float, float]:
    parts = text.split(":")
    if len(parts) != 4:
        raise argparse.ArgumentTypeError(f"a wall is angle:r0:r1:height, got {text!r}")
    angle, r0, r1, height = (float(v) for v in parts)
    if not 0 < r0 < r1 or height <= 0:
        raise argparse.ArgumentTypeError(f"a wall needs 0 < r0 < r1 and height > 0, got {text!r}")
    return angle, r0, r1, height


def _table(env: ToolDesignEnv) -> None:
    """One row per design: where the box ends (and how high), distances, F, off its plan."""
    print("| design | box ends at | box z | to (0, 1.5) | to (-0.25, 1.3) | F | off its plan (m) |")
    print("|---|---|---|---|---|---|---|")
    for label, design in DESIGNS.items():
        info = env.step(np.asarray(design, dtype=float))[4]
        if not info["valid"]:
            print(f"| {label} | unusable: {info['invalid_reason']} | | | | | |")
            continue
        end = info["box_trajectory"][-1]
        to_obstacle_goal = float(np.linalg.norm(end[:2] - (-0.25, 1.3)))
        print(
            f"| {label} | ({end[0]:.3f}, {end[1]:.3f}) | {end[2]:.3f} | "
            f"{info['final_distance']:.3f} | {to_obstacle_goal:.3f} | "
            f"{info['free_energy']:.0f} | {float(np.max(info['tracking_error'])):.3f} |"
        )


def walls(specs: list[tuple[float, float, float, float]]) -> None:
    """Print where each design leaves the box with a wall across its way (see above)."""
    base = get_task("obstacle")
    for angle, r0, r1, height in specs:
        t = math.radians(angle)
        middle = (r0 + r1) / 2
        wall = Obstacle(
            name="wall",
            position=(middle * math.cos(t), middle * math.sin(t)),
            size=(r1 - r0, 0.05, height),
            yaw=t,
        )
        task = replace(base, name="wall", obstacles=(wall,), accepts_any_goal=True)
        env = ToolDesignEnv(task=task, goal=(0.0, 1.5, 0.1), info_series=True)
        env.reset(seed=0)
        print(f"## wall at {angle:g} degrees from radius {r0:g} to {r1:g} m, {height:g} m high")
        try:
            _table(env)
        finally:
            env.close()
        # The noise floor there: a box tipped onto a curb may land either way.
        scenes = RetestConfig().scenes(task.scene)
        envs = [ToolDesignEnv(task=task, goal=(0.0, 1.5, 0.1), scene=sc) for sc in scenes]
        ranges = []
        try:
            for label, design in DESIGNS.items():
                values = []
                for scene_env in envs:
                    scene_env.reset(seed=0)
                    values.append(float(scene_env.step(np.asarray(design))[4]["free_energy"]))
                spread = (max(values) - min(values)) / abs(float(np.mean(values)))
                ranges.append(f"{label} {100 * spread:.2f} %")
        finally:
            for scene_env in envs:
                scene_env.close()
        print(f"relative range of F over {len(scenes)} nudged scenes: " + ", ".join(ranges))
        print()


def placements(posts: list[tuple[float, float]]) -> None:
    """Print where each design leaves the box with the post at each placement."""
    base = get_task("obstacle")
    for radius, angle in posts:
        where = (radius * math.cos(math.radians(angle)), radius * math.sin(math.radians(angle)))
        post = Obstacle(name="post", position=where, size=(0.1, 0.1, 0.4))
        task = replace(base, name="placement", obstacles=(post,), accepts_any_goal=True)
        env = ToolDesignEnv(task=task, goal=(0.0, 1.5, 0.1), info_series=True)
        env.reset(seed=0)
        print(f"## post at radius {radius:g} m, {angle:g} degrees")
        print("| design | box ends at | to (0, 1.5) | to (-0.25, 1.3) | F | off its plan (m) |")
        print("|---|---|---|---|---|---|")
        try:
            for label, design in DESIGNS.items():
                info = env.step(np.asarray(design, dtype=float))[4]
                if not info["valid"]:
                    print(f"| {label} | unusable: {info['invalid_reason']} | | | | |")
                    continue
                end = info["box_trajectory"][-1, :2]
                to_obstacle_goal = float(np.linalg.norm(end - (-0.25, 1.3)))
                print(
                    f"| {label} | ({end[0]:.3f}, {end[1]:.3f}) | {info['final_distance']:.3f} | "
                    f"{to_obstacle_goal:.3f} | {info['free_energy']:.0f} | "
                    f"{float(np.max(info['tracking_error'])):.3f} |"
                )
        finally:
            env.close()
        print()


def puck_noise(frictions: list[float]) -> None:
    """Print the puck's noise floor of F at each friction."""
    puck = get_task("puck")
    bounds = default_bounds(3)
    rng = np.random.default_rng(np.random.SeedSequence(0))
    designs = [np.zeros(3), *rng.uniform(bounds[:, 0], bounds[:, 1], size=(8, 3))]
    for friction in frictions:
        scene = replace(puck.scene, box_friction=friction)
        envs = [ToolDesignEnv(task="puck", scene=s) for s in RetestConfig().scenes(scene)]
        ranges = []
        try:
            for design in designs:
                values = []
                for env in envs:
                    env.reset(seed=0)
                    values.append(float(env.step(design)[4]["free_energy"]))
                ranges.append((max(values) - min(values)) / abs(float(np.mean(values))))
        finally:
            for env in envs:
                env.close()
        print(
            f"puck friction {friction:g}: relative range of F over 5 nudged scenes, median "
            f"{100 * float(np.median(ranges)):.2f} %, largest {100 * max(ranges):.2f} % "
            f"({len(designs)} designs)"
        )


def main(argv: list[str] | None = None) -> int:
    """Print both tables."""
    args = parse_args(argv)
    placements(args.posts)
    puck_noise(args.frictions)
    walls(args.walls)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
