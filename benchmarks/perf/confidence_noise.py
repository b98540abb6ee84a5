"""The noise floor of F: how much each estimator of Pi_U moves under nudges of the scene.

The same design is evaluated in scenes that differ only by a nudge of the box, at most
``--shift`` in position and ``--turn`` in yaw, drawn at random (seeded). The goal error barely
moves (the trajectory is the same); an estimator whose confidence moves much more measures noise.
For every estimator setting, per design: the relative spread (max - min) / |mean| over the nudges
of F, of the confidence and of the goal error; printed: the median over the designs.

Every estimator is scored on the SAME rollouts (one per design and nudge), so the differences
between rows are the estimators' alone. Also printed: what the contact estimator costs, as a share
of one evaluation with it (its recording in the loop, the Jacobians and the scoring).

With ``--scene-samples K ...`` it also scores F averaged over K scenes
(``ObjectiveSpec.scene_samples``, the contact estimator): each nudged scene is used with the box
at the K fixed offsets of ``scene_offsets`` added to its nudge, and the table gives the spread of
the mean over the nudges for each K, and its cost relative to one rollout.

Run: ``python benchmarks/perf/confidence_noise.py [--designs 12] [--nudges 6] [--seed 1]
[--scene-samples 1 4 8] [--section-shape square|round] [--scene FIELD=VALUE]`` (the section: the
default tool's, round; ``--scene``, e.g. ``merge_fixed_links=False``: a scene other than the
default, nudged the same way).
Targets (issue 8): median spread of F <= 1 %, of the confidence <= 2 %, cost <= 30 %.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import replace

import numpy as np
from physics_options import add_scene_option  # this folder: the script's own, on sys.path

from tooldesign_env import (
    ObjectiveSpec,
    SceneSpec,
    ToolGeometry,
    ToolSimulator,
    ToolSpec,
    make_tool,
)
from tooldesign_env.env import default_bounds
from tooldesign_env.geometry import SECTION_SHAPES
from tooldesign_env.objective import ObjectiveTerms, free_energy, scene_offsets
from tooldesign_env.simulation import Trajectory

#: name -> ObjectiveSpec changes; the estimators compared by default.
SETTINGS: dict[str, dict[str, object]] = {
    "contact": {"estimator": "contact"},
    "contact, response_time 0.05 s": {"estimator": "contact", "response_time": 0.05},
    "contact, response_time 0.2 s": {"estimator": "contact", "response_time": 0.2},
    "contact, slip_speed 0.003 m/s": {"estimator": "contact", "slip_speed": 0.003},
    "contact, slip_speed 0.03 m/s": {"estimator": "contact", "slip_speed": 0.03},
    "contact, eps 1e-4": {"estimator": "contact", "eps": 1e-4},
    "trajectory (clamped)": {"estimator": "trajectory"},
    "trajectory (gauss-newton)": {"estimator": "trajectory", "form": "gauss-newton"},
    "trajectory, window 96": {"estimator": "trajectory", "window": 96},
}


def nudged_scenes(base: SceneSpec, n: int, shift: float, turn: float, seed: int) -> list[SceneSpec]:
    """``base`` and n - 1 scenes with the box moved by <= shift (m) and turned by <= turn (rad)."""
    rng = np.random.default_rng(seed)
    out = [base]
    for _ in range(n - 1):
        radius = shift * math.sqrt(rng.uniform())
        angle = rng.uniform(0.0, 2.0 * math.pi)
        x, y = base.box_position
        out.append(
            replace(
                base,
                box_position=(x + radius * math.cos(angle), y + radius * math.sin(angle)),
                box_yaw=base.box_yaw + rng.uniform(-turn, turn),
            )
        )
    return out


def valid_designs(
    n: int, seed: int, sim: ToolSimulator, spec: ToolSpec | None = None
) -> list[np.ndarray]:
    """The first n uniform random designs in the default bounds that can be used (as ``spec``)."""
    rng = np.random.default_rng(seed)
    bounds = default_bounds(3)
    out: list[np.ndarray] = []
    while len(out) < n:
        c = rng.uniform(bounds[:, 0], bounds[:, 1])
        geometry = make_tool(c, spec)
        if geometry.buildable and not sim.build(geometry):
            out.append(c)
    return out


def score(
    traj: Trajectory, sim: ToolSimulator, goal: np.ndarray, spec: ObjectiveSpec
) -> ObjectiveTerms:
    """The terms of F of a rollout recorded with ``record_mobility=True``."""
    return free_energy(
        traj.box_position,
        traj.torques,
        goal,
        spec,
        mobility=traj.contact_mobility,
        control_dt=sim.control_dt,
    )


def spread(values: list[float]) -> float:
    """(max - min) / |mean| of a list of numbers (0 if they are all equal, e.g. all 0)."""
    if max(values) == min(values):
        return 0.0
    return (max(values) - min(values)) / abs(statistics.fmean(values))


def main() -> None:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=int, default=12)
    parser.add_argument("--nudges", type=int, default=6, help="scenes per design, base included")
    parser.add_argument("--shift", type=float, default=1e-4, help="largest box shift, m")
    parser.add_argument("--turn", type=float, default=1e-4, help="largest box turn, rad")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--goal-precision", type=float, default=20.0)
    parser.add_argument("--goal", type=float, nargs=3, default=(0.0, 1.5, 0.1))
    parser.add_argument(
        "--settings", nargs="*", default=list(SETTINGS), help="names of estimator settings"
    )
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool's section (ToolSpec.section_shape)",
    )
    parser.add_argument(
        "--scene-samples",
        type=int,
        nargs="*",
        default=[],
        help="also score F averaged over K scenes, for each K given (contact estimator)",
    )
    add_scene_option(
        parser,
        "a SceneSpec field changed from its default, e.g. merge_fixed_links=False: "
        "the scene that is nudged",
    )
    args = parser.parse_args()
    if any(k < 1 for k in args.scene_samples):
        parser.error(f"--scene-samples must be ints >= 1, got {args.scene_samples}")

    base = SceneSpec(**dict(args.scene))
    scenes = nudged_scenes(base, args.nudges, args.shift, args.turn, args.seed)
    sims = [ToolSimulator(scene=s) for s in scenes]
    tool_spec = ToolSpec(section_shape=args.section_shape)
    designs = valid_designs(args.designs, args.seed, sims[0], tool_spec)
    goal = np.asarray(args.goal, dtype=float)
    specs = {
        name: ObjectiveSpec(goal_precision=args.goal_precision, **SETTINGS[name])  # type: ignore[arg-type]
        for name in args.settings
    }
    # terms[name][design] -> list over nudges of (F, confidence, goal error)
    terms: dict[str, list[list[tuple[float, float, float]]]] = {n: [] for n in specs}
    plain_t, recorded_t, score_t = [], [], []
    # smoothed[design][nudge][k] -> (F, confidence, goal error) of the k-th scene of that nudge
    smoothed: list[list[list[tuple[float, float, float]]]] = []
    for c in designs:
        geometry = make_tool(c, tool_spec)
        rows: dict[str, list[tuple[float, float, float]]] = {n: [] for n in specs}
        for sim in sims:
            sim.build(geometry)
            t0 = time.perf_counter()
            traj = sim.run(record_mobility=True)
            recorded_t.append(time.perf_counter() - t0)
            for name, spec in specs.items():
                t0 = time.perf_counter()
                out = score(traj, sim, goal, spec)
                if name == "contact":
                    score_t.append(time.perf_counter() - t0)
                rows[name].append((out.free_energy, out.confidence, out.goal_error))
        # The rollout without recording, for the cost of the contact estimator.
        sims[0].build(geometry)
        t0 = time.perf_counter()
        sims[0].run()
        plain_t.append(time.perf_counter() - t0)
        for name in specs:
            terms[name].append(rows[name])
        if args.scene_samples:
            smoothed.append(score_smoothed(geometry, scenes, max(args.scene_samples), goal, args))

    print(
        f"{len(designs)} random valid designs (seed {args.seed}), {args.nudges} scenes each "
        f"(box shift <= {args.shift * 1e3:g} mm, turn <= {args.turn:g} rad), "
        f"p^X = {args.goal_precision:g}, {args.section_shape} section"
    )
    print(
        f"{'estimator':32s} {'F spread':>9s} {'conf spread':>12s} {'goal-err spread':>16s}"
        f" {'mean conf':>10s} {'mean F':>9s}"
    )
    for name in specs:
        f = [spread([r[0] for r in d]) for d in terms[name]]
        conf = [spread([r[1] for r in d]) for d in terms[name]]
        err = [spread([r[2] for r in d]) for d in terms[name]]
        mean_conf = statistics.fmean(r[1] for d in terms[name] for r in d)
        mean_f = statistics.fmean(r[0] for d in terms[name] for r in d)
        print(
            f"{name:32s} {100 * statistics.median(f):8.2f}% {100 * statistics.median(conf):11.2f}%"
            f" {100 * statistics.median(err):15.2f}% {mean_conf:10.1f} {mean_f:9.1f}"
        )
    if "contact" in specs:
        evaluation = statistics.median(recorded_t) + statistics.median(score_t)
        cost = evaluation - statistics.median(plain_t)
        plain, scoring = statistics.median(plain_t), statistics.median(score_t)
        print(
            f"contact estimator cost: {cost * 1e3:.1f} ms of a {evaluation * 1e3:.1f} ms "
            f"evaluation ({100 * cost / evaluation:.1f} %; rollout without recording "
            f"{plain * 1e3:.1f} ms, scoring {scoring * 1e3:.1f} ms)"
        )
    if args.scene_samples:
        print_smoothed(smoothed, args.scene_samples)


def score_smoothed(
    geometry: ToolGeometry,
    scenes: list[SceneSpec],
    samples: int,
    goal: np.ndarray,
    args: argparse.Namespace,
) -> list[list[tuple[float, float, float]]]:
    """Per nudged scene, the terms in each of its ``samples`` scenes (the offsets added)."""
    spec = ObjectiveSpec(goal_precision=args.goal_precision, scene_samples=samples)
    offsets = scene_offsets(spec)
    out = []
    for scene in scenes:
        sim = ToolSimulator(scene=scene)
        row = []
        for dx, dy, dyaw in offsets:
            sim.build(geometry, box_offset=(float(dx), float(dy), float(dyaw)))
            traj = sim.run(record_mobility=True)
            terms = score(traj, sim, goal, spec)
            row.append((terms.free_energy, terms.confidence, terms.goal_error))
        sim.close()
        out.append(row)
    return out


def print_smoothed(smoothed: list[list[list[tuple[float, float, float]]]], ks: list[int]) -> None:
    """The spread over nudges of the mean over the first K scenes, for each K."""
    print("F averaged over K scenes (ObjectiveSpec.scene_samples; contact estimator):")
    print(f"{'K':>4s} {'F spread':>9s} {'conf spread':>12s} {'goal-err spread':>16s} {'cost':>6s}")
    for k in sorted(ks):
        spreads = []
        for j in range(3):
            per_design = [
                spread([statistics.fmean(r[j] for r in nudge[:k]) for nudge in design])
                for design in smoothed
            ]
            spreads.append(100 * statistics.median(per_design))
        print(f"{k:4d} {spreads[0]:8.2f}% {spreads[1]:11.2f}% {spreads[2]:15.2f}% {k:5d}x")


if __name__ == "__main__":
    main()
