"""The figures of one evaluated design (``tooldesign evaluate``), drawn from its stored files.

Reads ``terms.json``, ``trajectory.csv`` and, when the design was tested, ``box_paths.json`` in
the folder, and writes ``tool_shape.png``, ``box_path.png``, ``free_energy.png`` (the goal error,
confidence and free energy per control step: the paper's Figure 4) and ``robustness.png``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.reports.html import write_html_report
from benchmarks.reports.plots import (
    new_figure,
    plot_box_paths,
    plot_time_series,
    plot_tool_shapes,
    save_png,
)

__all__ = ["write_evaluation_figures", "write_evaluation_report"]


def write_evaluation_figures(folder: str | os.PathLike[str]) -> list[Path]:
    """Draw the figures of an evaluated design from the files in ``folder``.

    Args:
        folder: The output folder of :func:`benchmarks.design.evaluate.evaluate_coefficients`.

    Returns:
        The PNG files written.

    Raises:
        FileNotFoundError: If ``folder`` has no ``terms.json``.
    """
    out = Path(folder)
    terms = json.loads((out / "terms.json").read_text(encoding="utf-8"))
    coeffs = np.asarray(terms["coefficients"], dtype=np.float64)
    goal = tuple(float(v) for v in terms["goal"])
    written = []
    from tooldesign_env import ToolSpec  # the geometry (trimesh, SciPy), for this figure only

    # The tool that was evaluated: its degree is its coefficients' count, its section is stored.
    shape = terms.get("settings", {}).get("section_shape", ToolSpec().section_shape)
    spec = ToolSpec(degree=coeffs.size, section_shape=shape)
    fig, ax = new_figure()
    plot_tool_shapes(ax, [coeffs], spec=spec)
    text = ", ".join(f"{v:.3g}" for v in coeffs)
    ax.set_title(f"tool C = ({text}): centreline, tool frame (m)")
    written.append(save_png(fig, out / "tool_shape.png"))
    table_path = out / "trajectory.csv"
    if not terms["valid"] or not table_path.is_file():
        return written
    table = pd.read_csv(table_path)
    fig, ax = new_figure()
    plot_box_paths(ax, [table[["box_x", "box_y", "box_z"]].to_numpy()], goal)
    ax.set_title(f"box path, top view (m): final distance {terms['final_distance']:.3f} m")
    written.append(save_png(fig, out / "box_path.png"))
    fig, ax = new_figure()
    plot_time_series(
        ax,
        table["time"].to_numpy(),
        {
            "goal error E_t = 1/2 p^X |X_t - X^g|^2": table["goal_error_t"].to_numpy(),
            "minus confidence -c_t = -1/2 log|Pi_U,t|": -table["confidence_t"].to_numpy(),
            "free energy F_t = E_t - c_t": table["free_energy_t"].to_numpy(),
        },
        ylabel="term per control step (dimensionless; F = sum of F_t)",
    )
    ax.set_title(f"F = {terms['free_energy']:,.0f} (dimensionless): its terms per control step")
    written.append(save_png(fig, out / "free_energy.png"))
    paths_file = out / "box_paths.json"
    if paths_file.is_file():
        stored = json.loads(paths_file.read_text(encoding="utf-8"))
        fig, ax = new_figure()
        paths = [np.asarray(p) for p in [stored["nominal"], *stored["perturbed"]]]
        labels = [f"m = {stored['nominal_mass']:g} kg (nominal)"]
        labels += [f"m = {m:g} kg" for m in stored["masses"]]
        plot_box_paths(ax, paths, goal, labels)
        ax.set_title("box paths at altered box masses, top view (m)")
        written.append(save_png(fig, out / "robustness.png"))
    return written


def write_evaluation_report(folder: str | os.PathLike[str]) -> list[Path]:
    """The figures of :func:`write_evaluation_figures`, then ``report.html`` of the folder."""
    return [*write_evaluation_figures(folder), write_html_report(folder)]
