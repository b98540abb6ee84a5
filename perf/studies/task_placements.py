"""How the obstacle task's curb and the puck's friction were chosen (docs/tasks.md).

1. **Post placements** (the obstacle task's first design, kept as its record). For each
   placement of a post (``--posts``, radius m and angle degrees from the base's x axis; 0.1 x
   0.1 x 0.4 m) in the push scene, each design of :data:`DESIGNS` (the named ones of
   ``task_baselines`` and small forward bows): where the box ends, its distance to the push
   goal (0, 1.5) and to that design's goal (-0.25, 1.3), F, and the largest distance of the
   grasp point from its plan (a tool held up by the post is pushed off it by centimetres; a
   free one tracks within millimetres).
2. **Walls and curbs in the box's way** (``--walls``, none by default): a wall 0.05 m thick
   standing radially at an angle (degrees) from radius r0 to r1 (m), of a height (m), with a
   friction (default 0.5), in the push scene. Per wall:

   * the table of 1. for :data:`DESIGNS`, with the box's height at the end (0.1 m standing,
     less tipped onto a curb, 0.05 m lying on its side) and the distance to the obstacle
     task's default goal;
   * F's relative range over the 5 nudged scenes of ``tooldesign retest`` for each of
     :data:`DESIGNS`, and for the noise-floor set of ``task_baselines`` (the straight tool and
     the first 8 usable of its 64 random designs, seed 0): median and largest;
   * those 64 random designs: how many end standing (upright and on the floor, as
     ``TaskDefinition.succeeded`` asks), tipped (the range of their height and tilt), lying,
     or shot away (more than :data:`SHOT_AWAY` m from the base), and how many succeed
     (standing, within the obstacle task's tolerance) at each goal of a grid around the
     obstacle task's goal range, the range marked; and how many that do not stand end within
     the tolerance of a goal of the range (the boxes a success test of the distance alone
     would call successes);
   * whether the wall stands between the box's start and every goal of the range, as seen
     along the box's way: its angle between the start's and each goal's angle about the base,
     and its radii spanning the box's way (printed once: the radii at which the straight tool
     carries the box in the push scene).

   A wall of a post's height in the box's way stops every tool (the tool sweeps every radius
   it reaches); a curb lower than the tool (its section's bottom is 0.065 m above the floor)
   stops the box alone. The obstacle task's curb is one of these (docs/tasks.md).
3. **Puck friction.** For each friction of the puck (``--frictions``): the relative range of
   F over the 5 nudged scenes of ``tooldesign retest`` (``RetestConfig().scenes``) for the
   straight tool and 8 random designs (seed 0), median and largest.

Run: ``python -m perf.studies.task_placements [--posts 1.6:55 1.75:45 1.75:60 1.75:70]
[--frictions 0.4 0.2] [--walls 60:1.3:1.7:0.04:1.0 ...]``; an option given without values skips
its part (``--posts --frictions --walls 60:1.3:1.7:0.04`` measures that curb alone). About 0.1
to 0.5 s an evaluation: 2 minutes with the defaults, about 170 evaluations a wall.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from benchmarks.suites.retest import RetestConfig
from tooldesign_env import ToolDesignEnv, default_bounds
from tooldesign_env.tasks import Obstacle, TaskDefinition, get_task

#: Where the box ended when a tool shot it away: farther than this from the base, m (the tool
#: reaches 1.9 m; the post at 1.6 m, 55 degrees once sent the box 5.3 m).
SHOT_AWAY = 2.0

#: The goal of the obstacle task's first design (the post beyond the box's way), (x, y) m: the
#: post placements are measured against it, as they were then.
POST_GOAL = (-0.25, 1.3)

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
        help="walls as angle:r0:r1:height[:friction] (degrees, m, m, m; friction 0.5)",
    )
    return parser.parse_args(argv)


def _wall(text: str) -> tuple[float, float, float, float, float]:
    parts = text.split(":")
    if len(parts) not in (4, 5):
        raise argparse.ArgumentTypeError(
            f"a wall is angle:r0:r1:height[:friction], got {text!r}"
        )
    try:
        angle, r0, r1, height, friction = (float(v) for v in [*parts, "0.5"][:5])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a wall is angle:r0:r1:height[:friction] in numbers, got {text!r}"
        ) from None
    if not 0 < r0 < r1 or height <= 0 or friction < 0:
        raise argparse.ArgumentTypeError(
            f"a wall needs 0 < r0 < r1, height > 0 and friction >= 0, got {text!r}"
        )
    return angle, r0, r1, height, friction


def _table(env: ToolDesignEnv, goal: tuple[float, float]) -> None:
    """One row per design: where the box ends (and how high), distances, F, off its plan."""
    print(f"| design | box ends at | box z | to (0, 1.5) | to ({goal[0]:g}, {goal[1]:g}) | F | "
          "off its plan (m) |")
    print("|---|---|---|---|---|---|---|")
    for label, design in DESIGNS.items():
        info = env.step(np.asarray(design, dtype=float))[4]
        if not info["valid"]:
            print(f"| {label} | unusable: {info['invalid_reason']} | | | | | |")
            continue
        end = info["box_trajectory"][-1]
        to_goal = float(np.linalg.norm(end[:2] - goal))
        print(
            f"| {label} | ({end[0]:.3f}, {end[1]:.3f}) | {end[2]:.3f} | "
            f"{info['final_distance']:.3f} | {to_goal:.3f} | "
            f"{info['free_energy']:.0f} | {float(np.max(info['tracking_error'])):.3f} |"
        )


def _random_designs(n: int = 64, seed: int = 0) -> np.ndarray:
    """The random designs of ``task_baselines`` (the same draw): (n, 3)."""
    bounds = default_bounds(3)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    designs: np.ndarray = rng.uniform(bounds[:, 0], bounds[:, 1], size=(n, 3))
    return designs


def _between(wall: tuple[float, float, float, float, float], task: TaskDefinition) -> str:
    """Whether the wall stands between the box's start and every goal, along the box's way."""
    angle, r0, r1 = wall[:3]
    start = task.box_start()
    start_angle = math.degrees(math.atan2(start[1], start[0]))
    (x0, y0, _), (x1, y1, _) = task.goal_low, task.goal_high
    corners = [(x, y) for x in (x0, x1) for y in (y0, y1)]
    goal_angles = [math.degrees(math.atan2(y, x)) for x, y in corners]
    # The box's footprint reaches its half-diagonal past its centre's angle.
    margin = math.degrees(math.hypot(0.05, 0.05) / math.hypot(start[0], start[1]))
    between = start_angle + margin < angle < min(goal_angles)
    return (
        f"the wall at {angle:g} degrees, radius {r0:g} to {r1:g} m; the box starts at "
        f"{start_angle:.1f} degrees (its corners to {start_angle + margin:.1f}), the goal "
        f"range's corners are at {min(goal_angles):.1f} to {max(goal_angles):.1f} degrees: "
        f"{'between' if between else 'NOT between'} the start and every goal"
    )


def _random_outcomes(env: ToolDesignEnv, task: TaskDefinition) -> None:
    """Where the 64 random designs leave the box, and which goals they reach."""
    ends, tilts = [], []
    for design in _random_designs():
        info = env.step(design)[4]
        if info["valid"]:
            ends.append(info["box_trajectory"][-1].copy())
            tilts.append(math.degrees(info["final_tilt"]))
    end, tilt = np.array(ends), np.array(tilts)
    standing = np.array(
        [
            task.succeeded(0.0, e[2], final_tilt=math.radians(t))
            for e, t in zip(end, tilt, strict=True)
        ]
    )
    lying = end[:, 2] < 0.06
    away = np.hypot(end[:, 0], end[:, 1]) > SHOT_AWAY
    tipped = ~standing & ~lying
    heights = (
        f" (its centre {end[tipped, 2].min():.3f} to {end[tipped, 2].max():.3f} m high, its up "
        f"axis {tilt[tipped].min():.0f} to {tilt[tipped].max():.0f} degrees from the vertical)"
        if tipped.any()
        else ""
    )
    print(
        f"64 random designs (seed 0): {len(end)} usable; the box ends standing "
        f"{int(standing.sum())}, tipped {int(tipped.sum())}{heights}, lying "
        f"{int(lying.sum())}; shot away (> {SHOT_AWAY:g} m from the base) {int(away.sum())}"
    )
    (x0, y0, _), (x1, y1, _) = task.goal_low, task.goal_high
    xs = np.round(np.arange(-0.45, -0.049, 0.05), 3)
    ys = np.round(np.arange(0.65, 1.301, 0.05), 3)
    print(f"successes of the random designs at each goal (standing, within {task.tolerance:g} "
          f"m; * in the goal range, x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}] m):")
    print("| y \\ x | " + " | ".join(f"{x:g}" for x in xs) + " |")
    print("|---" * (len(xs) + 1) + "|")
    for y in ys:
        cells = []
        for x in xs:
            near = np.hypot(end[:, 0] - x, end[:, 1] - y) <= task.tolerance
            inside = x0 - 1e-9 <= x <= x1 + 1e-9 and y0 - 1e-9 <= y <= y1 + 1e-9
            cells.append(f"{int((near & standing).sum())}{'*' if inside else ''}")
        print(f"| {y:g} | " + " | ".join(cells) + " |")
    # Boxes not standing that a success radius alone would count, at some goal of the range.
    gx = np.clip(end[:, 0], x0, x1)
    gy = np.clip(end[:, 1], y0, y1)
    false = (np.hypot(end[:, 0] - gx, end[:, 1] - gy) <= task.tolerance) & ~standing
    print(f"not standing but within {task.tolerance:g} m of a goal of the range: "
          f"{int(false.sum())}")


def _nudged_ranges(task: TaskDefinition, designs: list[np.ndarray]) -> list[float]:
    """F's relative range over the 5 nudged scenes of ``tooldesign retest``, per design."""
    scenes = RetestConfig().scenes(task.scene)
    envs = [ToolDesignEnv(task=task, goal=task.goal, scene=sc) for sc in scenes]
    ranges = []
    try:
        for design in designs:
            values = []
            for scene_env in envs:
                scene_env.reset(seed=0)
                values.append(float(scene_env.step(np.asarray(design))[4]["free_energy"]))
            ranges.append((max(values) - min(values)) / abs(float(np.mean(values))))
    finally:
        for scene_env in envs:
            scene_env.close()
    return ranges


