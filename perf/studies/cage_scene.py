"""Where can a hooked tool cage the box? Box placements measured with named and random designs.

The plan's pull moves the grasp point radially inward, from (0, 0.70) to (0, 0.35) m, with the
tool pointing along +y. A hook bends toward the tool's +y side, which is the world's -x side at
the end of the sweep, so a box at x < 0 beside the tool's line is missed by a straight tool
during the sweep and the pull, but can lie inside a hook's concavity when the sweep ends; the
pull then drags it toward the base. This script measures that, with a seeded set of designs:

1. **Grid.** For each box placement (x, y) (``--xs``, ``--ys``) and each design (the straight
   tool, hooks, a backward-bent tool and ``--random`` random valid designs drawn with
   ``--seed``): how far the sweep moves the box, how far the pull moves it, the share of the
   pull's control steps with tool-box contact, and the *carried* share: the box's displacement
   along -y during the pull over the tool's (0.35 m). A placement qualifies when the straight
   tool never moves the box (< 1 mm), and every named hook carries it (carried >= 0.7, contact
   during the whole pull).
   Of the placements that qualify, the one where the hooks move the box least during the sweep
   is picked: there the hooks close around the box at the end of the sweep, and the box's
   motion is the pull's.
2. **Detail** of the picked placement (or ``--pick X Y``): each design's box path (start, end
   of sweep, middle and end of pull, final) and final distance to ``--goal``, where the designs
   that move the box leave it (where a goal can be reached from this placement) and, with
   ``--masses``, the paper's robustness figure of each design (-sum_t |X(m_i, t) - X(m, t)|
   over the masses, m) next to the default scene's, so that a caging tool's robustness can be
   compared with a pushing tool's before any optimization.

3. **Claims** (``--claims RUN_FOLDER ...``, no simulation): claims (c) and (d) of the paper on
   retested robustness suite folders (``tooldesign retest``): per p^X the mean robustness,
   control deviation and final distance over the mass range with t intervals and their
   noise, Spearman rho with p^X, the lowest p^X minus each other paired by goal, and the noise
   floor of F. ``--precisions`` and ``--seeds`` pick a comparable subset of a larger suite.

Run: ``python -m perf.studies.cage_scene [--random 6] [--seed 1] [--pick X Y]
[--goal X Y] [--masses 0.3 0.5 0.7 0.9] [--section-shape square|round] [--scene FIELD=VALUE]`` or
``python -m
perf.studies.cage_scene --claims docs/results/cage docs/results/square/robustness
--precisions 0 20 50 --seeds 5``. The committed placement (docs/results/cage) was measured with
the square section and the 13-link arm, the defaults then: ``--section-shape square --scene
merge_fixed_links=False`` repeats it. One rollout takes
0.2 to 0.5 s; the default grid is 20 placements.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats as sstats

from benchmarks.reports.stats import t_interval
from benchmarks.reports.suite import designs_table
from benchmarks.storage import read_designs, read_manifest, read_retests
from benchmarks.suites.config import suite_of_manifest
from perf import _args
from perf.speed.physics_options import add_scene_option
from tooldesign_env import PlanSpec, SceneSpec, ToolSimulator, default_bounds, make_tool
from tooldesign_env.geometry import SECTION_SHAPES, ToolSpec
from tooldesign_env.schema import DEFAULT_GOAL
from tooldesign_env.simulation import PHASES, Trajectory
from tooldesign_env.specs import BOX_MASS_MAX

#: The designs every placement is measured with: (c1, c2, c3), highest power first.
NAMED: dict[str, tuple[float, float, float]] = {
    "straight": (0.0, 0.0, 0.0),
    "hook (0.4, 1.4, 0.18)": (0.4, 1.4, 0.18),
    "hook (0, 1.5, 0)": (0.0, 1.5, 0.0),
    "curl (1.5, 1.5, 0.5)": (1.5, 1.5, 0.5),
    "back (-1.4, 0.8, 0)": (-1.4, 0.8, 0.0),
}

#: Named designs that bend toward the tool's +y side: the ones a cage scene must let carry the box.
HOOKS = ("hook (0.4, 1.4, 0.18)", "hook (0, 1.5, 0)", "curl (1.5, 1.5, 0.5)")

SWEEP, PULL = PHASES.index("sweep"), PHASES.index("pull")


@dataclass(frozen=True)
class Outcome:
    """What one rollout did to the box.

    Attributes:
        sweep: box displacement during the sweep, m.
        pull: box displacement during the pull, m.
        carried: the box's displacement along -y during the pull over the grasp point's, 0 to ~1.
        contact: share of the pull's control steps with tool-box contact.
        path: (5, 2) box (x, y) at the start, the end of the sweep, mid-pull, the end of the pull
            and the end of the episode, m.
        trajectory: (T, 3) the whole box trajectory, m.
    """

    sweep: float
    pull: float
    carried: float
    contact: float
    path: np.ndarray
    trajectory: np.ndarray


def outcome(trajectory: Trajectory) -> Outcome:
    """The box's motion in the sweep and the pull of one rollout."""
    x = trajectory.box_position[:, :2]
    sweep = np.flatnonzero(trajectory.phase == SWEEP)
    pull = np.flatnonzero(trajectory.phase == PULL)
    start, s_end, p_mid, p_end = 0, sweep[-1], pull[len(pull) // 2], pull[-1]
    tool_y = trajectory.tool_position[:, 1]
    travel = float(tool_y[s_end] - tool_y[p_end])
    return Outcome(
        sweep=float(np.linalg.norm(x[s_end] - x[start])),
        pull=float(np.linalg.norm(x[p_end] - x[s_end])),
        carried=float((x[s_end, 1] - x[p_end, 1]) / travel),
        contact=float(np.mean(trajectory.contact[pull])),
        path=x[[start, s_end, p_mid, p_end, -1]].copy(),
        trajectory=trajectory.box_position.copy(),
    )


def random_designs(
    n: int, seed: int, tool: ToolSpec | None = None
) -> dict[str, tuple[float, float, float]]:
    """``n`` random designs in the default bounds, from ``seed``, buildable as ``tool``."""
    rng = np.random.default_rng(seed)
    bounds = default_bounds(3)
    out: dict[str, tuple[float, float, float]] = {}
    while len(out) < n:
        coeffs = tuple(float(v) for v in np.round(rng.uniform(bounds[:, 0], bounds[:, 1]), 3))
        if make_tool(coeffs, tool).buildable:
            out[f"random {len(out)} {coeffs}"] = coeffs  # type: ignore[assignment]
    return out


def measure(
    position: tuple[float, float],
    designs: dict[str, tuple[float, float, float]],
    *,
    masses: tuple[float, ...] = (),
    plan: PlanSpec | None = None,
    tool: ToolSpec | None = None,
    scene: dict[str, Any] | None = None,
) -> dict[str, tuple[Outcome, list[Outcome]] | None]:
    """Each design's outcome with the box at ``position`` (and at each of ``masses``).

    ``scene``: other ``SceneSpec`` fields than the box's position (``--scene``).

    ``None`` for a design that overlaps the box at the start of the sweep.
    """
    sim = ToolSimulator(scene=SceneSpec(box_position=position, **(scene or {})), plan=plan)
    out: dict[str, tuple[Outcome, list[Outcome]] | None] = {}
    try:
        for name, coeffs in designs.items():
            geometry = make_tool(coeffs, tool)
            if sim.build(geometry).overlaps_box:
                out[name] = None
                continue
            nominal = outcome(sim.run())
            altered = [outcome(sim.rollout(geometry, box_mass=m)) for m in masses]
            out[name] = (nominal, altered)
    finally:
        sim.close()
    return out


def robustness(nominal: Outcome, altered: list[Outcome]) -> float:
    """The paper's robustness: -sum_i sum_t |X(m_i, t) - X(m, t)|, m."""
    return -sum(
        float(np.sum(np.linalg.norm(a.trajectory - nominal.trajectory, axis=1))) for a in altered
    )


def qualifies(results: dict[str, tuple[Outcome, list[Outcome]] | None]) -> bool:
    """The straight tool leaves the box alone and every named hook carries it the whole pull."""
    straight = results["straight"]
    if straight is None or max(straight[0].sweep, straight[0].pull) > 1e-3:
        return False
    for name in HOOKS:
        result = results[name]
        if result is None or result[0].carried < 0.7 or result[0].contact < 0.99:
            return False
    return True


def hook_sweep(results: dict[str, tuple[Outcome, list[Outcome]] | None]) -> float:
    """Median over the named hooks of how far the sweep moves the box, m (inf if one overlaps).

    Small: the hooks close around the box at the end of the sweep instead of scooping it up
    during the sweep, so what happens to the box is the pull's doing.
    """
    values = []
    for name in HOOKS:
        result = results[name]
        values.append(math.inf if result is None else result[0].sweep)
    return statistics.median(values)


def print_grid(
    args: argparse.Namespace, designs: dict[str, tuple[float, float, float]]
) -> tuple[float, float] | None:
    """Step 1: every placement of the grid, one line per design; the placement picked.

    Of the placements that qualify, the one whose hooks move the box least in the sweep.
    """
    print("# Grid: box displacement in the sweep / in the pull (m), carried share, pull contact")
    good: dict[tuple[float, float], float] = {}
    for x in args.xs:
        for y in args.ys:
            results = measure((x, y), designs, tool=_tool(args), scene=dict(args.scene))
            ok = qualifies(results)
            if ok:
                good[(x, y)] = hook_sweep(results)
            touched = sum(
                1
                for name, r in results.items()
                if name.startswith("random") and r is not None and r[0].pull + r[0].sweep > 0.01
            )
            print(
                f"box ({x:+.2f}, {y:.2f}): {'QUALIFIES' if ok else 'no'}; the hooks' median "
                f"sweep displacement {hook_sweep(results):.3f} m; random designs that move it: "
                f"{touched} of {args.random}"
            )
            for name, r in results.items():
                if name.startswith("random"):
                    continue
                if r is None:
                    print(f"    {name:24s} overlaps the box at the start")
                    continue
                o = r[0]
                print(
                    f"    {name:24s} {o.sweep:5.3f} / {o.pull:5.3f}  carried {o.carried:5.2f}  "
                    f"contact {o.contact:4.2f}"
                )
    print(
        "placements that qualify (the hooks' median sweep displacement, m):",
        ", ".join(f"({x:+.2f}, {y:.2f}) {d:.3f}" for (x, y), d in good.items()) or "none",
    )
    if not good:
        return None
    pick = min(good, key=lambda key: good[key])
    print(f"picked: ({pick[0]:+.2f}, {pick[1]:.2f}), where the hooks close around the box last")
    return pick


def print_detail(
    args: argparse.Namespace,
    designs: dict[str, tuple[float, float, float]],
    pick: tuple[float, float],
) -> None:
    """Step 2: the picked placement, its paths, where boxes end, and (optionally) robustness."""
    masses = tuple(args.masses)
    scenes = [("cage", pick, tuple(args.goal))]
    if masses:
        scenes.append(("default", SceneSpec().box_position, DEFAULT_GOAL[:2]))
    for label, position, goal in scenes:
        x, y = position
        results = measure(
            position, designs, masses=masses, tool=_tool(args), scene=dict(args.scene)
        )
        print(f"\n# Detail: {label} scene, box at ({x:+.3f}, {y:.3f}), goal {tuple(goal)}")
        print(
            f"path of the box (x, y), m: start ({x:+.2f}, {y:.2f}) -> end of sweep -> mid-pull "
            "-> end of pull -> final; final distance to the goal"
        )
        finals: list[np.ndarray] = []
        rob_cage: list[float] = []
        rob_other: list[float] = []
        for name, r in results.items():
            if r is None:
                print(f"  {name:34s} overlaps the box at the start")
                continue
            nominal, altered = r
            path = " -> ".join(f"({p[0]:+.2f}, {p[1]:.2f})" for p in nominal.path[1:])
            moved = nominal.sweep + nominal.pull > 0.01
            distance = float(np.linalg.norm(nominal.path[-1] - np.asarray(goal)))
            line = (
                f"  {name:34s} {path}  {distance:.3f} m; carried {nominal.carried:4.2f}, "
                f"contact {nominal.contact:4.2f}"
            )
            if masses:
                rob = robustness(nominal, altered)
                line += f", robustness {rob:8.2f} m"
                if moved:
                    (rob_cage if nominal.carried >= 0.7 else rob_other).append(rob)
            print(line)
            if moved:
                finals.append(nominal.path[-1])
        if finals:
            ends = np.asarray(finals)
            print(
                f"  where the {len(ends)} designs that moved the box left it: x in "
                f"[{ends[:, 0].min():+.2f}, {ends[:, 0].max():+.2f}], y in "
                f"[{ends[:, 1].min():.2f}, {ends[:, 1].max():.2f}] m"
            )
        if masses and (rob_cage or rob_other):
            for what, values in (("carried >= 0.7", rob_cage), ("moved, not carried", rob_other)):
                if values:
                    print(
                        f"  robustness over masses {masses}: designs that {what}: median "
                        f"{statistics.median(values):.2f} m (n = {len(values)})"
                    )


def _design_rows(folder: Path, precisions: list[float] | None, seeds: int | None) -> pd.DataFrame:
    """One row per retested final design of a suite folder: its means over masses and repeats.

    ``robustness``, ``control_deviation`` and ``final_distance`` are the design's means over the
    altered masses and the repeated (nudged) scenes of ``tooldesign retest``, and ``*_noise``
    their range across the repeats, as in ``report/stress.md``; ``squared_goal_error`` is the
    final test's, as in ``report/designs.md``. Only variants with p^X in ``precisions`` and the
    suite's first ``seeds`` tasks are kept (all if None).
    """
    suite = suite_of_manifest(read_manifest(folder))
    keep_seeds = set(suite.seeds()[:seeds] if seeds else suite.seeds())
    designs = designs_table(read_designs(folder)).set_index(["variant", "seed"])
    rows = []
    for retest in read_retests(folder):
        stress = [r for r in retest.get("stress") or [] if r["change"] == "mass"]
        precision = float(retest["goal_precision"])
        if not stress or int(retest["seed"]) not in keep_seeds:
            continue
        if precisions is not None and precision not in precisions:
            continue
        per_repeat = pd.DataFrame(stress).groupby("nudge")[list(STRESS)].mean()
        row: dict[str, Any] = {"goal_precision": precision, "seed": int(retest["seed"])}
        for metric in STRESS:
            row[metric] = float(per_repeat[metric].mean())
            row[f"{metric}_noise"] = float(np.ptp(per_repeat[metric].to_numpy()))
        row["squared_goal_error"] = float(
            designs.loc[(retest["variant"], int(retest["seed"])), "squared_goal_error"]
        )
        noise = pd.DataFrame(retest.get("noise") or [])
        row["free_energy_range"] = float(np.ptp(noise["free_energy"])) if len(noise) else math.nan
        rows.append(row)
    return pd.DataFrame(rows)


STRESS = ("robustness", "control_deviation", "final_distance")


def print_claims(folder: Path, precisions: list[float] | None, seeds: int | None) -> None:
    """Claims (c) and (d) on a retested robustness suite folder, with the noise next to them."""
    table = _design_rows(folder, precisions, seeds)
    if table.empty:
        print(f"\n# {folder}: no retested design with a mass stress test")
        return
    values = sorted(table["goal_precision"].unique())
    print(
        f"\n# Claims (c) and (d) in {folder}: {len(table)} designs, p^X in "
        f"{[f'{v:g}' for v in values]}, {table['seed'].nunique()} goals"
    )
    print(
        "mean over goals [95 % t interval] (median noise: a design's range across the "
        "retest's repeated scenes)"
    )
    print(f"{'p^X':>4s}  " + "  ".join(f"{m:>34s}" for m in STRESS))
    for value in values:
        part = table[table["goal_precision"] == value]
        cells = []
        for metric in STRESS:
            ci = t_interval(part[metric].to_numpy())
            noise = float(part[f"{metric}_noise"].median())
            cells.append(f"{ci.estimate:9.4g} [{ci.low:9.4g}, {ci.high:9.4g}] ({noise:6.3g})")
        print(f"{value:4g}  " + "  ".join(f"{c:>34s}" for c in cells))
    print("Spearman rank correlation with p^X (rho > 0: grows with p^X):")
    for metric in (*STRESS, "squared_goal_error"):
        result = sstats.spearmanr(table["goal_precision"], table[metric])
        print(f"  {metric:20s} rho {result.statistic:+.3f}  p {result.pvalue:.3g}  n {len(table)}")
    low = values[0]
    base = table[table["goal_precision"] == low].set_index("seed")
    print(f"p^X = {low:g} minus each other p^X, paired by goal (95 % paired t interval):")
    for value in values[1:]:
        other = table[table["goal_precision"] == value].set_index("seed")
        common = base.index.intersection(other.index)
        for metric in ("robustness", "control_deviation"):
            diff = (base.loc[common, metric] - other.loc[common, metric]).to_numpy()
            _, lo, hi = t_interval(diff)
            floor = max(
                float(base[f"{metric}_noise"].median()), float(other[f"{metric}_noise"].median())
            )
            counts = (lo > 0 or hi < 0) and abs(diff.mean()) > floor
            print(
                f"  vs {value:4g} {metric:18s} {diff.mean():+9.4g} [{lo:+9.4g}, {hi:+9.4g}] "
                f"noise {floor:6.3g}  {'counts' if counts else 'does not count'}"
            )
    print(
        "noise floor of F over these designs (median range over the nudged scenes): "
        f"{float(table['free_energy_range'].median()):.4g}"
    )


def _tool(args: argparse.Namespace) -> ToolSpec:
    return ToolSpec(section_shape=args.section_shape)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--xs",
        type=_args.number(unit="m"),
        nargs="+",
        default=[-0.2, -0.3, -0.4, -0.5, -0.6],
        help="the grid's box x positions, m",
    )
    parser.add_argument(
        "--ys",
        type=_args.number(unit="m"),
        nargs="+",
        default=[1.0, 1.1, 1.2, 1.3],
        help="the grid's box y positions, m",
    )
    parser.add_argument("--random", type=_args.count(0), default=6, help="random valid designs")
    parser.add_argument("--seed", type=_args.seed, default=1)
    parser.add_argument(
        "--pick",
        type=_args.number(unit="m"),
        nargs=2,
        metavar=("X", "Y"),
        help="detail this placement (default: the grid's pick)",
    )
    parser.add_argument(
        "--goal",
        type=_args.number(unit="m"),
        nargs=2,
        metavar=("X", "Y"),
        default=[-0.5, 0.95],
        help="goal of the final distances in the cage scene, m",
    )
    parser.add_argument(
        "--masses",
        type=_args.number(0.0, BOX_MASS_MAX, above=True, unit="kg"),
        nargs="*",
        default=[],
        help="box masses of the --pick detail, kg",
    )
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool's section (docs/results/cage was placed with square) (default: %(default)s)",
    )
    add_scene_option(
        parser,
        "a SceneSpec field other than the box's position, e.g. merge_fixed_links=False: "
        "docs/results/cage was placed with the 13-link arm",
    )
    parser.add_argument("--no-grid", action="store_true", help="only the --pick detail")
    parser.add_argument(
        "--claims",
        type=Path,
        nargs="+",
        metavar="RUN_FOLDER",
        help="instead: claims (c) and (d) on retested robustness suite folders (no simulation)",
    )
    parser.add_argument(
        "--precisions",
        type=_args.number(0.0),
        nargs="+",
        help="with --claims: keep only these p^X values",
    )
    parser.add_argument(
        "--seeds",
        type=_args.count(1),
        help="with --claims: keep only each suite's first SEEDS goals",
    )
    args = parser.parse_args(argv)
    _args.check_scene(
        parser, args, {"box_position": "the placements are the grid's (--xs, --ys, --pick)"}
    )
    placements = [(x, y) for x in args.xs for y in args.ys]
    for position in placements + ([tuple(args.pick)] if args.pick is not None else []):
        try:
            SceneSpec(box_position=position, **dict(args.scene))
        except ValueError as error:
            parser.error(f"--xs / --ys / --pick: {error}")
    if not args.claims and args.no_grid and args.pick is None:
        parser.error("--no-grid needs --pick X Y")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure the grid and, with ``--pick``, one placement in detail."""
    args = parse_args(argv)
    if args.claims:
        for folder in args.claims:
            print_claims(folder, args.precisions, args.seeds)
        return
    start = time.perf_counter()
    designs = {**NAMED, **random_designs(args.random, args.seed, _tool(args))}
    print(f"designs: {len(NAMED)} named + {args.random} random (seed {args.seed})")
    pick = None if args.no_grid else print_grid(args, designs)
    if args.pick is not None:
        pick = (args.pick[0], args.pick[1])
    if pick is not None:
        print_detail(args, designs, pick)
    print(f"\ntime: {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
