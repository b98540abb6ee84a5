"""How long one evaluation of F takes, next to the floor of simulating the same episode.

Prints, for a fixed set of designs evaluated in one process (``--designs N``: the straight tool,
the hook, then N - 2 uniform random designs), each design's evaluation and its floor measured
back to back (so that load on a shared machine hits both alike):

* the median wall time of ``env.step`` with the env's default estimator (``contact``, which
  records the contact manifold during the rollout and computes Jacobians and mass matrices
  after it), and its parts: building the world, the controlled rollout (with the contact log),
  the objective (the post-rollout mobility, the estimator and F);
* the floor: building the same world and applying the same torques open loop, for the same
  number of simulated control steps, with no controller and no objective
  (``ToolSimulator.replay_open_loop``);
* the ratio evaluation / floor: the median over designs of each design's own ratio, the ratio
  of the medians, and the median of per-design ratios of process CPU time (less sensitive to
  other jobs on a shared machine than wall time);
* the cost of the first evaluation in a fresh process, what a user's first ``env.step`` costs:
  the env's construction (``ToolDesignEnv(...)``, which starts PyBullet and checks the cached
  mesh copies, and ``reset``) plus its first ``env.step`` (which may need the plan's inverse
  kinematics), timed after the child's imports, in a child process with an empty plan cache
  (cold), then in another child that finds the cache on disk (warm). Printed: the median of
  construction + first step, in seconds and in units of the median evaluation (the "medians" of
  the target "first evaluation at most 3 medians"), and the median of each part. The child makes
  the env with the same tool (``--section-shape``) and scene (``--scene``) as the evaluations
  above, and runs the same control loop (``--loop``; a warning says so when the loops differ);
* the cost of the reference (re-simulation) estimator.

Both the evaluation and the floor run in the simulator's control loop, C (the default, inside
PyBullet's server: :mod:`tooldesign_env.native`) or Python (``--loop python``), and the script
says which ran.

``--scene FIELD=VALUE`` measures a scene other than the default, e.g.
``--scene merge_fixed_links=False`` (the 13-link arm, the default before 2026-11-25).

Run: ``taskset -c 0 python -m perf.speed.evaluation_speed [--designs 12] [--repeats 3]
[--scene FIELD=VALUE]`` (``taskset`` pins it, and its child processes, to one core).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np

from perf import _args
from perf.speed.physics_options import add_scene_option, designs
from tooldesign_env import ObjectiveSpec, SceneSpec, ToolDesignEnv, make_tool
from tooldesign_env.geometry import SECTION_SHAPES, ToolSpec
from tooldesign_env.objective import free_energy

#: Run in a child process, after its imports: the wall time of making the env as the parent made
#: it (the same tool and scene; the control loop is the parent's environment's) and resetting it,
#: then of its first env.step; printed as JSON, with the control loop that ran.
_FIRST_EVALUATION = """
import ast, json, sys, time
import numpy as np
from tooldesign_env import SceneSpec, ToolDesignEnv
from tooldesign_env.geometry import ToolSpec
options = ast.literal_eval(sys.argv[1])
kwargs = {"tool": ToolSpec(**options["tool"])}
if options["scene"]:
    kwargs["scene"] = SceneSpec(**options["scene"])
