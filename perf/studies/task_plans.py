"""Per task: is its fixed plan pi_0 the right one? pi_0 against variants, on the same designs.

Issue 35 asks each task for "its own fixed plan with the reason for it written down"; every
built-in task keeps the paper's pi_0 (``PlanSpec()``), each for a reason argued in its
definition. This measures that reason against the plans a researcher would try instead, made
from ``PlanSpec``'s parameters with the plan's total duration unchanged (F sums over the
episode's steps, so its scale stays comparable): for each task (``--task``, default every
built-in one), for each plan of :data:`VARIANTS`, the straight tool C = 0 and ``--designs`` (64)
designs drawn uniformly in the d = 3 default bounds with ``--seed`` (0: the same draw as
``task_baselines``), one rollout each at the task's default goal, p^X = 20, the contact
estimator. Per (task, plan):

* **success at the default goal**: how many of the random designs succeed (the env's
  ``info["success"]``: within the tolerance and standing; an unusable design fails), and,
  paired with pi_0 on the same designs, how many succeed under the variant alone (gained) or
  under pi_0 alone (lost), with the exact two-sided sign test of gained against lost;
* **over the task's committed instances** (``benchmarks/protocol/data/instances-<task>-v1.json``;
  the plan does not depend on the goal, so the box's final pose of the one rollout decides every
  goal): the mean count of succeeding designs per instance and the number of instances no
  design reaches. Not for push, whose instances draw the box's mass and friction (a rollout
  each);
* **F**: min, median and max over the usable designs, and the gap between the median and the
  best in units of the task's noise floor under pi_0 (the median range of F over nudged scenes,
  ``docs/results/tasks/baselines.json``; a variant's own floor is not measured here);
* the median final distance, the share of usable designs, whether the env's floor guard ran
  an episode again (the plan brings the arm near the floor), and the straight tool's F, final
  distance and success;
* the lowest-F design that succeeds at the default goal (the rollout ``task_pictures
  --succeeding`` renders) and the lowest-F design.

Run: ``python -m perf.studies.task_plans [--task hook ...] [--designs 64] [--seed 0]
[--json FILE]``. Output: docs/results/tasks/plans-output.txt and plans.json (docs/tasks.md).
1,040 rollouts for the four tasks, about 0.06 s of CPU each (twice that when the floor guard
reruns one).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from tooldesign_env import ToolDesignEnv, default_bounds
from tooldesign_env.specs import PlanSpec
from tooldesign_env.tasks import BUILTIN_TASKS, TaskDefinition, get_task

#: The label of each task's own plan in the tables.
OWN = "pi_0"

#: A sign test's p below this calls a difference in successes measured (two-sided).
SIGNIFICANCE = 0.05

_PI0 = PlanSpec()
_YAW_100 = math.radians(100.0)

#: Per task, the plans compared with its own pi_0 (first): what a researcher would try there.
VARIANTS: dict[str, dict[str, PlanSpec]] = {
    "push": {
        OWN: _PI0,
        "shorter pull (pull_to 0.45 m)": replace(_PI0, pull_to=0.45),
        "sweep ends at 100 deg (yaw_end)": replace(_PI0, yaw_end=_YAW_100),
        "sweep nearer the base (reach 0.6 m)": replace(_PI0, reach=0.6),
    },
    "hook": {
        OWN: _PI0,
        "deeper pull (pull_to 0.25 m)": replace(_PI0, pull_to=0.25),
        "shorter pull (pull_to 0.45 m)": replace(_PI0, pull_to=0.45),
        "hook side turned on (yaw_end 100 deg)": replace(_PI0, yaw_end=_YAW_100),
    },
    "obstacle": {
        OWN: _PI0,
        "sweep ends at 100 deg (yaw_end)": replace(_PI0, yaw_end=_YAW_100),
        "sweep nearer the base (reach 0.6 m)": replace(_PI0, reach=0.6),
        "deeper pull (pull_to 0.25 m)": replace(_PI0, pull_to=0.25),
    },
    "puck": {
        OWN: _PI0,
        "slower sweep (7 s, hold 4 s)": replace(_PI0, sweep_duration=7.0, hold_duration=4.0),
        "push at the puck's centre (height 0.1 m)": replace(_PI0, height=0.1),
        "sweep ends at 100 deg (yaw_end)": replace(_PI0, yaw_end=_YAW_100),
    },
}


@dataclass(frozen=True)
class Rollout:
    """One design's rollout under one plan: F, success and the box's final pose."""

    design: tuple[float, float, float]
    valid: bool
    free_energy: float
    final_distance: float
    success: bool
    end: tuple[float, float, float]
    final_height: float
    final_tilt: float


def sign_test(gained: int, lost: int) -> float:
    """Exact two-sided p of ``gained`` against ``lost`` discordant pairs under p = 1/2.

    Raises:
        ValueError: a negative count.
    """
    if gained < 0 or lost < 0:
        raise ValueError(f"sign_test needs counts >= 0, got gained {gained}, lost {lost}")
    n = gained + lost
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, k) for k in range(min(gained, lost) + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def paired(own: Sequence[bool], variant: Sequence[bool]) -> tuple[int, int, float]:
    """(gained, lost, p): designs that succeed under the variant alone, under pi_0 alone.

    Raises:
        ValueError: the two lists are not of the same designs (lengths differ).
    """
    if len(own) != len(variant):
        raise ValueError(f"paired needs the same designs, got {len(own)} and {len(variant)}")
    gained = sum(1 for a, b in zip(own, variant, strict=True) if b and not a)
    lost = sum(1 for a, b in zip(own, variant, strict=True) if a and not b)
    return gained, lost, sign_test(gained, lost)


def successes_at(task: TaskDefinition, rollouts: Sequence[Rollout], goal: Sequence[float]) -> int:
    """How many usable rollouts end standing within the task's tolerance of ``goal``."""
    target = np.asarray(goal, dtype=float)
    return sum(
        1
        for r in rollouts
        if r.valid
        and task.succeeded(
            float(np.linalg.norm(np.asarray(r.end) - target)),
            r.final_height,
            final_tilt=r.final_tilt,
        )
    )