def box_way() -> None:
    """Print the radii at which the straight tool carries the box in the push scene."""
    env = ToolDesignEnv(task="push", info_series=True)
    env.reset(seed=0)
    try:
        path = env.step(np.zeros(3))[4]["box_trajectory"]
    finally:
        env.close()
    radius = np.hypot(path[:, 0], path[:, 1])
    angle = np.degrees(np.arctan2(path[:, 1], path[:, 0]))
    moved = angle > angle[0] + 5.0  # once the sweep has carried it on
    at = {a: float(radius[np.argmax(angle >= a)]) for a in (45, 60, 75, 90)}
    print(
        f"the box's way (push scene, the straight tool): from radius {radius[0]:.2f} m at "
        f"{angle[0]:.0f} degrees it is carried at {radius[moved].min():.2f} to "
        f"{radius[moved].max():.2f} m (" + ", ".join(f"{r:.2f} m at {a} degrees"
                                                  for a, r in at.items())
        + f"), to ({path[-1, 0]:.3f}, {path[-1, 1]:.3f})"
    )
    print()


def walls(specs: list[tuple[float, float, float, float, float]]) -> None:
    """Print where each design leaves the box with a wall across its way (see above)."""
    base = get_task("obstacle")
    goal = (base.goal[0], base.goal[1])
    if specs:
        box_way()
    for spec in specs:
        angle, r0, r1, height, friction = spec
        t = math.radians(angle)
        middle = (r0 + r1) / 2
        wall = Obstacle(
            name="wall",
            position=(middle * math.cos(t), middle * math.sin(t)),
            size=(r1 - r0, 0.05, height),
            yaw=t,
            friction=friction,
        )
        task = replace(base, name="wall", obstacles=(wall,))
        push_goal = replace(task, accepts_any_goal=True)
        env = ToolDesignEnv(task=push_goal, goal=(0.0, 1.5, 0.1), info_series=True)
        env.reset(seed=0)
        print(
            f"## wall at {angle:g} degrees from radius {r0:g} to {r1:g} m, {height:g} m high, "
            f"friction {friction:g}"
        )
        try:
            _table(env, goal)
            print()
            _random_outcomes(env, task)
        finally:
            env.close()
        print(_between(spec, task))
        # The noise floor there: a box tipped onto a curb may land either way.
        ranges = _nudged_ranges(task, [np.asarray(d, dtype=float) for d in DESIGNS.values()])
        print(
            "relative range of F over 5 nudged scenes: "
            + ", ".join(
                f"{label} {100 * r:.2f} %" for label, r in zip(DESIGNS, ranges, strict=True)
            )
        )
        check = ToolDesignEnv(task=task)
        check.reset(seed=0)
        try:
            usable = [d for d in _random_designs() if check.step(d)[4]["valid"]][:8]
        finally:
            check.close()
        floor = _nudged_ranges(task, [np.zeros(3), *usable])
        print(
            f"noise floor of task_baselines' set (the straight tool and {len(usable)} random "
            f"designs), at the goal ({goal[0]:g}, {goal[1]:g}): median "
            f"{100 * float(np.median(floor)):.2f} %, largest {100 * max(floor):.2f} %"
        )
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
                to_obstacle_goal = float(np.linalg.norm(end - POST_GOAL))
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
