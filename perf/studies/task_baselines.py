"""Per task: does the tool's shape decide the outcome? Noise floor, spread, success rates, tier.

For one registered task (``--task``, default every built-in one in turn) at its default goal,
p^X = 20, the default (contact) estimator and the default d = 3 bounds, this measures what
docs/tasks.md reports:

1. **Named designs**: the straight tool C = 0 and a few hand-picked cubics (a bow, hooks, a curl,
   a tool bent backward): F, the final distance and success.
2. **Random designs**: ``--random`` (64) designs drawn uniformly in the bounds with ``--seed``:
   the spread of F (min, quartiles, max over the usable ones), the share that is usable, and
   the success rate (an unusable design counts as a failure).
3. **Noise floor**: the first ``--floor-designs`` (8) usable random designs and the straight
   tool, each in the 5 scenes of ``tooldesign retest``'s nudges (``RetestConfig().scenes``: the
   box start moved by at most 0.1 mm and turned by at most 1e-4 rad, the first scene the task's
   own): the relative range (max - min) / |mean| of F per design, and its median. Each
   design's F in every scene is kept (``noise_floor.per_design``), and, in a task with
   obstacles, its F in the task's own scene with the obstacles removed: equal to its F with
   them, the design never touched an obstacle.
4. **CMA-ES**: ``--iterations`` x ``--batch`` (15 x 8) evaluations of the library's CMA-ES
   (``optimizers.make("cmaes")``, seed ``--seed``), invalid designs told as failures (the
   harness tells them their penalized F): its best design, F, final distance and success.
5. **Tier**, by the rule written in docs/tasks.md, from the share p of random designs that
   succeed: *easy* for p >= 10 %, *medium* for 1 % <= p < 10 %, *hard* for p < 1 %. Beside
   it: whether CMA-ES's best-F design succeeds, and its regret (its best F minus the best F
   seen in all of this task's evaluations).

6. **Reach** (``--reach FILE``, instead of 1 to 5): the ``--random`` designs of 2 rolled out
   once per task, each design's final box pose (centre and tilt) stored in FILE. The plan does
   not depend on the goal (checked: the first two designs roll out again at the range's low
   corner and must end at the same pose to the bit), so the pose gives the design's success at
   any goal, by the task's own test (``TaskDefinition.succeeded``: tolerance, resting height,
   tilt). Printed per task: successes at every goal of a grid of :data:`REACH_STEP` m over the
   goal range and :data:`REACH_MARGIN` m around it (the range marked), the grid goals of the
   range with none and with fewer than :data:`REACH_MINIMUM`, the largest box of grid goals in
   the range that holds the default goal and has at least :data:`REACH_MINIMUM` successes at
   every goal (the rule the obstacle's goal range follows, docs/tasks.md) and the largest such
   box without the default goal, and the successes at each committed protocol instance of the
   task (push's instances draw the box's mass and friction, so the poses here, at the nominal
   box, are not theirs: not counted). ``--reach-from FILE`` prints the same from a stored FILE
   without simulating. 4 tasks x 66 rollouts at 0.2 to 0.6 s each (the rate above): 1 to 3
   minutes on one core.

Run: ``python -m perf.studies.task_baselines [--task hook] [--random 64] [--iterations 15]
[--batch 8] [--seed 0] [--json FILE [--merge]]``; ``--merge`` replaces only the measured
tasks' entries of an existing FILE (a task re-measured alone). One evaluation takes 0.2 to
0.6 s on one core; a task takes about 240 evaluations (2 to 4 minutes). ``--noise-floor-only``
measures 2 and 3 alone (about 120 evaluations a task; the floor's designs are the same, as they
come from the same random draw): docs/results/tasks/noise-floor.json, whose summary must equal
baselines.json's. ``--reach docs/results/tasks/reach.json`` (``--merge`` keeps the other
tasks' entries) and ``--reach-from`` measure and print 6.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from dataclasses import replace
from typing import Any

import numpy as np

from benchmarks.suites.retest import RetestConfig
from optimizers import make as make_optimizer
from tooldesign_env import ToolDesignEnv, default_bounds
from tooldesign_env.tasks import BUILTIN_TASKS, TaskDefinition, get_task

#: The hand-picked designs, (c1, c2, c3), highest power first.
NAMED: dict[str, tuple[float, float, float]] = {
    "straight": (0.0, 0.0, 0.0),
    "bow (0, 0.6, 0)": (0.0, 0.6, 0.0),
    "bow back (0, -0.6, 0)": (0.0, -0.6, 0.0),
    "hook (0.4, 1.4, 0.18)": (0.4, 1.4, 0.18),
    "hook (0, 1.5, 0)": (0.0, 1.5, 0.0),
    "curl (1.5, 1.5, 0.5)": (1.5, 1.5, 0.5),
    "back (-1.4, 0.8, 0)": (-1.4, 0.8, 0.0),
}

#: Shares of random designs that succeed: at and above the first a task is easy, below the
#: second hard, between them medium.
EASY_SHARE = 0.10
HARD_SHARE = 0.01


#: Reach (6): the grid's step and its margin around the goal range, m, and the successes of
#: the random designs every goal of a task's range must have.
REACH_STEP = 0.05
REACH_MARGIN = 0.1
REACH_MINIMUM = 2


def tier(random_success: float) -> str:
    """The task's tier from the share of random designs that succeed (see above)."""
    if random_success >= EASY_SHARE:
        return "easy"
    return "medium" if random_success >= HARD_SHARE else "hard"


