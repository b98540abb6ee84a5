"""``tooldesign evaluate``: score given coefficients and write everything a user would look at.

Writes into ``--out``:

* ``terms.json``: F and its terms, validity, the design, the task and the settings;
* ``trajectory.csv``: one row per control step (time, phase, box X, torques U, grasp point,
  tool yaw, contact, E_t, c_t, F_t); invalid designs have none;
* ``tool.stl``, ``tool.obj``, ``tool.urdf``: the tool, in metres;
* ``tool_shape.png``, ``box_path.png``, ``free_energy.png``: the tool, the top view of the box path
  and the goal error / confidence / free energy over time (the paper's Figure 4);
* ``report.html``: all of the above in one self-contained page (``benchmarks.html_report``);
* with ``--video``: ``rollout.gif``, the rollout rendered headless (goal and box path drawn);
* with ``--robustness``: ``robustness.json`` and ``robustness.png`` (box paths under the altered
  masses).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.evaluation import add_task_arguments
from benchmarks.html_report import write_html_report
from benchmarks.plots import (
    new_figure,
    plot_box_paths,
    plot_time_series,
    plot_tool_shapes,
    save_png,
)
from benchmarks.storage import atomic_write_text, json_ready, json_text, package_versions
from benchmarks.video import rollout_gif
from tooldesign_env import (
    ToolDesignEnv,
    ToolSpec,
    default_bounds,
    export_mesh,
    make_tool,
    tool_urdf,
)
from tooldesign_env.geometry import validate_coefficients
from tooldesign_env.robustness import DEFAULT_MASSES
from tooldesign_env.simulation import PHASES

__all__ = ["add_parser", "evaluate", "trajectory_frame"]


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
        help="coefficients c1 ... cn, highest power first (default degree 3)",
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder (created)")
    add_task_arguments(p)
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
        "path (about 20 s more)",
    )
    p.set_defaults(run=_run)


def _run(args: argparse.Namespace) -> int:
    info = evaluate(
        args.coeffs,
        args.out,
        goal=tuple(args.goal),
        goal_precision=args.goal_precision,
        box_mass=args.box_mass,
        estimator=args.estimator,
        objective=args.objective,
        robustness=args.robustness,
        outside_bounds=args.outside_bounds,
        video=args.video,
    )
    status = "valid" if info["valid"] else f"INVALID ({info['invalid_reason']})"
    print(
        f"design {np.round(info['coefficients'], 6).tolist()}: {status}\n"
        f"  free energy F = {info['free_energy']:.6g}  (goal error {info['goal_error']:.6g}, "
        f"confidence {info['confidence']:.6g}, penalty {info['penalty']:.6g})\n"
        f"  final distance to the goal: {info['final_distance']:.3f} m\n"
        f"  written to {args.out}"
    )
    return 0


def trajectory_frame(info: dict[str, Any]) -> pd.DataFrame:
    """The per-step series of a step's ``info`` as a table (one row per control step)."""
    x, u, p = info["box_trajectory"], info["torques"], info["tool_position"]
    columns: dict[str, Any] = {
        "time": info["times"],
        "phase": [PHASES[i] for i in info["phase"]],
        "box_x": x[:, 0],
        "box_y": x[:, 1],
        "box_z": x[:, 2],
    }
    columns.update({f"torque_{j + 1}": u[:, j] for j in range(7)})
    columns.update({"tool_x": p[:, 0], "tool_y": p[:, 1], "tool_z": p[:, 2]})
    columns.update(
        tool_yaw=info["tool_yaw"],
        contact=info["contact"].astype(int),
        goal_error_t=info["goal_error_t"],
        confidence_t=info["confidence_t"],
        free_energy_t=info["free_energy_t"],
    )
    return pd.DataFrame(columns)


