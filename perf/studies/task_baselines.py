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

Run: ``python -m perf.studies.task_baselines [--task hook] [--random 64] [--iterations 15]
[--batch 8] [--seed 0] [--json FILE [--merge]]``; ``--merge`` replaces only the measured
tasks' entries of an existing FILE (a task re-measured alone). One evaluation takes 0.2 to
0.6 s on one core; a task takes about 240 evaluations (2 to 4 minutes). ``--noise-floor-only``
measures 2 and 3 alone (about 120 evaluations a task; the floor's designs are the same, as they
come from the same random draw): docs/results/tasks/noise-floor.json, whose summary must equal
baselines.json's.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from dataclasses import replace
from typing import Any

import numpy as np

from benchmarks.suites.retest import RetestConfig
from optimizers import make as make_optimizer
from tooldesign_env import ToolDesignEnv, default_bounds
from tooldesign_env.tasks import BUILTIN_TASKS, get_task

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


def _random_rows(env: ToolDesignEnv, random: int, seed: int) -> list[dict[str, Any]]:
    """``random`` designs drawn uniformly in the d = 3 bounds with ``seed``, scored."""
    bounds = default_bounds(3)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    designs = rng.uniform(bounds[:, 0], bounds[:, 1], size=(random, 3))
    return [_score(env, c) for c in designs]


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
        "--noise-floor-only",
        action="store_true",
        help="measure the random designs and the noise floor alone (no named designs, no CMA-ES)",
    )
    args = parser.parse_args(argv)
    if args.merge and not args.json:
        parser.error("--merge needs --json FILE: the file whose entries it replaces")
    return args


def main(argv: list[str] | None = None) -> int:
    """Measure and print the table of each task asked for."""
    args = parse_args(argv)
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