def _score(env: ToolDesignEnv, design: Any) -> dict[str, Any]:
    info = env.step(np.asarray(design, dtype=np.float64))[4]
    return {
        "design": [float(c) for c in np.asarray(design, dtype=float)],
        "valid": bool(info["valid"]),
        "free_energy": float(info["free_energy"]),
        "final_distance": float(info["final_distance"]),
        "success": bool(info["success"]),
    }


def _relative_range(values: list[float]) -> float:
    return (max(values) - min(values)) / abs(statistics.fmean(values))


def _random_designs(random: int, seed: int) -> np.ndarray:
    """``random`` designs drawn uniformly in the d = 3 bounds with ``seed``: (random, 3)."""
    bounds = default_bounds(3)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    designs: np.ndarray = rng.uniform(bounds[:, 0], bounds[:, 1], size=(random, 3))
    return designs


def _random_rows(env: ToolDesignEnv, random: int, seed: int) -> list[dict[str, Any]]:
    """``random`` designs drawn uniformly in the d = 3 bounds with ``seed``, scored."""
    return [_score(env, c) for c in _random_designs(random, seed)]


def noise_floor(name: str, floor_set: list[Any]) -> dict[str, Any]:
    """F of each design of ``floor_set`` in the 5 nudged scenes of the task's own scene.

    Returns the summary docs/tasks.md quotes and ``per_design``: each design, its F per scene,
    relative range and range, and (a task with obstacles) its F in the task's own scene with
    the obstacles removed.
    """
    task = get_task(name)
    scenes = RetestConfig().scenes(task.scene)
    envs = [ToolDesignEnv(task=name, scene=scene) for scene in scenes]
    bare = None
    if task.obstacles:
        bare = ToolDesignEnv(task=replace(task, name=f"{name}-without-obstacles", obstacles=()))
    per_design = []
    try:
        for design in floor_set:
            values = []
            for scene_env in envs:
                scene_env.reset(seed=0)
                values.append(_score(scene_env, design)["free_energy"])
            row: dict[str, Any] = {
                "design": [float(c) for c in design],
                "free_energy": values,
                "relative_range": _relative_range(values),
                "range": max(values) - min(values),
            }
            if bare is not None:
                bare.reset(seed=0)
                row["free_energy_without_obstacles"] = _score(bare, design)["free_energy"]
            per_design.append(row)
    finally:
        for scene_env in envs:
            scene_env.close()
        if bare is not None:
            bare.close()
    ranges = [r["relative_range"] for r in per_design]
    spans = [r["range"] for r in per_design]
    return {
        "designs": len(floor_set),
        "scenes": len(scenes),
        "median_relative_range": float(np.median(ranges)),
        "max_relative_range": float(np.max(ranges)),
        "median_range": float(np.median(spans)),
        "max_range": float(np.max(spans)),
        "per_design": per_design,
    }


