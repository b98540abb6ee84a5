"""The report of a design run (``tooldesign design``), drawn from its stored files alone.

:func:`write_design_report` reads the run folder (``manifest.json`` for the task and the degree,
``evaluations.csv``, ``design.json``, ``robustness.json`` and ``box_paths.json``) and writes the
panels of the paper's Figure 3 (``fig3a``-``fig3d`` and ``figure3.png``), ``robustness.png`` and
``report.html``. Nothing is simulated, so a run folder copied from elsewhere can be redrawn.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from benchmarks.design.stepper import iteration_bests
from benchmarks.reports import plots
from benchmarks.reports.html import write_html_report
from benchmarks.storage import (
    DESIGN_RUN_FILES,
    MANIFEST_NAME,
    ResultStore,
    finite_number,
    read_design_run_files,
    read_manifest,
    short_repr,
)
from benchmarks.storage.runfolder import record_report_files
from tooldesign_env.schema import coefficient_columns

__all__ = ["DesignRun", "read_design_run", "write_design_report"]


def _iteration_colorbar(ax: Any, iterations: Sequence[int]) -> None:
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    if not len(iterations):
        return
    low, high = float(min(iterations)), float(max(iterations))
    mappable = ScalarMappable(
        Normalize(low, high if high > low else low + 1.0), colormaps["viridis"]
    )
    bar = ax.figure.colorbar(mappable, ax=ax, fraction=0.046, pad=0.04)
    bar.set_label("iteration")
    from matplotlib.ticker import MaxNLocator

    bar.locator = MaxNLocator(integer=True)
    bar.update_ticks()


def _best_index(bests: pd.DataFrame) -> int | None:
    """Position (in ``bests``) of the run's best design: the iteration best with the lowest F."""
    if not len(bests):
        return None
    return int(np.argmin(bests["free_energy"].to_numpy(dtype=float)))


def _panel_curves(
    ax: Any, designs: list[np.ndarray], bests: pd.DataFrame, labels: list[str] | None, spec: Any
) -> None:
    plots.plot_tool_shapes(
        ax, designs, labels, colors=plots.sequential_colors(len(designs)), spec=spec
    )
    k = _best_index(bests)
    if k is not None:
        plots.plot_tool_shapes(
            ax,
            [designs[k]],
            [f"best tool (iteration {int(bests['iteration'].iloc[k])})"],
            colors=["red"],
            linewidth=3.5,
            spec=spec,
        )
        plots.legend(ax)
    _iteration_colorbar(ax, bests["iteration"].tolist())
    ax.set_title("a) best tool of each iteration (centrelines, m)")


def _panel_free_energy(ax: Any, evaluations: pd.DataFrame, bests: pd.DataFrame) -> None:
    ok = evaluations[evaluations["status"] == "ok"]
    ax.plot(ok["iteration"], ok["free_energy"], "o", color="0.7", markersize=3, label="evaluations")
    ax.plot(
        bests["iteration"], bests["free_energy"], "o-", color="tab:blue", label="iteration best"
    )
    so_far = evaluations.groupby("iteration", sort=True)["best_so_far"].last()
    ax.step(so_far.index, so_far.to_numpy(), where="post", color="black", label="best so far")
    scale = ""
    if len(bests) and len(ok):
        # Every evaluation stays visible. A bad candidate can score 100 times the good ones;
        # then a log (or, with F <= 0, symmetric-log) axis keeps the iteration bests readable
        # without clipping it.
        low = float(ok["free_energy"].min())
        top = float(ok["free_energy"].max())
        spread = float(np.nanmax([bests["free_energy"].max(), low])) - low
        margin = 0.05 * max(top - low, abs(top), 1.0)
        if top - low > 10.0 * max(spread, 1.0):
            if low > 0:
                ax.set_yscale("log")
                ax.set_ylim(low / 1.05, top * 1.05)
                scale = ", log scale"
            else:
                ax.set_yscale("symlog", linthresh=max(abs(low), spread, 1.0))
                ax.set_ylim(low - margin, top + margin)
                scale = ", symmetric log scale"
            _readable_log_ticks(ax, low, top)
        else:
            ax.set_ylim(low - margin, top + margin)
    ax.set_xlabel("iteration")
    ax.set_ylabel(f"F (dimensionless{scale})")
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.grid(True, alpha=0.3)
    ax.legend(frameon=False, fontsize="small")
    ax.set_title("b) free energy F per iteration (dimensionless)")


