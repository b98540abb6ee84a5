"""Does any physics setting lower the spread of the goal error itself under nudges of the box?

The noise floor of F (``confidence_noise.py``) is the goal error's: pushing is chaotic, and a
0.1 mm nudge of the box moves its end by millimetres. This script asks whether a setting of the
simulation makes the outcome less chaotic. For each setting it evaluates the same random valid
designs in the same nudged scenes (as ``confidence_noise.py``: box shift <= 0.1 mm, turn <=
1e-4 rad) and prints the median over the designs of the relative range (max - min) / |mean| over
the nudges of F, of the confidence and of the goal error, and the median spread of the box's end
position (the largest distance from the mean end position), mm.

Every setting starts from the tool of ``--section-shape`` (the default tool's, round; the figures
in docs/model.md that were measured with the square section give ``--section-shape square``), and
the designs are the first valid ones for that tool. Settings change the scene (``SceneSpec``),
the tool (``ToolSpec``), PyBullet's engine parameters
or the contact dynamics of the box and the tool (``changeDynamics`` after the build). Settings
that change the task (friction, mass) are measured to locate the chaos, not as candidates.

Run: ``python -m perf.studies.physics_noise [--designs 12] [--nudges 6] [--seed 1]
[--section-shape square|round] [--settings default "tool segments 60" ...]``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace
from typing import Any

import numpy as np

from benchmarks.execution import TaskSettings
from perf import _args
from perf.studies.confidence_noise import nudged_scenes, score, spread, valid_designs
from tooldesign_env import ObjectiveSpec, SceneSpec, ToolSimulator, make_tool
from tooldesign_env.geometry import SECTION_SHAPES, ToolSpec

#: name -> (SceneSpec changes, ToolSpec changes, engine parameters, contact dynamics).
SETTINGS: dict[str, tuple[dict[str, Any], dict[str, Any], dict[str, Any], dict[str, Any]]] = {
    "default": ({}, {}, {}, {}),
    "square section": ({}, {"section_shape": "square"}, {}, {}),
    "round section": ({}, {"section_shape": "round"}, {}, {}),
    "round section, 10 segments": ({}, {"section_shape": "round", "n_segments": 10}, {}, {}),
    "round section, 60 segments": ({}, {"section_shape": "round", "n_segments": 60}, {}, {}),
    "tool segments 10": ({}, {"n_segments": 10}, {}, {}),
    "tool segments 15": ({}, {"n_segments": 15}, {}, {}),
    "tool segments 20": ({}, {"n_segments": 20}, {}, {}),
    "tool segments 60": ({}, {"n_segments": 60}, {}, {}),
    "tool segments 120": ({}, {"n_segments": 120}, {}, {}),
    "no cone friction": ({}, {}, {"enableConeFriction": 0}, {}),
    "contact ERP 0.05": ({}, {}, {"contactERP": 0.05}, {}),
    "contact ERP 0.9": ({}, {}, {"contactERP": 0.9}, {}),
    "contact slop 1e-4": ({}, {}, {"contactSlop": 1e-4}, {}),
    "soft contact k=3e4": ({}, {}, {}, {"contactStiffness": 3e4, "contactDamping": 190.0}),
    "soft contact k=3e3": ({}, {}, {}, {"contactStiffness": 3e3, "contactDamping": 60.0}),
    "spinning friction 0.001": ({}, {}, {}, {"spinningFriction": 0.001}),
    "spinning friction 0.01": ({}, {}, {}, {"spinningFriction": 0.01}),
    "tool friction 0 (task change)": ({"tool_friction": 0.0}, {}, {}, {}),
    "tool friction 1 (task change)": ({"tool_friction": 1.0}, {}, {}, {}),
    "box mass 0.5 kg (task change)": ({"box_mass": 0.5}, {}, {}, {}),
}


def measure(name: str, args: argparse.Namespace) -> tuple[float, float, float, float, list[float]]:
    """Median spreads of F, confidence, goal error (relative) and end position (m)."""
    scene_changes, tool_changes, engine, dynamics = SETTINGS[name]
    base = replace(SceneSpec(), **scene_changes)
    scenes = nudged_scenes(base, args.nudges, 1e-4, 1e-4, args.seed)
    sims = [ToolSimulator(scene=s) for s in scenes]
    base_tool = ToolSpec(section_shape=args.section_shape)
    tool_spec = replace(base_tool, **tool_changes)
    # The same designs for every setting, chosen with the base tool, so that rows compare;
    # a design the setting's tool cannot use is skipped below.
    designs = valid_designs(args.designs, args.seed, ToolSimulator(), base_tool)
    goal = np.asarray(args.goal, dtype=float)
    spec = ObjectiveSpec(goal_precision=args.goal_precision)
    f_spread, c_spread, e_spread, ends = [], [], [], []
    for c in designs:
        geometry = make_tool(c, tool_spec)
        rows = []
        for sim in sims:
            if sim.build(geometry).overlaps_box:
                break  # this tool spec makes the design overlap the box: skip it
            client = sim.world.client
            if engine:
                client.setPhysicsEngineParameter(**engine)
            if dynamics:
                robot = sim._robot
                assert robot is not None and sim._box is not None
                client.changeDynamics(sim._box, -1, **dynamics)
                client.changeDynamics(robot.body, robot.tool_link, **dynamics)
            traj = sim.run(record_mobility=True)
            out = score(traj, sim, goal, spec)
            rows.append((out.free_energy, out.confidence, out.goal_error, traj.box_position[-1]))
        else:
            f_spread.append(spread([r[0] for r in rows]))
            c_spread.append(spread([r[1] for r in rows]))
            e_spread.append(spread([r[2] for r in rows]))
            end = np.array([r[3] for r in rows])
            ends.append(float(np.max(np.linalg.norm(end - end.mean(axis=0), axis=1))))
    for sim in sims:
        sim.close()
    return (
        statistics.median(f_spread),
        statistics.median(c_spread),
        statistics.median(e_spread),
        statistics.median(ends),
        e_spread,
    )


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=_args.count(1), default=12, help="random valid designs")
    parser.add_argument(
        "--nudges",
        type=_args.count(2, why=" (a spread needs two scenes)"),
        default=6,
        help="scenes per design, base included (>= 2)",
    )
    parser.add_argument("--seed", type=_args.seed, default=1)
    parser.add_argument("--goal-precision", type=float, default=20.0)
    parser.add_argument("--goal", type=float, nargs=3, default=(0.0, 1.5, 0.1))
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool every setting starts from (default: %(default)s)",
    )
    args = parser.parse_args(argv)
    try:
        TaskSettings(goal=tuple(args.goal), goal_precision=args.goal_precision)
    except (TypeError, ValueError) as error:
        parser.error(f"--goal / --goal-precision: {error}")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    print(
        f"{args.designs} random valid designs (seed {args.seed}, {args.section_shape} section), "
        f"{args.nudges} scenes each "
        "(box shift <= 0.1 mm, turn <= 1e-4 rad); median over designs"
    )
    print(
        f"{'setting':32s} {'F':>7s} {'conf':>7s} {'goal err':>9s} {'end (mm)':>9s}  "
        "goal-error spread per design (%)"
    )
    for name in args.settings:
        t0 = time.perf_counter()
        f, c, e, end, per_design = measure(name, args)
        print(
            f"{name:32s} {100 * f:6.2f}% {100 * c:6.2f}% {100 * e:8.2f}% {1e3 * end:9.1f}  "
            + " ".join(f"{100 * v:.1f}" for v in per_design)
            + f"  ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )


if __name__ == "__main__":
    main()