def _floor_set(usable: list[dict[str, Any]], floor_designs: int) -> list[Any]:
    """The straight tool and the first ``floor_designs`` usable random designs."""
    return [NAMED["straight"]] + [r["design"] for r in usable[:floor_designs]]


def measure_noise_floor(name: str, *, random: int, seed: int, floor_designs: int
                        ) -> dict[str, Any]:
    """Only the noise floor of :func:`measure` (its random draw picks the same designs)."""
    env = ToolDesignEnv(task=name)
    env.reset(seed=0)
    try:
        rows = _random_rows(env, random, seed)
    finally:
        env.close()
    usable = [r for r in rows if r["valid"]]
    return {"task": name, "noise_floor": noise_floor(name, _floor_set(usable, floor_designs))}


def measure(name: str, *, random: int, iterations: int, batch: int, seed: int,
            floor_designs: int) -> dict[str, Any]:
    """Every figure of one task's row in docs/tasks.md (see the module docstring)."""
    task = get_task(name)
    bounds = default_bounds(3)
    env = ToolDesignEnv(task=name)
    env.reset(seed=0)
    start = time.perf_counter()
    evaluations = 0
    try:
        named = {label: _score(env, c) for label, c in NAMED.items()}
        evaluations += len(named)
        rows = _random_rows(env, random, seed)
        evaluations += len(rows)
        usable = [r for r in rows if r["valid"]]
        energies = np.array([r["free_energy"] for r in usable])
        optimizer = make_optimizer("cmaes", bounds=bounds, batch_size=batch, seed=seed)
        cmaes: list[dict[str, Any]] = []
        for _ in range(iterations):
            asked = optimizer.ask()
            scored = [_score(env, x) for x in asked.x]
            optimizer.tell(asked.ids, [s["free_energy"] if s["valid"] else None for s in scored])
            cmaes.extend(scored)
        evaluations += len(cmaes)
    finally:
        env.close()
    best = min((r for r in cmaes if r["valid"]), key=lambda r: r["free_energy"])
    # The noise floor: every design in the same 5 nudged scenes of the task's own scene.
    floor = noise_floor(name, _floor_set(usable, floor_designs))
    evaluations += floor["designs"] * (floor["scenes"] + bool(task.obstacles))
    everything = [r["free_energy"] for r in (*named.values(), *usable, *cmaes) if r["valid"]]
    random_success = sum(r["success"] for r in rows) / len(rows)
    return {
        "task": name,
        "goal": list(task.goal),
        "tolerance": task.tolerance,
        "named": named,
        "random": {
            "n": len(rows),
            "usable": len(usable),
            "success_rate": random_success,
            "free_energy_quantiles": np.quantile(energies, [0, 0.25, 0.5, 0.75, 1]).tolist(),
            "final_distance_median": float(np.median([r["final_distance"] for r in usable])),
        },
        "noise_floor": floor,
        "cmaes": {
            "evaluations": len(cmaes),
            "best": best,
            "success_rate_of_its_evaluations": sum(r["success"] for r in cmaes) / len(cmaes),
            "regret": best["free_energy"] - min(everything),
        },
        "tier": tier(random_success),
        "evaluations": evaluations,
        "seconds": time.perf_counter() - start,
    }


def _final_pose(info: dict[str, Any]) -> dict[str, Any]:
    """The box's final centre (x, y, z) m and tilt rad of one rollout, and whether it is usable.

    An unusable design (rejected before its rollout) has no pose: both are None.
    """
    path = info["box_trajectory"]
    if not info["valid"] or len(path) == 0:
        return {"valid": False, "final_position": None, "final_tilt": None}
    return {
        "valid": True,
        "final_position": [float(v) for v in path[-1]],
        "final_tilt": float(info["final_tilt"]),
    }