def _readable_log_ticks(ax: Any, low: float, top: float) -> None:
    """About 5 to 8 labelled ticks on a log F axis, as plain numbers (8,000, not 8x10^3).

    Matplotlib labels only the powers of ten, so a range within one decade (F from 8000 to
    15000) showed a single label, 10^4.
    """
    from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator, NullLocator

    low, top = max(low, 1e-12), max(top, low * 1.0001)
    decades = math.log10(top / low)
    subs = (1.0, 2.0, 5.0) if decades > 1.5 else tuple(float(k) for k in range(1, 10))
    if decades > 4:
        subs = (1.0,)
    ticks: list[float] = []
    for power in range(math.floor(math.log10(low)) - 1, math.ceil(math.log10(top)) + 1):
        ticks.extend(sub * 10.0**power for sub in subs)
    inside = [t for t in ticks if low / 1.05 <= t <= top * 1.05]
    if decades <= 1.0:  # within a decade: evenly spaced round numbers read best
        values = MaxNLocator(nbins=7, steps=[1, 2, 2.5, 5, 10]).tick_values(low, top)
        below = [float(t) for t in values if 0 < t <= low]
        if below:  # a labelled tick under the best F, which is the one read
            ax.set_ylim(below[-1], ax.get_ylim()[1])
        inside = [float(t) for t in values if (below[-1] if below else low) <= t <= top * 1.05]
    while len(inside) > 9:
        inside = inside[::2]
    ax.yaxis.set_major_locator(FixedLocator(inside))
    ax.yaxis.set_minor_locator(NullLocator())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:,.6g}"))


def _panel_paths(
    ax: Any,
    paths: list[np.ndarray],
    bests: pd.DataFrame,
    labels: list[str] | None,
    goal: Sequence[float],
) -> None:
    k = _best_index(bests)
    if k is not None and len(paths[k]):
        # Under the markers: the goal star stays visible on top of the thick path.
        path = np.asarray(paths[k])
        ax.plot(path[:, 0], path[:, 1], color="red", linewidth=3.0, label="best tool", zorder=3)
    plots.plot_box_paths(ax, paths, goal, labels, colors=plots.sequential_colors(len(paths)))
    _iteration_colorbar(ax, bests["iteration"].tolist())
    ax.set_title("c) box paths of the best tools, top view (m)")


def _panel_tool(ax: Any, coeffs: np.ndarray, free_energy: float | None, spec: Any) -> None:
    from matplotlib.patches import Circle, Polygon

    from tooldesign_env import make_tool

    geometry = make_tool(coeffs, spec)
    corners = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    style = {"facecolor": "tab:orange", "edgecolor": "0.3", "lw": 0.5}
    # The collision shapes seen from above: boxes, or capsules (a rectangle and two discs).
    shapes = [(b.center, b.yaw, np.asarray(b.half_extents)[:2]) for b in geometry.boxes]
    shapes += [(c.center, c.yaw, np.array([c.half_length, c.radius])) for c in geometry.capsules]
    for center, yaw, half in shapes:
        c, s = math.cos(yaw), math.sin(yaw)
        turn = np.array([[c, s], [-s, c]])
        world = (corners * half) @ turn + np.asarray(center)[:2]
        ax.add_patch(Polygon(world, closed=True, **style))
    for capsule in geometry.capsules:
        axis = capsule.half_length * np.array([math.cos(capsule.yaw), math.sin(capsule.yaw)])
        for end in (np.asarray(capsule.center)[:2] - axis, np.asarray(capsule.center)[:2] + axis):
            ax.add_patch(Circle(tuple(end), capsule.radius, **style))
    plots.plot_tool_shapes(ax, [coeffs], ["centreline"], colors=["black"], linewidth=0.8, spec=spec)
    from matplotlib.patches import Patch

    handles, names = ax.get_legend_handles_labels()
    kind = "capsules" if geometry.capsules else "boxes"
    shape = Patch(
        facecolor="tab:orange",
        edgecolor="0.3",
        lw=0.5,
        label=f"collision {kind} from above ({spec.section:g} m section)",
    )
    ax.legend([*handles, shape], [*names, shape.get_label()], frameon=False, fontsize="small")
    text = ", ".join(f"{v:.3g}" for v in coeffs)
    energy = "n/a" if free_energy is None else f"{float(free_energy):,.0f}"
    ax.set_title(f"d) final tool, F = {energy} (dimensionless)\nC = ({text})")


