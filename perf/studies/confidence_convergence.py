"""Is the control confidence a converging quantity as the resolution is refined?

Two studies, printed as tables and drawn in one PNG.

(a) Time-step refinement. Four fixed designs (the straight tool (0, 0, 0), the hook (0, 1.5, 0)
and two random valid designs) are rolled out with the physics time step 1/240, 1/480 and
1/960 s, the control period scaled to 2, 4 and 8 physics steps so that the controller runs at
120 Hz (and every rollout has the same control steps). Each time step is run in 3 nudged scenes
(box moved by <= 0.1 mm and turned by <= 1e-4 rad, the same nudges at every time step) so that
the noise at each resolution can be seen next to the change between resolutions. The contact
estimator (the default) and the trajectory estimator score the SAME rollouts. Printed per
design, time step and estimator: the mean summed confidence over the nudges, its change relative
to the finest time step, its spread over the nudges ((max - min) / |mean|) and the mean goal
error; then per design and estimator the changes between successive time steps.

(b) Agreement with finite differences as the perturbation shrinks. The re-simulation estimator
replays the recorded torques +-P N m for H = 12 control steps (0.1 s, the contact estimator's
default response time) from snapshots; its dX/dU should approach the contact estimator's
linearization as P -> 0 if both measure the same derivative. Per control step in contact with
the box sliding (speed >= ``ObjectiveSpec.slip_speed``), the Frobenius norms of the two dX/dU
are compared for P = 2, 0.5, 0.1, 0.02 N m on the straight tool and the hook. Printed: the
median ratio resim / contact, its quartiles, the median |log ratio|, the same median on the
snapshot steps alone (where the two windows start at the same step) and both summed
confidences. PyBullet's stiction and its inexact restore in contact may keep them apart: the
script reports what it measures and tunes nothing.

Converging means here: in (a), the changes between successive time steps shrink as the step is
halved (ratio of successive changes > 1) and the estimate at the finest steps differs from the
next coarser one by no more than about the noise over nudges; in (b), the median ratio tends
to a constant (ideally 1) and the median |log ratio| shrinks as P decreases.

Run: ``python -m perf.studies.confidence_convergence [--seed 1] [--section-shape square|round]
[--scene FIELD=VALUE] [--figure PATH]`` (about a minute and a half on one core). ``--scene``,
e.g. ``merge_fixed_links=False`` (the 13-link arm, the default before 2026-11-25): a scene other
than the default, in which every time step is run. Unless ``--figure`` says otherwise, the
figure goes to the committed figure of the section (:func:`default_figure`):
``docs/images/confidence_convergence.png`` for the square section, ``..._round.png`` for the
round one, and with ``--scene`` to a name that also gives the scene's fields, so that no run
overwrites the figure of another setting. It is written atomically.
"""

from __future__ import annotations

import argparse
import math
import re
import statistics
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from benchmarks.reports.comparison import DPI, figure_png_bytes
from benchmarks.storage import atomic_write_bytes
from perf import _args
from perf.speed.physics_options import add_scene_option
from perf.studies.confidence_noise import nudged_scenes, score, spread, valid_designs
from tooldesign_env import ObjectiveSpec, SceneSpec, ToolDesignEnv, ToolSimulator, make_tool
from tooldesign_env.geometry import SECTION_SHAPES, ToolSpec
from tooldesign_env.specs import ControllerSpec, TaskSpec

#: (physics time step s, control period in physics steps): the control rate stays 120 Hz.
RESOLUTIONS: tuple[tuple[float, int], ...] = ((1 / 240, 2), (1 / 480, 4), (1 / 960, 8))
#: The estimators of study (a), scored on the same rollouts.
ESTIMATORS: dict[str, ObjectiveSpec] = {
    "contact": ObjectiveSpec(),
    "trajectory": ObjectiveSpec(estimator="trajectory"),
}
#: The fixed designs of both studies.
FIXED_DESIGNS: dict[str, tuple[float, float, float]] = {
    "straight": (0.0, 0.0, 0.0),
    "hook": (0.0, 1.5, 0.0),
}
#: Torque perturbations of the re-simulation estimator in study (b), N m.
PERTURBATIONS: tuple[float, ...] = (2.0, 0.5, 0.1, 0.02)
#: Re-simulation horizon, control steps: 0.1 s at 120 Hz, the contact estimator's response time.
HORIZON = 12
NUDGES, SHIFT, TURN = 3, 1e-4, 1e-4
#: Where the committed figures are (docs/model.md shows both).
IMAGES = Path(__file__).resolve().parents[2] / "docs" / "images"
#: The committed figure of each section (the square's name predates the round section).
FIGURES: dict[str, str] = {
    "square": "confidence_convergence.png",
    "round": "confidence_convergence_round.png",
}