def measure_reach(name: str, *, random: int, seed: int) -> dict[str, Any]:
    """The final box pose of each of the ``random`` designs of :func:`measure` in one task.

    Raises:
        RuntimeError: a design ended elsewhere with the goal at the range's low corner (the
            plan would depend on the goal, and the poses would not give the success at every
            goal).
    """
    task = get_task(name)
    designs = _random_designs(random, seed)
    env = ToolDesignEnv(task=name, info_series=True)
    corner = ToolDesignEnv(task=name, goal=task.goal_low, info_series=True)
    env.reset(seed=0)
    corner.reset(seed=0)
    try:
        rows = [
            {"design": [float(c) for c in design], **_final_pose(env.step(design)[4])}
            for design in designs
        ]
        for row, design in zip(rows[:2], designs[:2], strict=True):
            again = _final_pose(corner.step(design)[4])
            if again != {k: row[k] for k in again}:
                raise RuntimeError(
                    f"{name}: the design {row['design']} ends at {again['final_position']} with "
                    f"the goal {list(task.goal_low)}, at {row['final_position']} with the "
                    "default goal: the rollout depends on the goal"
                )
    finally:
        env.close()
        corner.close()
    return {
        "task": name,
        "seed": seed,
        "n": len(rows),
        "bounds": default_bounds(3).tolist(),
        "goal_low": list(task.goal_low),
        "goal_high": list(task.goal_high),
        "designs": rows,
    }


def reach_successes(entry: dict[str, Any], task: TaskDefinition, goal: Any) -> int:
    """How many designs of a :func:`measure_reach` entry succeed at ``goal`` (x, y, z) m.

    An unusable design fails; a usable one is judged by ``task.succeeded`` on its final pose.
    """
    goal = np.asarray(goal, dtype=float)
    count = 0
    for row in entry["designs"]:
        end = np.asarray(row["final_position"], dtype=float)
        if row["valid"] and task.succeeded(
            float(np.linalg.norm(end - goal)), float(end[2]), final_tilt=row["final_tilt"]
        ):
            count += 1
    return count


def _grid_axis(low: float, high: float, margin: float) -> np.ndarray:
    """Multiples of :data:`REACH_STEP` from ``low - margin`` to ``high + margin``."""
    first = math.floor(round((low - margin) / REACH_STEP, 6))
    last = math.ceil(round((high + margin) / REACH_STEP, 6))
    return np.round(np.arange(first, last + 1) * REACH_STEP, 6)


