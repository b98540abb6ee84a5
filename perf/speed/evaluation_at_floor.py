r"""Time per evaluation at a physics preset against a baseline tree, and evaluation / floor.

Issue 31's "done when": one script that prints, side by side in one run on one core, the time
per evaluation of ``ToolDesign-v0`` at the candidate settings against that of 062b3a0 (target:
at most 0.5) and evaluation / floor (target: at most 1.10).

Each round runs, one after the other and each in a fresh process (so that all see the same
load): the baseline tree at its defaults, this tree at its defaults, and this tree at the
preset (``--preset``, a name of ``tooldesign_env.specs.PHYSICS_PRESETS``). Every process makes
the env, warms it with one evaluation, then for each design (``--designs N``: the straight
tool, the hook, then N - 2 uniform random cubics, as ``evaluation_speed.py`` draws them)
times ``env.step`` and, right after it, the floor: building the same world and applying the
same simulated torques open loop (``ToolSimulator.replay_open_loop``), with no controller and
no objective, at the same settings. It prints the median wall and CPU time of an evaluation
and of the floor, and the medians of per-design ratios evaluation / floor (wall and CPU
time). The table then gives, per round and as the median over rounds, each variant's
evaluation time over the baseline's of its round.

The floor is the preset's own: a preset with fewer solver iterations has a lower floor too
(item 3 of the issue lowers it, item 2 brings the evaluation to it).

The baseline tree is a checkout of the older commit with its C control loop built, e.g.::

    git worktree add --detach /tmp/062b3a0 062b3a0
    (cd /tmp/062b3a0 && PYTHONPATH=$PWD python setup.py build_ext --inplace)
    python -m perf.speed.evaluation_at_floor /tmp/062b3a0 --rounds 5 --designs 12 --core 0

``--core`` pins this process and its children to one CPU (as ``taskset -c`` would). Measure on
an idle machine: on a loaded one the times are noise (instruction counts from
``rollout_callgrind.py`` are the figures that survive load).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from perf import _args

HERE = Path(__file__).resolve().parents[2]

#: Run in a child process with PYTHONPATH set to the tree measured. It uses only what 062b3a0
#: already had (ToolDesignEnv, env.simulator.replay_open_loop, info["fast_forward_from"]), so
#: the same code measures the baseline and this tree; argv: designs, seed, preset ("" for the
#: tree's defaults). Prints one JSON line.
_CHILD = r"""
import json, statistics, sys, time
import numpy as np
from tooldesign_env import ToolDesignEnv, make_tool

n, seed, preset = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
kwargs = {}
if preset:
    from tooldesign_env.specs import physics_preset
    kwargs = physics_preset(preset).specs()
rng = np.random.default_rng(seed)
designs = [np.zeros(3), np.array([0.0, 1.5, 0.0])]
designs += list(rng.uniform([-1.5, -1.5, -0.5], [1.5, 1.5, 0.5], size=(max(n - 2, 0), 3)))
designs = designs[:n]
env = ToolDesignEnv(**kwargs)
env.reset(seed=0)
env.step(np.zeros(3))  # warm: the plan, imports, caches
sim = env.simulator
evaluation, evaluation_cpu, floor, floor_cpu, ratios, cpu_ratios = [], [], [], [], [], []
for c in designs:
    t0, c0 = time.perf_counter(), time.process_time()
    info = env.step(c)[4]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if not info["valid"]:
        continue
    series = getattr(env, "_last_series", None) or info
    simulated = np.asarray(series["torques"])[: info["fast_forward_from"]]
    geometry = make_tool(c)
    t0, c0 = time.perf_counter(), time.process_time()
    sim.replay_open_loop(geometry, simulated)
    low, low_cpu = time.perf_counter() - t0, time.process_time() - c0
    evaluation.append(wall)
    evaluation_cpu.append(cpu)
    floor.append(low)
    floor_cpu.append(low_cpu)
    ratios.append(wall / low)
    cpu_ratios.append(cpu / low_cpu)
