"""``tooldesign evaluate``: score given coefficients and write everything a user would look at."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from benchmarks.cli._common import (
    add_task_arguments,
    add_task_name_argument,
    box_mass_flag,
    check_in_default_bounds,
    check_out_folder,
    out_path,
    task_goal,
    unique_pairs,
)


def add_parser(subparsers: Any) -> None:
    """Register ``tooldesign evaluate``."""
    p = subparsers.add_parser(
        "evaluate",
        help="evaluate given coefficients: terms, trajectories, mesh and plots",
        description="Score given coefficients and write everything a user would look at: "
        "terms (JSON), trajectories (CSV), mesh (STL/OBJ/URDF) and plots.",
    )
    p.add_argument(
        "--coeffs",
        type=float,
        nargs="+",
        required=True,
        metavar="C",
        help="coefficients c1 ... cn, highest power first; their count is the polynomial "
        "degree n (the paper's tool has 3; 1 to 20)",
    )
    p.add_argument(
        "--out", type=out_path, required=True, metavar="DIR", help="output folder (created)"
    )
    add_task_arguments(p, goal_of_task=True)
    add_task_name_argument(p)
    p.add_argument(
        "--robustness",
        action="store_true",
        help="also test the design under box masses 0.3, 0.5, 0.7, 0.9 kg",
    )
    p.add_argument(
        "--outside-bounds",
        action="store_true",
        help="accept coefficients outside the default bounds (c1, c2 in [-1.5, 1.5], "
        "c3 in [-0.5, 0.5]); without it they are refused, as env.step refuses them",
    )
    p.add_argument(
        "--video",
        action="store_true",
        help="also write rollout.gif: the rollout rendered headless, with the goal and the box "
        "path (about 20 s more; a valid design only: an invalid one is not simulated)",
    )
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    # Bad input is refused in well under a second, before the simulation and the plotting are
    # imported (seconds on a busy machine); the library checks everything again.
    check_out_folder(args.out, empty=True)
    goal = task_goal(args)  # an unknown task, or a goal outside its range: refused now
    box_mass = box_mass_flag(args)  # in the words of tooldesign design's
    if not args.outside_bounds:
        check_in_default_bounds(args.coeffs)
    import numpy as np

    from benchmarks.design.evaluate import evaluate_coefficients
    from benchmarks.reports import write_evaluation_report

    info = evaluate_coefficients(
        args.coeffs,
        args.out,
        goal=goal,
        goal_precision=args.goal_precision,
        box_mass=box_mass,
        estimator=args.estimator,
        objective=args.objective,
        scene_samples=args.scene_samples,
        section_shape=args.section_shape,
        scene=unique_pairs(args.scene, "--scene"),
        robustness=args.robustness,
        outside_bounds=args.outside_bounds,
        video=args.video,
        task=args.task,
    )
    write_evaluation_report(args.out)
    status = "valid" if info["valid"] else f"INVALID ({info['invalid_reason']})"
    if args.video and not info["valid"]:
        print(
            f"no rollout.gif: the design is invalid ({info['invalid_reason']}), so it was not "
            "simulated and there is no rollout to show",
            file=sys.stderr,
        )
    print(
        f"design {np.round(info['coefficients'], 6).tolist()}: {status}\n"
        f"  free energy F = {info['free_energy']:.6g}  (goal error {info['goal_error']:.6g}, "
        f"confidence {info['confidence']:.6g}, penalty {info['penalty']:.6g})\n"
        f"  final distance to the goal: {info['final_distance']:.3f} m "
        f"({'success' if info['success'] else 'no success'} on the {info['task']} task)\n"
        f"  written to {args.out}"
    )
    return 0