def default_figure(section_shape: str, scene: dict[str, Any] | None = None) -> Path:
    """The figure of a section's study, in ``docs/images``; a scene's fields named after it.

    Args:
        section_shape: The tool's section, one of ``SECTION_SHAPES``.
        scene: ``SceneSpec`` fields changed from the default (``--scene``); ``None`` or ``{}``
            for the default scene, whose figure is the committed one.

    Returns:
        ``docs/images/confidence_convergence.png`` (square) or
        ``docs/images/confidence_convergence_round.png`` (round), with ``_FIELD-VALUE`` per
        scene field before ``.png`` (e.g. ``..._round_merge_fixed_links-False.png``).
    """
    if section_shape not in FIGURES:
        raise ValueError(f"section_shape must be one of {tuple(FIGURES)}, got {section_shape!r}")
    name = Path(FIGURES[section_shape])
    suffix = "".join(
        "_" + re.sub(r"[^A-Za-z0-9_.+-]+", "-", f"{field}-{value!r}").strip("-")
        for field, value in sorted((scene or {}).items())
    )
    return IMAGES / f"{name.stem}{suffix}{name.suffix}"


@dataclass(frozen=True)
class Agreement:
    """Study (b) for one design and perturbation.

    Attributes:
        steps: control steps compared (in contact, box sliding).
        zero: of those, steps where re-simulation found no response at all.
        median_ratio: median of |J_resim| / |J_contact|.
        quartiles: (25 %, 75 %) of the ratio.
        median_log: median |log ratio| over the steps with a nonzero ratio.
        snapshot_ratio: median ratio on the compared steps that start a replay.
        resim_confidence: summed confidence of the re-simulation estimator.
        rollout_difference: largest |X_resim - X_contact| between the two rollouts, m.
    """

    steps: int
    zero: int
    median_ratio: float
    quartiles: tuple[float, float]
    median_log: float
    snapshot_ratio: float
    resim_confidence: float
    rollout_difference: float


def time_step_study(
    designs: dict[str, np.ndarray],
    seed: int,
    goal: np.ndarray,
    tool: ToolSpec,
    scene: SceneSpec | None = None,
) -> dict[tuple[str, float, str], list[tuple[float, float]]]:
    """Study (a): (design, time step, estimator) -> [(confidence, goal error)] over the nudges.

    ``scene``: the scene every time step is run in (its ``time_step`` replaced); the default's
    if ``None``.
    """
    base = SceneSpec() if scene is None else scene
    out: dict[tuple[str, float, str], list[tuple[float, float]]] = {}
    for time_step, period in RESOLUTIONS:
        scenes = nudged_scenes(replace(base, time_step=time_step), NUDGES, SHIFT, TURN, seed)
        controller = ControllerSpec(control_period=period)
        sims = [ToolSimulator(scene=s, controller=controller) for s in scenes]
        for name, coeffs in designs.items():
            geometry = make_tool(coeffs, tool)
            for sim in sims:
                if sim.build(geometry).overlaps_box:
                    raise RuntimeError(f"{name} overlaps the box in a nudged scene")
                traj = sim.run(record_mobility=True)
                for estimator, spec in ESTIMATORS.items():
                    terms = score(traj, sim, goal, spec)
                    row = (terms.confidence, terms.goal_error)
                    out.setdefault((name, time_step, estimator), []).append(row)
        for sim in sims:
            sim.close()
    return out