def evaluate(
    coeffs: Any,
    out: Path | str,
    *,
    goal: tuple[float, float, float] = (0.0, 1.5, 0.1),
    goal_precision: float = 20.0,
    box_mass: float = 0.1,
    estimator: str = "contact",
    objective: str = "free-energy",
    robustness: bool = False,
    outside_bounds: bool = False,
    video: bool = False,
) -> dict[str, Any]:
    """Evaluate one design and write the files listed in the module docstring.

    One rule for the command line and the API (``env.step``): a design outside the default
    bounds (``default_bounds``) is refused with a ValueError, unless asked for explicitly
    (here ``outside_bounds=True``, on the command line ``--outside-bounds``, for the env
    ``bounds=``).

    Args:
        coeffs: the design (c1, ..., cn), highest power first.
        out: output folder (created).
        goal: goal X^g (x, y, z) in m.
        goal_precision: p^X.
        box_mass: box mass in kg.
        estimator: estimator of dX/dU.
        objective: what is scored (``free-energy`` or ``expected-goal-error``).
        robustness: also test the design under other box masses.
        outside_bounds: accept a design outside the default bounds (the bounds are widened to
            include it).
        video: also write ``rollout.gif``, the rollout rendered headless (valid designs only;
            about 20 s more).

    Returns:
        The env's step ``info``.

    Raises:
        ValueError: the design is malformed, or outside the bounds without ``outside_bounds``.
    """
    out = Path(out)
    spec = ToolSpec(degree=int(np.size(coeffs)) if np.ndim(coeffs) == 1 else 3)
    c = validate_coefficients(coeffs, spec.degree)
    bounds = default_bounds(spec.degree)
    outside = (c < bounds[:, 0]) | (c > bounds[:, 1])
    if np.any(outside) and not outside_bounds:
        raise ValueError(
            f"design {c.tolist()} is outside the default bounds {bounds.tolist()} (as env.step "
            "refuses it); pass --outside-bounds (API: outside_bounds=True) to evaluate it anyway"
        )
    bounds = np.stack([np.minimum(bounds[:, 0], c), np.maximum(bounds[:, 1], c)], axis=1)
    settings: dict[str, Any] = {
        "goal": goal,
        "goal_precision": goal_precision,
        "box_mass": box_mass,
        "estimator": estimator,
        "objective_kind": objective,
        "bounds": bounds,
        "tool": spec,
    }
    env = ToolDesignEnv(**settings)
    try:
        env.reset(seed=0)
        info = env.step(c)[4]
        out.mkdir(parents=True, exist_ok=True)
        geometry = make_tool(info["coefficients"], env.tool_spec)
        export_mesh(geometry, out / "tool.stl")
        export_mesh(geometry, out / "tool.obj")
        atomic_write_text(out / "tool.urdf", tool_urdf(geometry))
        scalars = {
            k: json_ready(v)
            for k, v in info.items()
            if not isinstance(v, np.ndarray) or v.ndim == 1 and k in ("coefficients", "goal")
        }
        card: dict[str, Any] = {
            **scalars,
            "settings": {
                "goal_precision": goal_precision,
                "box_mass": box_mass,
                "estimator": estimator,
                "objective": objective,
            },
            "versions": package_versions(),
        }
        fig, ax = new_figure()
        plot_tool_shapes(ax, [info["coefficients"]])
        ax.set_title(f"tool C = {np.round(info['coefficients'], 3).tolist()}")
        save_png(fig, out / "tool_shape.png")
        if info["valid"]:
            table = trajectory_frame(info)
            atomic_write_text(
                out / "trajectory.csv", table.to_csv(index=False, float_format="%.17g")
            )
            fig, ax = new_figure()
            plot_box_paths(ax, [info["box_trajectory"]], info["goal"])
            ax.set_title(f"box path, final distance {info['final_distance']:.3f} m")
            save_png(fig, out / "box_path.png")
            fig, ax = new_figure()
            plot_time_series(
                ax,
                info["times"],
                {
                    "goal error E_t = 1/2 p^X |X_t - X^g|^2": info["goal_error_t"],
                    "minus confidence -c_t = -1/2 log|Pi_U,t|": -info["confidence_t"],
                    "free energy F_t = E_t - c_t": info["free_energy_t"],
                },
                ylabel="term per control step (dimensionless; F = sum of F_t)",
            )
            ax.set_title(f"F = {info['free_energy']:.4g}")
            save_png(fig, out / "free_energy.png")
            if video:
                rollout_gif(info["coefficients"], out / "rollout.gif", **settings)
            if robustness:
                result = env.evaluate_robustness(info["coefficients"], DEFAULT_MASSES)
                card["robustness"] = {
                    "robustness": result.robustness,
                    "accuracy": result.accuracy,
                    "control_deviation": result.control_deviation,
                    "nominal_mass": result.nominal_mass,
                    "masses": list(result.masses),
                }
                atomic_write_text(out / "robustness.json", json_text(card["robustness"]))
                fig, ax = new_figure()
                paths = [result.nominal.box_position] + [t.box_position for t in result.perturbed]
                labels = [f"{result.nominal_mass} kg"] + [f"{m} kg" for m in result.masses]
                plot_box_paths(ax, paths, info["goal"], labels)
                ax.set_title("box paths under altered box masses")
                save_png(fig, out / "robustness.png")
        atomic_write_text(out / "terms.json", json_text(card))
        write_html_report(out)
        return info
    finally:
        env.close()