def summary(
    task: TaskDefinition,
    rollouts: Sequence[Rollout],
    *,
    noise: float | None,
    goals: Sequence[Sequence[float]] = (),
) -> dict[str, Any]:
    """The table row of one (task, plan) from its random designs' rollouts.

    Args:
        task: the task (its success test and tolerance).
        rollouts: the random designs' rollouts at the task's default goal.
        noise: the task's noise floor in F units (median range over nudged scenes), or None.
        goals: the committed instances' goals, (x, y, z) each; empty for none.
    """
    usable = [r for r in rollouts if r.valid]
    values = sorted(r.free_energy for r in usable)
    median = statistics.median(values) if values else math.nan
    best = min(usable, key=lambda r: r.free_energy) if usable else None
    winners = [r for r in usable if r.success]
    best_success = min(winners, key=lambda r: r.free_energy) if winners else None
    per_goal = [successes_at(task, rollouts, g) for g in goals]
    return {
        "designs": len(rollouts),
        "usable": len(usable),
        "successes": len(winners),
        "f_min": values[0] if values else math.nan,
        "f_median": median,
        "f_max": values[-1] if values else math.nan,
        "gap_over_noise": (median - values[0]) / noise if values and noise else None,
        "median_distance": statistics.median(r.final_distance for r in usable)
        if usable
        else math.nan,
        "instances": len(per_goal),
        "instance_mean_successes": statistics.fmean(per_goal) if per_goal else None,
        "instances_unreached": sum(1 for c in per_goal if c == 0) if per_goal else None,
        "best": asdict(best) if best else None,
        "best_success": asdict(best_success) if best_success else None,
    }