def agreement_study(
    designs: dict[str, np.ndarray],
    goal: np.ndarray,
    tool: ToolSpec,
    scene: SceneSpec | None = None,
) -> tuple[dict[str, float], dict[tuple[str, float], Agreement]]:
    """Study (b): the contact estimator's summed confidence per design, and the comparisons.

    ``scene``: the scene of every rollout; the default's if ``None``.
    """
    base = SceneSpec() if scene is None else scene
    contact_env = ToolDesignEnv(goal=tuple(goal.tolist()), tool=tool, scene=base, info_series=True)
    resim_envs = {
        p: ToolDesignEnv(
            goal=tuple(goal.tolist()),
            tool=tool,
            scene=base,
            objective=ObjectiveSpec(estimator="resimulation", perturbation=p, horizon=HORIZON),
            info_series=True,
        )
        for p in PERTURBATIONS
    }
    slip = ObjectiveSpec().slip_speed
    dt = contact_env.simulator.control_dt
    confidence: dict[str, float] = {}
    out: dict[tuple[str, float], Agreement] = {}
    for name, coeffs in designs.items():
        info = contact_env.step(coeffs)[4]
        confidence[name] = info["confidence"]
        box = info["box_trajectory"]
        speed = np.linalg.norm(np.diff(box, axis=0, prepend=box[:1]), axis=1) / dt
        norm_c = info["jacobian_norm_t"]
        # Steps in contact with the box sliding: there the contact estimator's J is in full.
        mask = info["contact"] & (speed >= slip) & (norm_c > 0)
        snapshot = mask & (np.arange(mask.size) % HORIZON == 0)
        for p, env in resim_envs.items():
            resim = env.step(coeffs)[4]
            ratio = resim["jacobian_norm_t"] / np.where(mask, norm_c, 1.0)
            steps = ratio[mask]
            logs = np.abs(np.log(steps[steps > 0]))
            out[name, p] = Agreement(
                steps=int(mask.sum()),
                zero=int(np.sum(steps == 0)),
                median_ratio=float(np.median(steps)),
                quartiles=(float(np.quantile(steps, 0.25)), float(np.quantile(steps, 0.75))),
                median_log=float(np.median(logs)) if logs.size else math.nan,
                snapshot_ratio=float(np.median(ratio[snapshot])) if snapshot.any() else math.nan,
                resim_confidence=resim["confidence"],
                rollout_difference=float(np.max(np.abs(resim["box_trajectory"] - box))),
            )
    contact_env.close()
    for env in resim_envs.values():
        env.close()
    return confidence, out


def print_time_steps(results: dict[tuple[str, float, str], list[tuple[float, float]]]) -> None:
    """The table of study (a) and the changes between successive time steps."""
    finest = RESOLUTIONS[-1][0]
    designs = list(dict.fromkeys(key[0] for key in results))
    print(
        f"{'design':10s} {'time step':>9s} {'estimator':10s} {'mean conf':>10s} "
        f"{'vs finest':>9s} {'nudge spread':>12s} {'min':>9s} {'max':>9s} {'goal err':>9s}"
    )
    for name in designs:
        for time_step, _ in RESOLUTIONS:
            for estimator in ESTIMATORS:
                rows = results[name, time_step, estimator]
                conf = [r[0] for r in rows]
                mean = statistics.fmean(conf)
                ref = statistics.fmean(r[0] for r in results[name, finest, estimator])
                print(
                    f"{name:10s} 1/{round(1 / time_step):<7d} {estimator:10s} {mean:10.1f} "
                    f"{100 * (mean - ref) / abs(ref):+8.2f}% {100 * spread(conf):11.2f}% "
                    f"{min(conf):9.1f} {max(conf):9.1f} {statistics.fmean(r[1] for r in rows):9.1f}"
                )
    print()
    print(
        "successive changes of the mean confidence (converging: |d1| > |d2|, |d2| near the noise)"
    )
    print(
        f"{'design':10s} {'estimator':10s} {'d1 240->480':>12s} {'d2 480->960':>12s} "
        f"{'|d1|/|d2|':>9s} {'noise':>9s}"
    )
    for name in designs:
        for estimator in ESTIMATORS:
            means, ranges = [], []
            for time_step, _ in RESOLUTIONS:
                conf = [r[0] for r in results[name, time_step, estimator]]
                means.append(statistics.fmean(conf))
                ranges.append(max(conf) - min(conf))
            d1, d2 = means[1] - means[0], means[2] - means[1]
            quotient = abs(d1) / abs(d2) if d2 else math.inf
            print(
                f"{name:10s} {estimator:10s} {d1:+12.1f} {d2:+12.1f} {quotient:9.2f} "
                f"{statistics.fmean(ranges):9.1f}"
            )
    print("(noise: the mean over the time steps of max - min over the nudges)")