t0 = time.perf_counter()
env = ToolDesignEnv(**kwargs)
env.reset(seed=0)
t1 = time.perf_counter()
env.step(np.zeros(3))
t2 = time.perf_counter()
loop = getattr(env.simulator, "native_status", "Python")
print(json.dumps({"construction": t1 - t0, "step": t2 - t1, "loop": loop}))
env.close()
"""


def first_evaluation(cache_dir: str, options: dict[str, Any]) -> dict[str, Any]:
    """The first evaluation of a fresh process whose plan cache is ``cache_dir``.

    ``options`` are the env's as this process made it: ``{"tool": ToolSpec fields, "scene":
    SceneSpec fields changed}`` (Python literals). Returns the seconds of ``"construction"``
    (``ToolDesignEnv(...)`` and ``reset``) and of the first ``"step"``, and the control ``"loop"``
    that ran (the child inherits this process's environment, TOOLDESIGN_NATIVE_LOOP included).
    """
    env = dict(os.environ, TOOLDESIGN_CACHE_DIR=cache_dir)
    out = subprocess.run(
        [sys.executable, "-c", _FIRST_EVALUATION, repr(options)],
        env=env,
        # `python -c` puts the working folder first on sys.path: run it where there is no
        # package, so PYTHONPATH decides which tooldesign_env is measured.
        cwd=cache_dir,
        check=False,
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        sys.stderr.write(out.stderr)
        raise SystemExit(f"the first evaluation's fresh process failed (exit {out.returncode})")
    result: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--designs",
        type=_args.count(1),
        default=12,
        help="designs in all: the straight tool, the hook, then N - 2 random ones (N >= 1; "
        "1 is the straight tool alone; default: %(default)s)",
    )
    parser.add_argument(
        "--repeats",
        type=_args.count(1),
        default=3,
        help="rounds over the designs (default: %(default)s)",
    )
    parser.add_argument("--seed", type=_args.seed, default=0, help="the random designs' seed")
    parser.add_argument(
        "--reference",
        type=_args.count(0),
        default=3,
        help="designs for the reference estimator, the first N of --designs' list "
        "(0 skips it; default: %(default)s)",
    )
    parser.add_argument(
        "--first",
        type=_args.count(0),
        default=3,
        help="fresh processes per plan-cache state (0 skips them; default: %(default)s)",
    )
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool's section (default: %(default)s)",
    )
    parser.add_argument(
        "--loop",
        choices=("native", "python"),
        default="native",
        help="the control loop: C where built (default), or Python (TOOLDESIGN_NATIVE_LOOP=0)",
    )
    add_scene_option(
        parser,
        "a SceneSpec field changed from its default, e.g. merge_fixed_links=False",
    )
    args = parser.parse_args(argv)
    _args.check_scene(parser, args)
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    scene_fields = dict(args.scene)
    if args.loop == "python":
        # tooldesign_env.native.ENV_SWITCH, by name: compare_trees.py also runs this script
        # against trees that predate the module. Set here and for the child processes below.
        os.environ["TOOLDESIGN_NATIVE_LOOP"] = "0"

    tool = ToolSpec(section_shape=args.section_shape)
    # Without --scene the env is made as older trees make it (compare_trees.py runs this
    # script against them).
    scene: dict[str, Any] = {"scene": SceneSpec(**scene_fields)} if scene_fields else {}
    env = ToolDesignEnv(tool=tool, **scene)
    env.reset(seed=0)
    sim = env.simulator
    env.step(np.zeros(3))  # warm: the plan's inverse kinematics, imports, caches

    step_t, build_t, rollout_t, objective_t, floor_t, ratios, steps = [], [], [], [], [], [], []
    cpu_ratios = []
    for _ in range(args.repeats):
        for c in designs(args.designs, args.seed):
            t0, c0 = time.perf_counter(), time.process_time()
            info = env.step(c)[4]
            step, step_cpu = time.perf_counter() - t0, time.process_time() - c0
            if not info["valid"]:
                continue
            geometry = make_tool(c, tool)
            # The per-step series are left out of info by default (info_series=False); the env
            # keeps the last step's (older versions put them in info).
            series = getattr(env, "_last_series", None) or info
            simulated = series["torques"][: info["fast_forward_from"]]
            t0, c0 = time.perf_counter(), time.process_time()
            sim.replay_open_loop(geometry, simulated)
            floor, floor_cpu = time.perf_counter() - t0, time.process_time() - c0
            step_t.append(step)
            floor_t.append(floor)
            ratios.append(step / floor)
            cpu_ratios.append(step_cpu / floor_cpu)
            steps.append(info["fast_forward_from"])
            # The parts of env.step, as it does them.
            t0 = time.perf_counter()
            sim.build(geometry)
            build_t.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            traj = sim.run(record_mobility=True)
            rollout_t.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            free_energy(
                traj.box_position,
                traj.torques,
                env._goal,
                env.objective,
                mobility=traj.contact_mobility,
                control_dt=sim.control_dt,
            )
            objective_t.append(time.perf_counter() - t0)
    if not step_t:
        raise SystemExit(
            f"none of the {args.designs} designs is valid in this scene: there is nothing to time"
        )

    med = statistics.median
    n_total = len(sim.reference.times)
    period = sim.controller.control_period
    physics_steps = med(steps) * period + round(sim.scene.box_settle_time / sim.scene.time_step)
    print(
        f"designs x repeats: {args.designs} x {args.repeats} (valid: {len(step_t)}); control "
        f"steps per episode: {n_total} ({period} physics steps each); estimator: "
        f"{env.objective.estimator}; control loop: {getattr(sim, 'native_status', 'Python')}"
        + (f"; scene: {scene_fields}" if scene_fields else "")
    )
    print(
        f"evaluation of F (env.step):          median {med(step_t):.4f} s "
        f"(min {min(step_t):.4f}, max {max(step_t):.4f})"
    )
    print(f"  build world (floor, box, arm+tool): median {med(build_t):.4f} s")
    print(
        f"  controlled rollout + contact log:   median {med(rollout_t):.4f} s "
        f"(simulated control steps: median {int(med(steps))} of {n_total})"
    )
    print(f"  objective (mobility, estimator, F): median {med(objective_t):.4f} s")
    print(
        f"floor (build + same steps, open loop, no controller/objective): "
        f"median {med(floor_t):.4f} s, {1e6 * (med(floor_t) - med(build_t)) / physics_steps:.1f} "
        f"us per physics step after the build"
    )
    print(
        f"ratio evaluation / floor: median of per-design ratios {med(ratios):.3f}; "
        f"ratio of medians {med(step_t) / med(floor_t):.3f}; median of per-design CPU-time "
        f"ratios {med(cpu_ratios):.3f}"
    )

    if args.first > 0:
        # The child makes the env as this process did: the same tool and scene; the control
        # loop comes with the environment (TOOLDESIGN_NATIVE_LOOP), and the child says which ran.
        options = {"tool": {"section_shape": args.section_shape}, "scene": scene_fields}
        with tempfile.TemporaryDirectory(prefix="tooldesign-cache-") as cache:
            cold = [
                first_evaluation(tempfile.mkdtemp(dir=cache), options) for _ in range(args.first)
            ]
            warm_dir = tempfile.mkdtemp(dir=cache)
            first_evaluation(warm_dir, options)  # fills it
            warm = [first_evaluation(warm_dir, options) for _ in range(args.first)]
        print(
            "first evaluation in a fresh process, after its imports: the env's construction "
            "(ToolDesignEnv() and reset) + its first env.step; medians: of the median evaluation "
            "above"
        )
        for label, runs in (("empty plan cache:  ", cold), ("plan cache on disk:", warm)):
            total = med(r["construction"] + r["step"] for r in runs)
            construction = med(r["construction"] for r in runs)
            first_step = med(r["step"] for r in runs)
            print(
                f"  {label} construction + first step median {total:.3f} s "
                f"({total / med(step_t):.1f} medians); construction median {construction:.3f} s, "
                f"first step median {first_step:.3f} s ({first_step / med(step_t):.1f} medians)"
            )
        loops = {r["loop"] for r in cold + warm}
        if loops != {getattr(sim, "native_status", "Python")}:
            print(
                f"  WARNING: the fresh processes ran the control loop {sorted(loops)}, this one "
                f"{getattr(sim, 'native_status', 'Python')!r}: their times do not compare"
            )

    if args.reference > 0:
        ref = ToolDesignEnv(tool=tool, objective=ObjectiveSpec(estimator="resimulation"), **scene)
        ref.reset(seed=0)
        ref_t = []
        for c in designs(args.reference, args.seed):
            t0 = time.perf_counter()
            ref.step(c)
            ref_t.append(time.perf_counter() - t0)
        print(
            f"reference estimator (re-simulation): median {med(ref_t):.3f} s over {len(ref_t)} "
            f"designs ({med(ref_t) / med(step_t):.1f}x the default)"
        )
        ref.close()
    env.close()


if __name__ == "__main__":
    main()