def verdict(rows: dict[str, dict[str, Any]]) -> str:
    """Which plan the measurement favours for one task, in a sentence.

    ``rows`` maps each plan's label to its :func:`summary` with ``gained``, ``lost``, ``p`` and
    ``straight`` added; the first is pi_0. A variant is better if more designs succeed under it
    at the default goal (sign test p < :data:`SIGNIFICANCE`), no fewer instances on average,
    and the straight tool does not succeed under it where it fails under pi_0 (the task would
    stop asking for a shape).
    """
    own = rows[OWN]
    better = [
        label
        for label, row in rows.items()
        if label != OWN
        and row["gained"] > row["lost"]
        and row["p"] < SIGNIFICANCE
        and (
            own["instance_mean_successes"] is None
            or row["instance_mean_successes"] >= own["instance_mean_successes"]
        )
        and (own["straight"]["success"] or not row["straight"]["success"])
    ]
    worse = [
        label
        for label, row in rows.items()
        if label != OWN and row["lost"] > row["gained"] and row["p"] < SIGNIFICANCE
    ]
    if better:
        best = max(better, key=lambda label: rows[label]["successes"])
        return f"a better fixed plan: {best} (p {rows[best]['p']:.3g})"
    text = "pi_0 confirmed: no variant has measurably more successes"
    if worse:
        text += f"; measurably fewer under {', '.join(worse)}"
    return text


def random_designs(n: int, seed: int) -> np.ndarray:
    """The designs of ``task_baselines`` (the same draw for the same n and seed): (n, 3)."""
    bounds = default_bounds(3)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    designs: np.ndarray = rng.uniform(bounds[:, 0], bounds[:, 1], size=(n, 3))
    return designs


def rollouts(task: str, plan: PlanSpec, designs: np.ndarray) -> tuple[list[Rollout], bool]:
    """Each design's rollout under ``plan`` at the task's default goal; whether the guard reran."""
    env = ToolDesignEnv(task=task, plan=plan, info_series=True)
    out = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        try:
            env.reset(seed=0)
            for design in designs:
                info = env.step(np.asarray(design, dtype=np.float64))[4]
                end = info["box_trajectory"][-1] if info["valid"] else np.full(3, math.nan)
                out.append(
                    Rollout(
                        design=tuple(float(c) for c in design),  # type: ignore[arg-type]
                        valid=bool(info["valid"]),
                        free_energy=float(info["free_energy"]),
                        final_distance=float(info["final_distance"]),
                        success=bool(info["success"]),
                        end=tuple(float(v) for v in end),  # type: ignore[arg-type]
                        final_height=float(info.get("final_height", math.nan)),
                        final_tilt=float(info.get("final_tilt", math.nan)),
                    )
                )
        finally:
            env.close()
    guard = any("floor" in str(w.message) for w in caught)
    return out, guard


def _noise(task: str, baselines: Path) -> float | None:
    if not baselines.is_file():
        return None
    for result in json.loads(baselines.read_text()):
        if result["task"] == task:
            return float(result["noise_floor"]["median_range"])
    return None


def measure(task: str, *, designs: int, seed: int, baselines: Path) -> dict[str, Any]:
    """Every plan of :data:`VARIANTS` for one task: rows, verdict."""
    from benchmarks.design.instances import committed_tasks, load_instances

    definition = get_task(task)
    draw = random_designs(designs, seed)
    goals = (
        [list(i.goal) for i in load_instances(task=task)]
        if task != "push" and task in committed_tasks()
        else []
    )
    noise = _noise(task, baselines)
    rows: dict[str, dict[str, Any]] = {}
    own_success: list[bool] = []
    for label, plan in VARIANTS[task].items():
        runs, guard = rollouts(task, plan, np.vstack([np.zeros((1, 3)), draw]))
        straight, random = runs[0], runs[1:]
        row = summary(definition, random, noise=noise, goals=goals)
        flags = [r.success for r in random]
        if label == OWN:
            own_success = flags
        row["gained"], row["lost"], row["p"] = paired(own_success, flags)
        row["straight"] = asdict(straight)
        row["floor_guard_reran"] = guard
        row["plan"] = asdict(plan)
        rows[label] = row
    return {
        "task": task,
        "goal": list(definition.goal),
        "tolerance": definition.tolerance,
        "noise_floor_range": noise,
        "seed": seed,
        "rows": rows,
        "verdict": verdict(rows),
    }