def print_agreement(
    confidence: dict[str, float], results: dict[tuple[str, float], Agreement]
) -> None:
    """The table of study (b)."""
    print(
        f"{'design':10s} {'P N m':>6s} {'steps':>6s} {'zero':>5s} {'med ratio':>10s} "
        f"{'quartiles':>17s} {'med |log|':>9s} {'snap ratio':>10s} {'resim conf':>10s} "
        f"{'contact conf':>12s} {'rollout diff':>12s}"
    )
    for (name, p), a in results.items():
        quartiles = f"{a.quartiles[0]:.3g} - {a.quartiles[1]:.3g}"
        print(
            f"{name:10s} {p:6.2f} {a.steps:6d} {a.zero:5d} {a.median_ratio:10.3g} "
            f"{quartiles:>17s} {a.median_log:9.2f} {a.snapshot_ratio:10.3g} "
            f"{a.resim_confidence:10.1f} {confidence[name]:12.1f} {a.rollout_difference:10.2g} m"
        )


def _nice_log_ticks(ax: Axes) -> None:
    """Plain-number ticks at 1, 2, 3, 5 times powers of ten on a log y axis, no minor ticks."""
    ax.minorticks_off()
    low, high = ax.get_ylim()
    ticks = [
        m * 10.0**e
        for e in range(math.floor(math.log10(low)), math.ceil(math.log10(high)) + 1)
        for m in (1, 2, 3, 5)
        if low <= m * 10.0**e <= high
    ]
    ax.set_yticks(ticks, [f"{t:g}" for t in ticks])


def plot(
    time_steps: dict[tuple[str, float, str], list[tuple[float, float]]],
    agreement: dict[tuple[str, float], Agreement],
    path: Path,
) -> None:
    """Two panels: confidence vs time step, and resim / contact Jacobian ratio vs P."""
    figure = Figure(figsize=(11.0, 4.4), dpi=DPI, layout="constrained")
    FigureCanvasAgg(figure)
    ax_a, ax_b = figure.subplots(1, 2)
    colors = [f"C{i}" for i in range(10)]
    designs = list(dict.fromkeys(key[0] for key in time_steps))
    steps = np.array([ts for ts, _ in RESOLUTIONS])
    for i, name in enumerate(designs):
        for estimator, style in (("contact", "-"), ("trajectory", "--")):
            conf = [[r[0] for r in time_steps[name, ts, estimator]] for ts in steps]
            mean = np.array([statistics.fmean(c) for c in conf])
            low = mean - np.array([min(c) for c in conf])
            high = np.array([max(c) for c in conf]) - mean
            ax_a.errorbar(
                steps,
                mean,
                yerr=[low, high],
                color=colors[i % 10],
                linestyle=style,
                marker="o" if estimator == "contact" else "s",
                capsize=3,
                label=f"{name}, {estimator}",
            )
    ax_a.set_xscale("log")
    ax_a.set_yscale("log")
    ax_a.set_xticks(steps, [f"1/{round(1 / s)}" for s in steps])
    _nice_log_ticks(ax_a)
    ax_a.invert_xaxis()  # refinement goes to the right
    ax_a.set_xlabel("physics time step, s (control at 120 Hz)")
    ax_a.set_ylabel("summed confidence")
    ax_a.set_title("(a) time-step refinement (bars: min-max over 3 nudges)")
    ax_a.legend(fontsize="x-small", ncol=2)
    names_b = list(dict.fromkeys(key[0] for key in agreement))
    ps = np.array(PERTURBATIONS)
    for i, name in enumerate(names_b):
        rows = [agreement[name, p] for p in PERTURBATIONS]
        median = np.array([a.median_ratio for a in rows])
        low = median - np.array([a.quartiles[0] for a in rows])
        high = np.array([a.quartiles[1] for a in rows]) - median
        ax_b.errorbar(
            ps, median, yerr=[low, high], color=colors[i % 10], marker="o", capsize=3, label=name
        )
    ax_b.axhline(1.0, color="0.5", linewidth=0.8, linestyle=":")
    ax_b.set_xscale("log")
    ax_b.set_yscale("log")
    ax_b.set_xticks(ps, [f"{p:g}" for p in ps])
    _nice_log_ticks(ax_b)
    ax_b.invert_xaxis()  # shrinking P goes to the right
    ax_b.set_xlabel("re-simulation torque perturbation P, N m")
    ax_b.set_ylabel("median |dX/dU| resim / contact")
    ax_b.set_title(f"(b) steps in contact, box sliding (H = {HORIZON}; bars: quartiles)")
    ax_b.legend(fontsize="small")
    atomic_write_bytes(path, figure_png_bytes(figure))


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line, checked: a bad value is an argparse error naming it.

    ``args.scene_spec`` is then the ``SceneSpec`` of ``--scene``.
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=_args.seed, default=1, help="random designs and nudges")
    parser.add_argument(
        "--figure",
        type=Path,
        default=None,
        help="PNG to write (default: the section's committed figure, see default_figure)",
    )
    parser.add_argument(
        "--section-shape",
        choices=SECTION_SHAPES,
        default=ToolSpec().section_shape,
        help="the tool's section (default: %(default)s)",
    )
    add_scene_option(
        parser,
        "a SceneSpec field changed from its default, e.g. merge_fixed_links=False: the scene "
        "every time step is run in (its time_step is the study's)",
    )
    args = parser.parse_args(argv)
    args.scene_spec = _args.check_scene(
        parser, args, {"time_step": "the time steps are the study's (RESOLUTIONS)"}
    )
    if args.figure is not None and not args.figure.resolve().parent.is_dir():
        parser.error(f"--figure {str(args.figure)!r}: its folder does not exist")
    return args