def reach_grid(
    entry: dict[str, Any], task: TaskDefinition, margin: float = REACH_MARGIN
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Successes at each goal of the grid over the task's goal range and ``margin`` around it.

    Returns:
        xs (nx,), ys (ny,) in m and the counts (ny, nx), the goals' z the range's.
    """
    xs = _grid_axis(task.goal_low[0], task.goal_high[0], margin)
    ys = _grid_axis(task.goal_low[1], task.goal_high[1], margin)
    z = task.goal_low[2]
    counts = np.array([[reach_successes(entry, task, (x, y, z)) for x in xs] for y in ys])
    return xs, ys, counts


def _in_range(task: TaskDefinition, x: float, y: float) -> bool:
    (x0, y0, _), (x1, y1, _) = task.goal_low, task.goal_high
    return bool(x0 - 1e-9 <= x <= x1 + 1e-9 and y0 - 1e-9 <= y <= y1 + 1e-9)


def _holds(low: float, high: float, value: float) -> bool:
    """Whether ``value`` lies in [low, high] (NaN: no constraint)."""
    return math.isnan(value) or low - 1e-9 <= value <= high + 1e-9


def largest_reached_box(
    xs: np.ndarray,
    ys: np.ndarray,
    counts: np.ndarray,
    task: TaskDefinition,
    minimum: int = REACH_MINIMUM,
    *,
    with_default_goal: bool = True,
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The largest box of grid goals in the range, with the default goal, reached everywhere.

    Every grid goal of the box has at least ``minimum`` successes. Largest by area (ties: by the
    number of grid goals, then the lowest corner). The default goal must lie in the box (not on
    the grid), unless ``with_default_goal`` is False.

    Returns:
        ((x0, y0), (x1, y1)) m, or None if no such box exists.
    """
    ix = [i for i, x in enumerate(xs) if _in_range(task, x, task.goal_low[1])]
    iy = [j for j, y in enumerate(ys) if _in_range(task, task.goal_low[0], y)]
    gx, gy = (task.goal[0], task.goal[1]) if with_default_goal else (math.nan, math.nan)
    best: tuple[float, int] | None = None
    corners: tuple[tuple[float, float], tuple[float, float]] | None = None
    for a in ix:
        for b in (i for i in ix if i >= a and _holds(xs[a], xs[i], gx)):
            for c in iy:
                for d in (j for j in iy if j >= c and _holds(ys[c], ys[j], gy)):
                    if counts[c : d + 1, a : b + 1].min() < minimum:
                        continue
                    key = (float((xs[b] - xs[a]) * (ys[d] - ys[c])), (b - a + 1) * (d - c + 1))
                    if best is None or key > best:  # the first (lowest corner) wins a tie
                        best = key
                        corners = (float(xs[a]), float(ys[c])), (float(xs[b]), float(ys[d]))
    return corners


def _print_reach(entry: dict[str, Any]) -> None:
    """Print one task's reach (see the module docstring, 6)."""
    from benchmarks.protocol.instances import PUSH_TASK, committed_tasks, load_instances

    name = entry["task"]
    task = get_task(name)
    usable = sum(row["valid"] for row in entry["designs"])
    (x0, y0, z), (x1, y1, _) = task.goal_low, task.goal_high
    print(f"## {name}: {entry['n']} random designs (seed {entry['seed']}), {usable} usable")
    print(
        f"successes at each goal (z {z:g} m; success within {task.tolerance:g} m, the centre "
        f"within {task.height_tolerance:g} m of its resting height, tilted at most "
        f"{math.degrees(task.max_tilt):g} degrees; * in the goal range, x in [{x0:g}, {x1:g}], "
        f"y in [{y0:g}, {y1:g}] m; the default goal ({task.goal[0]:g}, {task.goal[1]:g}) has "
        f"{reach_successes(entry, task, task.goal)}):"
    )
    xs, ys, counts = reach_grid(entry, task)
    print("| y \\ x | " + " | ".join(f"{x:g}" for x in xs) + " |")
    print("|---" * (len(xs) + 1) + "|")
    inside = []
    for j, y in enumerate(ys):
        cells = []
        for i, x in enumerate(xs):
            star = _in_range(task, x, y)
            if star:
                inside.append((float(x), float(y), int(counts[j, i])))
            cells.append(f"{counts[j, i]}{'*' if star else ''}")
        print(f"| {y:g} | " + " | ".join(cells) + " |")
    none = [(x, y) for x, y, n in inside if n == 0]
    few = [(x, y) for x, y, n in inside if n < REACH_MINIMUM]
    listed = ": " + ", ".join(f"({x:g}, {y:g})" for x, y in few) if 0 < len(few) <= 12 else ""
    print(
        f"grid goals in the range: {len(inside)}; successes {min(n for *_, n in inside)} to "
        f"{max(n for *_, n in inside)}; with none {len(none)}, with fewer than {REACH_MINIMUM} "
        f"{len(few)}{listed}"
    )
    for with_goal in (True, False):
        box = largest_reached_box(xs, ys, counts, task, with_default_goal=with_goal)
        holding = "holding the default goal " if with_goal else ""
        what = (
            f"the largest box of grid goals in the range {holding}with at least "
            f"{REACH_MINIMUM} successes at every goal"
        )
        if box is None:
            print(f"{what}: none")
        else:
            (bx0, by0), (bx1, by1) = box
            whole = (bx0, by0, bx1, by1) == (x0, y0, x1, y1)
            print(f"{what}: x in [{bx0:g}, {bx1:g}], y in [{by0:g}, {by1:g}] m"
                  + (" (the whole range)" if whole else ""))
        if box is not None and (box[0][0], box[0][1], box[1][0], box[1][1]) == (x0, y0, x1, y1):
            break  # the whole range: the second box is the same
    if name == PUSH_TASK:
        print("committed instances: not counted (each push instance draws the box's mass and "
              "friction; these poses are the nominal box's)")
    elif name in committed_tasks():
        per = [
            (i.id, i.set, i.goal, reach_successes(entry, task, i.goal))
            for i in load_instances(task=name)
        ]
        print(
            "committed instances (version 1): "
            + ", ".join(f"{i} ({g[0]:g}, {g[1]:g}) {n}" for i, _, g, n in per)
        )
        print(
            f"  successes {min(n for *_, n in per)} to {max(n for *_, n in per)}; with none: "
            + (", ".join(i for i, *_, n in per if n == 0) or "no instance")
            + f"; with fewer than {REACH_MINIMUM}: "
            + (", ".join(i for i, *_, n in per if n < REACH_MINIMUM) or "no instance")
        )
    else:
        print("committed instances: none (a task without a committed set)")
    print()


def _print_floor(n: dict[str, Any]) -> None:
    print(
        f"noise floor: median relative range of F {100 * n['median_relative_range']:.2f} % "
        f"(max {100 * n['max_relative_range']:.2f} %), in F units median {n['median_range']:.1f}"
        f" (max {n['max_range']:.1f}), over {n['designs']} designs x {n['scenes']} nudged scenes"
    )
    for row in n.get("per_design", ()):
        design = ", ".join(f"{v:.3f}" for v in row["design"])
        without = row.get("free_energy_without_obstacles")
        extra = "" if without is None else (
            f"; without obstacles F {without:.1f}"
            f" ({'the same' if without == row['free_energy'][0] else 'not the same'})"
        )
        print(f"  ({design}): {100 * row['relative_range']:.2f} % (F {row['free_energy'][0]:.1f},"
              f" range {row['range']:.1f}){extra}")


def _print(result: dict[str, Any]) -> None:
    r, n, c = result["random"], result["noise_floor"], result["cmaes"]
    q = r["free_energy_quantiles"]
    print(f"## {result['task']}: goal {result['goal']}, success within {result['tolerance']} m")
    print("| design | F | final distance (m) | success |")
    print("|---|---|---|---|")
    for label, row in result["named"].items():
        f = f"{row['free_energy']:.0f}" if row["valid"] else "unusable"
        print(f"| {label} | {f} | {row['final_distance']:.3f} | {row['success']} |")
    best = c["best"]
    design = ", ".join(f"{v:.3f}" for v in best["design"])
    print(f"| CMA-ES best ({design}) | {best['free_energy']:.0f} | "
          f"{best['final_distance']:.3f} | {best['success']} |")
    print(
        f"random: {r['usable']}/{r['n']} usable, success {100 * r['success_rate']:.1f} %, "
        f"F min {q[0]:.0f}, quartiles {q[1]:.0f} / {q[2]:.0f} / {q[3]:.0f}, max {q[4]:.0f}, "
        f"median final distance {r['final_distance_median']:.3f} m"
    )
    _print_floor(n)
    print(
        f"CMA-ES {c['evaluations']} evaluations: best F {best['free_energy']:.0f}, regret "
        f"{c['regret']:.0f}, {100 * c['success_rate_of_its_evaluations']:.1f} % of its "
        f"evaluations succeed; tier {result['tier']}; {result['evaluations']} evaluations in "
        f"{result['seconds']:.0f} s\n"
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--task", action="append", choices=BUILTIN_TASKS, default=None)
    parser.add_argument("--random", type=int, default=64)
    parser.add_argument("--iterations", type=int, default=15)
    parser.add_argument("--batch", type=int, default=8)
    parser.add_argument("--floor-designs", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="also write the figures to this JSON file")
    parser.add_argument(
        "--merge",
        action="store_true",
        help="with --json: replace the measured tasks' entries of an existing file, keeping "
        "the others and their order (one task re-measured alone)",
    )
    parser.add_argument(
        "--reach",
        metavar="FILE",
        default=None,
        help="instead of the baselines: roll out the random designs once per task, store their "
        "final poses in FILE and print each task's per-goal success grid and the successes at "
        "its committed instances",
    )
    parser.add_argument(
        "--reach-from",
        metavar="FILE",
        default=None,
        help="print the --reach grids and instance counts from the poses stored in FILE (no "
        "simulation)",
    )
    parser.add_argument(
        "--noise-floor-only",
        action="store_true",
        help="measure the random designs and the noise floor alone (no named designs, no CMA-ES)",
    )
    args = parser.parse_args(argv)
    if args.merge and not (args.json or args.reach):
        parser.error("--merge needs --json FILE or --reach FILE: the file whose entries it "
                     "replaces")
    if args.reach and args.reach_from:
        parser.error("--reach measures and --reach-from reads: give one of them")
    if (args.reach or args.reach_from) and (args.json or args.noise_floor_only):
        parser.error("--reach and --reach-from measure the reach alone: no --json or "
                     "--noise-floor-only with them")
    if args.random < 1:
        parser.error(f"--random must be at least 1, got {args.random}")
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print the table of each task asked for."""
    args = parse_args(argv)
    if args.reach_from:
        return print_reach(args.reach_from, args.task)
    if args.reach:
        from benchmarks.storage.atomic import atomic_write_text

        entries = []
        for name in args.task or BUILTIN_TASKS:
            entries.append(measure_reach(name, random=args.random, seed=args.seed))
            _print_reach(entries[-1])
        if args.merge:
            entries = merge_results(args.reach, entries)
        atomic_write_text(args.reach, json.dumps(entries, indent=1) + "\n")
        return 0
    results = []
    for name in args.task or BUILTIN_TASKS:
        if args.noise_floor_only:
            result = measure_noise_floor(
                name, random=args.random, seed=args.seed, floor_designs=args.floor_designs
            )
            print(f"## {name}")
            _print_floor(result["noise_floor"])
        else:
            result = measure(
                name,
                random=args.random,
                iterations=args.iterations,
                batch=args.batch,
                seed=args.seed,
                floor_designs=args.floor_designs,
            )
            _print(result)
        results.append(result)
    if args.json:
        from benchmarks.storage.atomic import atomic_write_text

        if args.merge:
            results = merge_results(args.json, results)
        atomic_write_text(args.json, json.dumps(results, indent=1) + "\n")
    return 0


def print_reach(path: str, tasks: list[str] | None = None) -> int:
    """Print the reach of each task stored in the ``--reach`` file ``path`` (or of ``tasks``).

    Returns 0, or 2 (with a one-line message on stderr) if ``path`` is missing, not a list of
    task entries, or lacks a task asked for.
    """
    import sys
    from pathlib import Path

    try:
        entries = json.loads(Path(path).read_text(encoding="utf-8"))
        if not isinstance(entries, list) or not all(
            isinstance(e, dict) and {"task", "designs"} <= set(e) for e in entries
        ):
            raise ValueError("not a list of --reach task entries")
    except (OSError, ValueError) as err:
        print(f"--reach-from {path}: {err}", file=sys.stderr)
        return 2
    by_task = {e["task"]: e for e in entries}
    missing = [t for t in tasks or () if t not in by_task]
    if missing:
        print(f"--reach-from {path}: no entry for {', '.join(missing)}; it holds "
              f"{', '.join(by_task)}", file=sys.stderr)
        return 2
    for name in tasks or list(by_task):
        _print_reach(by_task[name])
    return 0


def merge_results(path: str, results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The entries of the JSON file ``path`` with those of ``results``' tasks replaced.

    A task the file lacks is appended; the file's other entries keep their place and content.

    Raises:
        ValueError: the file is not a list of task entries.
    """
    from pathlib import Path

    try:
        before = json.loads(Path(path).read_text())
    except FileNotFoundError:
        return results
    if not isinstance(before, list) or not all(
        isinstance(entry, dict) and "task" in entry for entry in before
    ):
        raise ValueError(f"--merge: {path} is not a list of task entries")
    new = {entry["task"]: entry for entry in results}
    merged = [new.pop(entry["task"], entry) for entry in before]
    return merged + list(new.values())


if __name__ == "__main__":
    raise SystemExit(main())
