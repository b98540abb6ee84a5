"""Score given coefficients and write everything a user would look at (``tooldesign evaluate``).

Writes into ``--out``:

* ``terms.json``: F and its terms, validity, the design, the task and the settings;
* ``trajectory.csv``: one row per control step (time, phase, box X, torques U, grasp point,
  tool yaw, contact, E_t, c_t, F_t); invalid designs have none;
* ``tool.stl``, ``tool.obj``, ``tool.urdf``: the tool, in metres;
* ``tool_shape.png``, ``box_path.png``, ``free_energy.png``: the tool, the top view of the box path
  and the goal error / confidence / free energy over time (the paper's Figure 4);
* ``report.html``: all of the above in one self-contained page (:mod:`benchmarks.reports.html`);
* with ``--video``: ``rollout.gif``, the rollout rendered headless (goal and box path drawn);
* with ``--robustness``: ``robustness.json``, ``box_paths.json`` (the box paths under the altered
  masses) and ``robustness.png``.

The figures and ``report.html`` are drawn from the files written here by
:func:`benchmarks.reports.write_evaluation_report` (``tooldesign evaluate`` calls both).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.design.config import recorded_scene, scene_spec
from benchmarks.design.video import rollout_gif
from benchmarks.storage import (
    atomic_write_text,
    check_out_dir,
    json_ready,
    json_text,
    package_versions,
)
from tooldesign_env import (
    ToolDesignEnv,
    ToolSpec,
    default_bounds,
    export_mesh,
    make_tool,
    past_bounds,
    tool_urdf,
)
from tooldesign_env.env import COEFFICIENT_MAX
from tooldesign_env.geometry import validate_coefficients
from tooldesign_env.schema import (
    DEFAULT_BOX_MASS,
    DEFAULT_GOAL_PRECISION,
    ROBUSTNESS_MASSES,
    rounded_path,
)
from tooldesign_env.simulation import PHASES
from tooldesign_env.tasks import DEFAULT_TASK, get_task

__all__ = ["evaluate_coefficients", "trajectory_frame"]


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


def evaluate_coefficients(
    coeffs: Any,
    out: Path | str,
    *,
    goal: tuple[float, float, float] | None = None,
    goal_precision: float = DEFAULT_GOAL_PRECISION,
    box_mass: float = DEFAULT_BOX_MASS,
    estimator: str = "contact",
    objective: str = "free-energy",
    scene_samples: int = 1,
    section_shape: str = "round",
    scene: Any = None,
    robustness: bool = False,
    outside_bounds: bool = False,
    video: bool = False,
    task: str = "push",
) -> dict[str, Any]:
    """Evaluate one design and write the files listed in the module docstring.

    One rule for the command line and the API (``env.step``, through
    :func:`tooldesign_env.past_bounds`): a design outside the default bounds
    (``default_bounds``) is refused with a ValueError, unless asked for explicitly (here
    ``outside_bounds=True``, on the command line ``--outside-bounds``, for the env
    ``bounds=``); a coefficient past a bound by rounding only (``ACTION_ROUNDING``) is
    evaluated at the bound.

    Args:
        coeffs: the design (c1, ..., cn), highest power first.
        out: output folder (created).
        goal: goal X^g (x, y, z) in m; None is the task's default goal (the paper's
            (0, 1.5, 0.1) for ``push``).
        goal_precision: p^X.
        box_mass: box mass in kg.
        estimator: estimator of dX/dU.
        objective: what is scored (``free-energy`` or ``expected-goal-error``).
        scene_samples: K, the scenes F is averaged over (``ObjectiveSpec.scene_samples``).
        section_shape: the tool's section (``ToolSpec.section_shape``).
        scene: overrides of ``SceneSpec`` fields, ``{field: value}`` (JSON values, as a design
            run's ``scene``); ``None`` or ``{}`` is the default scene.
        robustness: also test the design under other box masses.
        outside_bounds: accept a design outside the default bounds (the bounds are widened to
            include it).
        video: also write ``rollout.gif``, the rollout rendered headless (valid designs only;
            about 20 s more).
        task: the task (docs/tasks.md): a registered name (``"push"``, the paper's), a
            ``"module:ATTR"`` naming a ``TaskDefinition`` or an installed package's task (entry
            point group ``tooldesign.tasks``): its scene (which ``scene`` overrides field by
            field), plan, obstacles and goal range.

    Returns:
        The env's step ``info``.

    Raises:
        ValueError: the design is malformed, outside the bounds without ``outside_bounds``, a
            coefficient beyond +-1000 (``COEFFICIENT_MAX``) even with it, or ``out`` is an
            existing file or a folder that is not empty.
        TypeError: ``out`` is not a path.
    """
    out = check_out_dir(out)  # before the simulation: a file named like the folder is refused
    if out.is_dir() and any(out.iterdir()):
        # Its files would replace another run's (a design run's tool.stl beside its own
        # design.json) or mix with an earlier evaluation's (a robustness.json of another design).
        raise ValueError(
            f"--out {out} exists and is not empty; tooldesign evaluate writes a folder of its "
            "own: give a new folder, or delete this one first"
        )
    scene_pairs = recorded_scene(scene or {})  # checked: a bad field or value is refused here
    definition = get_task(task)
    if goal is None:
        goal = definition.goal
    elif not definition.accepts_any_goal:
        goal = definition.check_goal(goal, "goal")
    # else push's goal goes to the env unchecked, as before tasks existed: the API refuses a bad
    # one in the words it always was (TaskSpec.goal ...). The command line checks --goal itself,
    # for every task in the same words (benchmarks.cli._common.check_goal_flag).
    if definition.name == DEFAULT_TASK:
        scene_override = scene_spec(scene_pairs)
    else:
        scene_override = dataclasses.replace(definition.scene, **dict(scene_pairs))
        definition.check_scene(scene_override)
    spec = ToolSpec(
        degree=int(np.size(coeffs)) if np.ndim(coeffs) == 1 else 3, section_shape=section_shape
    )
    c = validate_coefficients(coeffs, spec.degree)
    bounds = default_bounds(spec.degree)
    if not np.any(past_bounds(c, bounds[:, 0], bounds[:, 1])):
        c = np.clip(c, bounds[:, 0], bounds[:, 1])  # past a bound by rounding only: the bound
    elif not outside_bounds:
        raise ValueError(
            f"design {c.tolist()} is outside the default bounds {bounds.tolist()} (as env.step "
            "refuses it); pass --outside-bounds (API: outside_bounds=True) to evaluate it anyway"
        )
    else:
        # The bounds are widened to the design below; past COEFFICIENT_MAX the env would refuse
        # those widened bounds, which the user never gave, instead of the coefficient.
        beyond = np.flatnonzero(np.abs(c) > COEFFICIENT_MAX)
        if beyond.size:
            k = int(beyond[0])
            raise ValueError(
                f"coefficient c{k + 1} = {float(c[k])!r} of design {c.tolist()} is beyond "
                f"+-{COEFFICIENT_MAX:g}, the largest any coefficient may be (of a 1.1 m tool), "
                "even with --outside-bounds (API: outside_bounds=True)"
            )
    bounds = np.stack([np.minimum(bounds[:, 0], c), np.maximum(bounds[:, 1], c)], axis=1)
    settings: dict[str, Any] = {
        "goal": goal,
        "goal_precision": goal_precision,
        "box_mass": box_mass,
        "estimator": estimator,
        "objective_kind": objective,
        "scene_samples": scene_samples,
        "bounds": bounds,
        "tool": spec,
    }
    if definition.name != DEFAULT_TASK:
        # The definition, not its name: a task given as "module:ATTR" or by an entry point is
        # not in the registry the env looks names up in.
        settings["task"] = definition
    if scene_override is not None:
        settings["scene"] = scene_override
    env = ToolDesignEnv(**settings, info_series=True)
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
                "scene_samples": scene_samples,
                "section_shape": section_shape,
                "scene": dict(scene_pairs),
                **({"task": definition.name} if definition.name != DEFAULT_TASK else {}),
            },
            "versions": package_versions(),
        }
        if info["valid"]:
            table = trajectory_frame(info)
            atomic_write_text(
                out / "trajectory.csv", table.to_csv(index=False, float_format="%.17g")
            )
            if video:
                rollout_gif(info["coefficients"], out / "rollout.gif", **settings)
            if robustness:
                result = env.evaluate_robustness(info["coefficients"], ROBUSTNESS_MASSES)
                card["robustness"] = {
                    "robustness": result.robustness,
                    "accuracy": result.accuracy,
                    "control_deviation": result.control_deviation,
                    "nominal_mass": result.nominal_mass,
                    "masses": list(result.masses),
                }
                atomic_write_text(out / "robustness.json", json_text(card["robustness"]))
                paths = {
                    "nominal_mass": result.nominal_mass,
                    "masses": list(result.masses),
                    "nominal": rounded_path(result.nominal.box_position),
                    "perturbed": [rounded_path(t.box_position) for t in result.perturbed],
                }
                atomic_write_text(out / "box_paths.json", json_text(paths, compact=True))
        atomic_write_text(out / "terms.json", json_text(card))
        return info
    finally:
        env.close()