def main(argv: list[str] | None = None) -> None:
    """Measure, print and plot."""
    args = parse_args(argv)
    fields = dict(args.scene)
    scene = args.scene_spec
    figure = default_figure(args.section_shape, fields) if args.figure is None else args.figure

    goal = np.asarray(TaskSpec().goal, dtype=float)
    probe = ToolSimulator(scene=scene)
    designs = {name: np.asarray(c, dtype=float) for name, c in FIXED_DESIGNS.items()}
    tool = ToolSpec(section_shape=args.section_shape)
    for i, c in enumerate(valid_designs(2, args.seed, probe, tool)):
        designs[f"random {i + 1}"] = c
    probe.close()
    for name, c in designs.items():
        print(f"{name:10s} C = ({', '.join(f'{v:+.3f}' for v in c)})")

    goal_text = "(" + ", ".join(f"{v:g}" for v in goal) + ") m"
    t0 = time.perf_counter()
    time_steps = time_step_study(designs, args.seed, goal, tool, scene)
    t1 = time.perf_counter()
    print()
    print(
        f"(a) time-step refinement: {NUDGES} scenes per time step (box shift <= {SHIFT * 1e3:g} "
        f"mm, turn <= {TURN:g} rad, seed {args.seed}), control at 120 Hz, goal {goal_text}, "
        f"p^X = {ObjectiveSpec().goal_precision:g}, {args.section_shape} section, "
        f"{'hand merged (9 links)' if scene.merge_fixed_links else '13-link arm'}"
        f"{''.join(f', {k}={v!r}' for k, v in sorted(fields.items()))} ({t1 - t0:.0f} s)"
    )
    print_time_steps(time_steps)

    fixed = {name: designs[name] for name in FIXED_DESIGNS}
    confidence, agreement = agreement_study(fixed, goal, tool, scene)
    t2 = time.perf_counter()
    print()
    print(
        f"(b) |dX/dU| re-simulation (H = {HORIZON} steps = {HORIZON / 120:g} s) / contact "
        f"(response time {ObjectiveSpec().response_time:g} s), per control step in contact with "
        f"the box sliding, time step 1/240 s ({t2 - t1:.0f} s)"
    )
    print_agreement(confidence, agreement)

    plot(time_steps, agreement, figure)
    print()
    print(f"figure: {figure}")


if __name__ == "__main__":
    main()