@dataclasses.dataclass(frozen=True)
class DesignRun:
    """What the report of a design run draws, read from its folder and checked.

    Attributes:
        folder: The run folder.
        goal: X^g in m, from the manifest's config.
        spec: The tool's ``ToolSpec`` (degree and section), from the manifest's config.
        evaluations: The evaluation log (``ResultStore.read``).
        card: ``design.json``.
        robustness: ``robustness.json``.
        box_paths: ``box_paths.json``.
    """

    folder: Path
    goal: tuple[float, float, float]
    spec: Any
    evaluations: pd.DataFrame
    card: dict[str, Any]
    robustness: dict[str, Any]
    box_paths: dict[str, Any]


def _config_fields(folder: Path) -> tuple[tuple[float, float, float], Any]:
    """The goal and the ``ToolSpec`` a design run's manifest records; ValueError naming a field."""
    from benchmarks.design.config import check_section_shape
    from tooldesign_env import ToolSpec

    where = folder / MANIFEST_NAME
    manifest = read_manifest(folder)

    def bad(field: str, allowed: str, value: Any, present: bool = True) -> ValueError:
        got = ("null" if value is None else short_repr(value)) if present else "nothing"
        return ValueError(f"{where}: field {field!r} must be {allowed}, got {got}")

    config = manifest.get("config")
    if not isinstance(config, dict):
        raise bad("config", "a JSON object of the run's settings", config, "config" in manifest)
    goal = config.get("goal")
    if not (isinstance(goal, list) and len(goal) == 3 and all(finite_number(v) for v in goal)):
        raise bad("config.goal", "a list of 3 finite numbers (m)", goal, "goal" in config)
    bounds = config.get("bounds")
    if not (
        isinstance(bounds, list)
        and bounds
        and all(
            isinstance(b, list) and len(b) == 2 and all(finite_number(v) for v in b) for b in bounds
        )
    ):
        raise bad(
            "config.bounds",
            "a list of [low, high] pairs of finite numbers, one per coefficient",
            bounds,
            "bounds" in config,
        )
    # Runs stored before the section could be chosen have a square one.
    shape = config.get("section_shape", "square")
    try:
        check_section_shape(shape)
    except ValueError as error:
        raise ValueError(f"{where}: field 'config.section_shape': {error}") from None
    try:
        spec = ToolSpec(degree=len(bounds), section_shape=shape)
    except (TypeError, ValueError) as error:  # more coefficients than a tool can have
        raise ValueError(f"{where}: field 'config.bounds': {error}") from None
    return (float(goal[0]), float(goal[1]), float(goal[2])), spec


def read_design_run(run_folder: str | os.PathLike[str]) -> DesignRun:
    """Read and check everything :func:`write_design_report` draws, writing nothing.

    ``tooldesign report`` calls it before it writes any report file, so a damaged folder is
    refused whole rather than half redrawn.

    Args:
        run_folder: A finished ``tooldesign design`` run folder.

    Returns:
        The checked contents.

    Raises:
        FileNotFoundError: If a file the figures need is missing (the run is not finished).
        ValueError: If the manifest's config, the evaluation log, ``design.json``,
            ``robustness.json`` or ``box_paths.json`` is damaged, differs from its recorded
            checksum or does not fit the others; the message names the file and the field.
    """
    out = Path(run_folder)
    files = read_design_run_files(out)  # first: a missing file says the run is not finished
    goal, spec = _config_fields(out)
    evaluations = ResultStore(out).read()
    card, robustness, box_paths = files["card"], files["robustness"], files["box_paths"]
    if len(card["coefficients"]) != spec.degree:
        raise ValueError(
            f"{out / DESIGN_RUN_FILES['card']}: field 'coefficients' must hold {spec.degree} "
            f"numbers (the degree of the manifest's config.bounds), got "
            f"{len(card['coefficients'])}"
        )
    iterations = [int(i) for i in iteration_bests(evaluations)["iteration"]]
    if box_paths["iterations"] != iterations:
        raise ValueError(
            f"{out / DESIGN_RUN_FILES['box_paths']}: field 'iterations' must be the iterations "
            f"of the evaluation log that have a best design, {iterations}, got "
            f"{box_paths['iterations']}"
        )
    return DesignRun(
        folder=out,
        goal=goal,
        spec=spec,
        evaluations=evaluations,
        card=card,
        robustness=robustness,
        box_paths=box_paths,
    )