def _g(value: float | None, fmt: str = ".0f") -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else (
        format(value, fmt)
    )


def print_result(result: dict[str, Any]) -> None:
    """Print one task's table and verdict as markdown."""
    rows = result["rows"]
    n = next(iter(rows.values()))["designs"]
    noise = result["noise_floor_range"]
    print(f"## {result['task']}: default goal {result['goal']}, success within "
          f"{result['tolerance']:g} m, {n} random designs (seed {result['seed']})")
    print(f"| plan | success of {n} | gained / lost vs pi_0 (p) | instances: mean success "
          "(none reach) | median final distance (m) | F min / median / max | "
          f"(median - min) / noise floor {_g(noise, '.1f')} | straight: F, distance, success "
          "| floor guard reran |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, row in rows.items():
        inst = (
            "n/a"
            if row["instance_mean_successes"] is None
            else f"{row['instance_mean_successes']:.1f} of {n} ({row['instances_unreached']} "
            f"of {row['instances']})"
        )
        pair = "" if label == OWN else f"{row['gained']} / {row['lost']} ({row['p']:.2g})"
        s = row["straight"]
        print(
            f"| {label} | {row['successes']} | {pair} | {inst} | {row['median_distance']:.3f} | "
            f"{row['f_min']:.0f} / {row['f_median']:.0f} / {row['f_max']:.0f} | "
            f"{_g(row['gap_over_noise'])} | {s['free_energy']:.0f}, "
            f"{s['final_distance']:.3f} m, {'yes' if s['success'] else 'no'} | "
            f"{'yes' if row['floor_guard_reran'] else 'no'} |"
        )
    for label, row in rows.items():
        win = row["best_success"]
        low = row["best"]
        print(
            f"- {label}: lowest F {low['free_energy']:.0f} at "
            f"({', '.join(f'{c:.3f}' for c in low['design'])}), "
            f"{low['final_distance']:.3f} m, {'succeeds' if low['success'] else 'fails'}; "
            + (
                f"lowest-F success {win['free_energy']:.0f} at "
                f"({', '.join(f'{c:.3f}' for c in win['design'])}), {win['final_distance']:.3f} m"
                if win
                else "no design succeeds"
            )
        )
    print(f"verdict: {result['verdict']}")
    print()


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of :func:`main`."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--task", action="append", choices=sorted(VARIANTS), default=None,
                        help="measure this task (repeatable; default every built-in one)")
    parser.add_argument("--designs", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--baselines", type=Path,
                        default=Path("docs/results/tasks/baselines.json"),
                        help="task_baselines' JSON, for each task's noise floor in F units")
    parser.add_argument("--json", type=Path, default=None, help="write every row here")
    args = parser.parse_args(argv)
    if args.designs < 1:
        parser.error(f"--designs must be a count >= 1, got {args.designs}")
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print each task's plans; write the JSON if asked."""
    args = parse_args(argv)
    tasks = args.task or [t for t in BUILTIN_TASKS if t in VARIANTS]
    results = []
    for task in tasks:
        result = measure(task, designs=args.designs, seed=args.seed, baselines=args.baselines)
        print_result(result)
        results.append(result)
    if args.json is not None:
        from benchmarks.storage import atomic_write_text

        atomic_write_text(args.json, json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
