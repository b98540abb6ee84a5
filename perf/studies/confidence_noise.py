"""The noise floor of F: how much each estimator of Pi_U moves under nudges of the scene.

The same design is evaluated in scenes that differ only by a nudge of the box, at most
``--shift`` in position and ``--turn`` in yaw, drawn at random (seeded). The goal error barely
moves (the trajectory is the same); an estimator whose confidence moves much more measures noise.
For every estimator setting, per design: the relative spread (max - min) / |mean| over the nudges
of F, of the confidence and of the goal error; printed: the median over the designs.

Every estimator is scored on the SAME rollouts (one per design and nudge), so the differences
between rows are the estimators' alone. At p^X = 0 (pure confidence) F is minus the confidence,
so F's spread is the confidence's; the script says so.

Also printed: what the contact estimator costs, as a share of one evaluation with it (build,
rollout with the contact log, Jacobians and scoring). For every design and scene the same design
is evaluated on the same simulator with the estimator and without it (no recording, no scoring),
in alternating order, each timed in CPU time of this thread (``time.thread_time``); printed is
the median over these pairs of (with - without) / with, and its quartiles. A ratio within a pair
barely moves with the machine's load, where a difference of medians of wall-clock times did
(4-37 %).

With ``--scene-samples K ...`` it also scores F averaged over K scenes
(``ObjectiveSpec.scene_samples``, the contact estimator): each nudged scene is used with the box
at the K fixed offsets of ``scene_offsets`` added to its nudge, and the table gives the spread of
the mean over the nudges for each K, and its cost relative to one rollout.

Run: ``python -m perf.studies.confidence_noise [--designs 12] [--nudges 6] [--seed 1]
[--scene-samples 1 4 8] [--section-shape square|round] [--scene FIELD=VALUE]`` (the section: the
default tool's, round; ``--scene``, e.g. ``merge_fixed_links=False``: a scene other than the
default, nudged the same way).
Targets (issue 8): median spread of F <= 1 %, of the confidence <= 2 %, cost <= 30 %, over at
least 12 random valid designs and nudges of at most 0.1 mm and 1e-4 rad (the defaults of
``--shift`` and ``--turn``; larger ones are allowed, but the targets do not speak of them), at
p^X > 0 for F (docs/model.md, "The targets"). Bad input (``--nudges`` below 2, ``--designs``
below 1, a negative ``--shift`` or ``--turn``, an unknown ``--settings`` name, a goal outside
the workspace) is an argparse error.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import replace

import numpy as np

from benchmarks.execution import TaskSettings
from perf import _args
from perf.speed.physics_options import add_scene_option
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
        if geometry.buildable and sim.build(geometry).usable:
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


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: every bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--designs", type=_args.count(1), default=12)
    parser.add_argument(
        "--nudges",
        type=_args.count(2, why=" (a spread needs two scenes)"),
        default=6,
        help="scenes per design, base included (>= 2)",
    )
    parser.add_argument(
        "--shift",
        type=_args.number(0.0, unit="m"),
        default=1e-4,
        help="largest box shift, m (the targets of issue 8 are stated for <= 1e-4)",
    )
    parser.add_argument(
        "--turn",
        type=_args.number(0.0, unit="rad"),
        default=1e-4,
        help="largest box turn, rad (the targets of issue 8 are stated for <= 1e-4)",
    )
    parser.add_argument("--seed", type=_args.seed, default=1)
    parser.add_argument("--goal-precision", type=float, default=20.0)
    parser.add_argument("--goal", type=float, nargs=3, default=(0.0, 1.5, 0.1))
    parser.add_argument(
        "--settings",
        nargs="*",
        choices=list(SETTINGS),
        default=list(SETTINGS),
        metavar="NAME",
        help=f"names of estimator settings, of: {', '.join(repr(n) for n in SETTINGS)}",
    )
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool's section (ToolSpec.section_shape)",
    )
    parser.add_argument(
        "--scene-samples",
        type=_args.count(1),
        nargs="*",
        default=[],
        help="also score F averaged over K scenes, for each K given (contact estimator)",
    )
    add_scene_option(
        parser,
        "a SceneSpec field changed from its default, e.g. merge_fixed_links=False: "
        "the scene that is nudged",
    )
    args = parser.parse_args(argv)
    try:
        TaskSettings(goal=tuple(args.goal), goal_precision=args.goal_precision)
    except (TypeError, ValueError) as error:
        parser.error(f"--goal / --goal-precision: {error}")
    args.scene_spec = _args.check_scene(parser, args)
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure and print."""
    args = parse_args(argv)
    base = args.scene_spec
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
    # One (plain, evaluation with the contact estimator) pair of CPU times per design and scene.
    pairs: list[tuple[float, float]] = []
    # smoothed[design][nudge][k] -> (F, confidence, goal error) of the k-th scene of that nudge
    smoothed: list[list[list[tuple[float, float, float]]]] = []
    contact = ObjectiveSpec(goal_precision=args.goal_precision)
    for c in designs:
        geometry = make_tool(c, tool_spec)
        rows: dict[str, list[tuple[float, float, float]]] = {n: [] for n in specs}
        for sim in sims:
            # The cost pair: the same design on the same simulator, without recording and with
            # the contact estimator (recording and scoring), in alternating order.
            plain_first = len(pairs) % 2 == 0
            if plain_first:
                plain = timed_plain(sim, geometry)
            traj, evaluation = timed_evaluation(sim, geometry, goal, contact)
            if not plain_first:
                plain = timed_plain(sim, geometry)
            pairs.append((plain, evaluation))
            for name, spec in specs.items():
                out = score(traj, sim, goal, spec)
                rows[name].append((out.free_energy, out.confidence, out.goal_error))
        for name in specs:
            terms[name].append(rows[name])
        if args.scene_samples:
            smoothed.append(score_smoothed(geometry, scenes, max(args.scene_samples), goal, args))

    arm = "13-link arm" if not base.merge_fixed_links else "hand merged (9 links)"
    print(
        f"{len(designs)} random valid designs (seed {args.seed}), {args.nudges} scenes each "
        f"(box shift <= {args.shift * 1e3:g} mm, turn <= {args.turn:g} rad), "
        f"p^X = {args.goal_precision:g}, {args.section_shape} section, {arm}"
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
    if args.goal_precision == 0:
        print(
            "p^X = 0 (pure confidence): F = -confidence, so F's spread is the confidence's "
            "(the target on F, <= 1 %, is stated at p^X > 0; the confidence's is <= 2 %)"
        )
    print(cost_line(pairs))
    if args.scene_samples:
        print_smoothed(smoothed, args.scene_samples)


def timed_plain(sim: ToolSimulator, geometry: ToolGeometry) -> float:
    """CPU time of this thread to build ``geometry`` and roll it out without recording, s."""
    t0 = time.thread_time()
    sim.build(geometry)
    sim.run()
    return time.thread_time() - t0


def timed_evaluation(
    sim: ToolSimulator, geometry: ToolGeometry, goal: np.ndarray, spec: ObjectiveSpec
) -> tuple[Trajectory, float]:
    """The recorded rollout, and the CPU time of build, rollout and scoring with ``spec``, s."""
    t0 = time.thread_time()
    sim.build(geometry)
    traj = sim.run(record_mobility=True)
    score(traj, sim, goal, spec)
    return traj, time.thread_time() - t0


def cost_line(pairs: list[tuple[float, float]]) -> str:
    """The contact estimator's share of one evaluation: the median of the per-pair shares.

    Each pair is the CPU time of the same design on the same simulator built and rolled out
    without recording (plain) and evaluated with the contact estimator (built, rolled out with
    the contact log, scored): its share is (evaluation - plain) / evaluation. CPU time of this
    thread and a median of per-pair ratios, so that the machine's load moves it little.
    """
    shares = [(evaluation - plain) / evaluation for plain, evaluation in pairs]
    plain = statistics.median(p for p, _ in pairs)
    evaluation = statistics.median(e for _, e in pairs)
    return (
        f"contact estimator cost: {100 * statistics.median(shares):.1f} % of an evaluation "
        f"(median over {len(pairs)} pairs of the same design and scene, CPU time; "
        f"quartiles {100 * _quantile(shares, 0.25):.1f}-{100 * _quantile(shares, 0.75):.1f} %; "
        f"evaluation {evaluation * 1e3:.1f} ms, without the estimator {plain * 1e3:.1f} ms)"
    )


def _quantile(values: list[float], q: float) -> float:
    return float(np.quantile(values, q))


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