def write_design_report(
    run_folder: str | os.PathLike[str], *, checked: DesignRun | None = None
) -> list[Path]:
    """Draw the figures and ``report.html`` of a design run folder from its stored files.

    Everything is read and checked (:func:`read_design_run`) before the first file is written.

    Args:
        run_folder: A finished ``tooldesign design`` run folder.
        checked: What :func:`read_design_run` returned for it, if the caller read it already
            (``tooldesign report`` does, before it writes anything); read here if None.

    Returns:
        The files written.

    Raises:
        FileNotFoundError: If a file the figures need is missing (the run is not finished).
        ValueError: If a file is damaged; the message names the file and the field.
    """
    run = read_design_run(run_folder) if checked is None else checked
    out, goal, spec, evaluations = run.folder, run.goal, run.spec, run.evaluations
    card, robustness, stored = run.card, run.robustness, run.box_paths
    bests = iteration_bests(evaluations)
    columns = coefficient_columns(spec.degree)
    designs = [row[columns].to_numpy(dtype=np.float64) for _, row in bests.iterrows()]
    paths = [np.asarray(x, dtype=np.float64).reshape(-1, 3) for x in stored["iteration_bests"]]
    coeffs = np.asarray(card["coefficients"], dtype=np.float64)
    written: list[Path] = []
    # The iterations are told apart by a colour bar (_iteration_colorbar), not a legend: a
    # legend of every iteration hides the plot, and one of the first and last says too little.
    labels = None
    panels: dict[str, Callable[[Any], None]] = {
        "fig3a": lambda ax: _panel_curves(ax, designs, bests, labels, spec),
        "fig3b": lambda ax: _panel_free_energy(ax, evaluations, bests),
        "fig3c": lambda ax: _panel_paths(ax, paths, bests, labels, goal),
        "fig3d": lambda ax: _panel_tool(ax, coeffs, card["free_energy"], spec),
    }
    for key, draw in panels.items():
        figure, ax = plots.new_figure()
        draw(ax)
        written.append(plots.save_png(figure, out / DESIGN_RUN_FILES[key]))
    figure, axes = plots.new_figure_grid(2, 2, figsize=(12.0, 9.0))
    for ax, draw in zip(axes.flat, panels.values(), strict=True):
        draw(ax)
    written.append(plots.save_png(figure, out / DESIGN_RUN_FILES["fig3"]))

    figure, ax = plots.new_figure()
    if robustness.get("error"):
        ax.text(0.5, 0.5, f"not tested: {robustness['error']}", ha="center", va="center", wrap=True)
        ax.set_axis_off()
    else:
        masses = stored["masses"]
        colors = ["black", *plots.sequential_colors(len(masses), "plasma")]
        names = [f"m = {stored['nominal_mass']:g} kg (nominal)"]
        names += [f"m = {m:g} kg" for m in masses]
        trajectories = [
            np.asarray(x, dtype=np.float64).reshape(-1, 3)
            for x in [stored["nominal"], *stored["perturbed"]]
        ]
        plots.plot_box_paths(ax, trajectories, goal, names, colors=colors)
        steps = max(len(trajectories[0]), 1)
        mean = abs(float(robustness["robustness"])) / (max(len(masses), 1) * steps)
        ax.set_title(
            f"final tool's box paths at {len(masses) + 1} box masses (top view, m)\n"
            f"mean deviation from the nominal path: {1000.0 * mean:.3g} mm per step\n"
            f"robustness = {robustness['robustness']:,.1f} m (sum over {len(masses)} masses "
            f"x {steps} steps)",
            fontsize="medium",
        )
    written.append(plots.save_png(figure, out / DESIGN_RUN_FILES["robustness_png"]))
    # The page shows a figure only while it is as written here (html leaves out the others).
    record_report_files(out, written)
    written.append(write_html_report(out))
    return written