env.close()
med = statistics.median
print(json.dumps({
    "valid": len(evaluation),
    "evaluation": med(evaluation) if evaluation else None,
    "evaluation_cpu": med(evaluation_cpu) if evaluation else None,
    "floor": med(floor) if floor else None,
    "floor_cpu": med(floor_cpu) if floor else None,
    "ratio": med(ratios) if ratios else None,
    "cpu_ratio": med(cpu_ratios) if ratios else None,
}))
"""


def measure(tree: Path, designs: int, seed: int, preset: str) -> dict[str, Any]:
    """One child process's medians for ``tree`` at ``preset`` ("" for its defaults)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(designs), str(seed), preset],
        env=env,
        # `python -c` puts the working folder first on sys.path: run where there is no
        # package, so PYTHONPATH decides which tooldesign_env is measured.
        cwd=tempfile.gettempdir(),
        capture_output=True,
        text=True,
        check=False,
    )
    lines = out.stdout.strip().splitlines()
    if out.returncode != 0 or not lines:
        raise SystemExit(
            f"measuring {tree} (preset {preset or 'its defaults'!r}) failed (exit "
            f"{out.returncode}):\n{out.stdout[-2000:]}{out.stderr[-2000:]}"
        )
    result: dict[str, Any] = json.loads(lines[-1])
    if not result["valid"]:
        raise SystemExit(f"none of the {designs} designs is valid in {tree}: nothing to time")
    return result


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "baseline", type=Path, help="the baseline source tree (a git worktree of 062b3a0)"
    )
    parser.add_argument(
        "--preset",
        default="lower-floor",
        help="the physics preset of this tree to measure (default: %(default)s)",
    )
    parser.add_argument(
        "--designs",
        type=_args.count(1),
        default=12,
        help="designs per process: the straight tool, the hook, then N - 2 random ones "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--rounds", type=_args.count(1), default=5, help="rounds (default: %(default)s)"
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the random designs' seed")
    parser.add_argument(
        "--core",
        type=_args.count(0),
        default=None,
        help="pin this process and its children to this CPU (default: not pinned)",
    )
    args = parser.parse_args(argv)
    from tooldesign_env.specs import PHYSICS_PRESETS

    if args.preset not in PHYSICS_PRESETS:
        parser.error(f"--preset must be one of {sorted(PHYSICS_PRESETS)}, got {args.preset!r}")
    if not (args.baseline / "tooldesign_env" / "__init__.py").is_file():
        parser.error(f"{args.baseline} has no tooldesign_env package: give a source tree's root")
    if args.core is not None:
        cpus = sorted(os.sched_getaffinity(0))
        if args.core not in cpus:
            parser.error(f"--core must be one of the CPUs this process may use {cpus}")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    if args.core is not None:
        os.sched_setaffinity(0, {args.core})  # inherited by the children
    baseline = args.baseline.resolve()
    variants = {
        "baseline": (baseline, ""),
        "this tree, defaults": (HERE, ""),
        f"this tree, {args.preset}": (HERE, args.preset),
    }
    runs: dict[str, list[dict[str, Any]]] = {name: [] for name in variants}
    print(
        f"baseline {baseline}; this tree {HERE}; {args.designs} designs per process; "
        f"{args.rounds} rounds; core {args.core if args.core is not None else 'not pinned'}; "
        f"load average {os.getloadavg()[0]:.2f}",
        flush=True,
    )
    for k in range(args.rounds):
        cells = []
        for name, (tree, preset) in variants.items():
            result = measure(tree, args.designs, args.seed, preset)
            runs[name].append(result)
            cells.append(
                f"[{name}] {result['evaluation']:.4f} s (floor {result['floor']:.4f} s, "
                f"ratio {result['ratio']:.3f})"
            )
        print(f"round {k + 1}: " + "; ".join(cells), flush=True)

    med = statistics.median
    base = runs["baseline"]
    print(f"\nmedians over {args.rounds} rounds (load average now {os.getloadavg()[0]:.2f}):")
    head = (
        f"{'variant':<28} {'evaluation s':>12} {'CPU s':>8} {'floor s':>8} {'CPU s':>8} "
        f"{'eval/floor':>10} {'(CPU)':>6} {'eval/baseline':>13} {'(CPU)':>6}"
    )
    print(head)
    print("-" * len(head))
    for name, results in runs.items():
        against = [r["evaluation"] / b["evaluation"] for r, b in zip(results, base, strict=True)]
        against_cpu = [
            r["evaluation_cpu"] / b["evaluation_cpu"] for r, b in zip(results, base, strict=True)
        ]
        print(
            f"{name:<28} {med(r['evaluation'] for r in results):>12.4f} "
            f"{med(r['evaluation_cpu'] for r in results):>8.4f} "
            f"{med(r['floor'] for r in results):>8.4f} "
            f"{med(r['floor_cpu'] for r in results):>8.4f} "
            f"{med(r['ratio'] for r in results):>10.3f} "
            f"{med(r['cpu_ratio'] for r in results):>6.3f} {med(against):>13.3f} "
            f"{med(against_cpu):>6.3f}"
        )
    print(
        "targets (issue 31): eval/baseline <= 0.5 at the preset, eval/floor <= 1.10; "
        "measured on a loaded machine these are noise"
    )


if __name__ == "__main__":
    main()
