"""Plotting helpers shared by ``tooldesign design``, ``tooldesign evaluate`` and the suites.

Every function draws on a given :class:`matplotlib.axes.Axes` and returns it, so callers compose
panels into their own figures. Figures come from
:func:`benchmarks.reports.comparison.new_figure` (Agg canvas,
no pyplot, no global backend switch) and are saved with :func:`save_png`, which writes the same
bytes for the same figure (no timestamp or software tag) and writes them atomically.

Conventions follow the paper's Figure 3: tool shapes are centrelines in the tool frame (x along
the handle, origin at the grasp point, m); box paths are top views (x, y in the world frame, m)
with the start as a black circle, the end as a black cross and the goal as a red star.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from benchmarks.reports.comparison import DPI, figure_png_bytes, new_figure
from benchmarks.storage import atomic_write_bytes

__all__ = [
    "legend",
    "new_figure",
    "new_figure_grid",
    "plot_box_paths",
    "plot_time_series",
    "plot_tool_shapes",
    "save_png",
    "sequential_colors",
]


def new_figure_grid(
    nrows: int, ncols: int, figsize: tuple[float, float]
) -> tuple[Figure, np.ndarray]:
    """A figure with a grid of axes on the Agg canvas, outside pyplot's global state.

    Args:
        nrows: Rows of axes.
        ncols: Columns of axes.
        figsize: (width, height) in inches.

    Returns:
        ``(figure, axes)`` with ``axes`` an (nrows, ncols) array.
    """
    figure = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    FigureCanvasAgg(figure)
    return figure, figure.subplots(nrows, ncols, squeeze=False)


def sequential_colors(n: int, cmap: str = "viridis") -> list[tuple[float, float, float, float]]:
    """``n`` colours evenly along a colormap, early to late (e.g. iterations).

    Args:
        n: Number of colours, >= 0.
        cmap: A matplotlib colormap name.

    Returns:
        ``n`` RGBA tuples; a single colour is the colormap's middle.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"n must be an int >= 0, got {n!r}")
    colormap = colormaps[cmap]
    # Stop at 0.9: the top of viridis is a yellow that vanishes on white.
    stops = [0.45] if n == 1 else np.linspace(0.0, 0.9, n).tolist()
    return [tuple(float(v) for v in colormap(s)) for s in stops]  # type: ignore[misc]


def _labels(labels: Sequence[str] | None, n: int, what: str) -> list[str | None]:
    if labels is None:
        return [None] * n
    if isinstance(labels, str) or len(labels) != n:
        raise ValueError(f"labels must be {n} strings, one per {what}, got {labels!r}")
    return [str(label) for label in labels]


def _colors(colors: Sequence[object] | None, n: int) -> list[object]:
    if colors is None:
        return list(sequential_colors(n))
    if len(colors) != n:
        raise ValueError(f"colors must hold {n} colours, got {len(colors)}")
    return list(colors)


def plot_tool_shapes(
    ax: Axes,
    coeffs_list: Sequence[Sequence[float]] | Sequence[np.ndarray] | np.ndarray,
    labels: Sequence[str] | None = None,
    *,
    colors: Sequence[object] | None = None,
    linewidth: float = 2.0,
    spec: object | None = None,
    key: bool = True,
) -> Axes:
    """Draw tool centrelines (handle and curve) in the tool frame, equal axes.

    Args:
        ax: Axes to draw on.
        coeffs_list: (n_tools, n) designs ``(c1, ..., cn)``.
        labels: One legend label per tool, or ``None`` for no legend.
        colors: One colour per tool; default :func:`sequential_colors` (early to late).
        linewidth: Line width in points.
        spec: A ``tooldesign_env.ToolSpec``; the paper's tool if ``None``.
        key: Name the grasp-point marker (a "+" at the origin) in the legend; False for
            small multiples that share one key.

    Returns:
        ``ax``, with x and y in m in the tool frame (origin at the grasp point).
    """
    from tooldesign_env import make_tool

    designs = [np.asarray(c, dtype=np.float64) for c in coeffs_list]
    names = _labels(labels, len(designs), "tool")
    palette = _colors(colors, len(designs))
    for coeffs, label, color in zip(designs, names, palette, strict=True):
        line = np.asarray(make_tool(coeffs, spec).centerline)  # type: ignore[arg-type]
        ax.plot(line[:, 0], line[:, 1], color=color, linewidth=linewidth, label=label)
    ax.plot(
        [0.0],
        [0.0],
        marker="+",
        color="black",
        markersize=8,
        linestyle="none",
        zorder=5,
        label=GRASP_LABEL if key and GRASP_LABEL not in _legend_labels(ax) else None,
    )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x, tool frame (m)")
    ax.set_ylabel("y, tool frame (m)")
    ax.grid(True, alpha=0.3)
    if key or (labels is not None and designs):
        legend(ax)
    return ax


#: The legend entries of the markers every tool and box-path figure draws.
GRASP_LABEL = "grasp point (tool-frame origin)"
START_LABEL = "box start"
END_LABEL = "box end"
GOAL_LABEL = "goal X^g"


def _legend_labels(ax: Axes) -> set[str]:
    return {str(line.get_label()) for line in ax.get_lines()}


def legend(ax: Axes) -> Axes:
    """The axes' legend, its lines first and the markers' key (start, end, goal, grasp) last.

    Args:
        ax: Axes drawn by :func:`plot_tool_shapes` or :func:`plot_box_paths` (and others).

    Returns:
        ``ax``.
    """
    handles, labels = ax.get_legend_handles_labels()
    keys = (GRASP_LABEL, START_LABEL, END_LABEL, GOAL_LABEL)
    order = sorted(range(len(labels)), key=lambda i: any(labels[i].startswith(k) for k in keys))
    ax.legend(
        [handles[i] for i in order], [labels[i] for i in order], frameon=False, fontsize="small"
    )
    return ax


def plot_box_paths(
    ax: Axes,
    trajectories: Sequence[np.ndarray],
    goal: Sequence[float],
    labels: Sequence[str] | None = None,
    *,
    colors: Sequence[object] | None = None,
    linewidth: float = 1.5,
    key: bool = True,
) -> Axes:
    """Draw box paths seen from above, with start, end and goal markers.

    Args:
        ax: Axes to draw on.
        trajectories: One (T, 3) (or (T, 2)) box trajectory in m, world frame, per path; an
            empty one (a design that was not simulated) is skipped, its label too.
        goal: Goal X^g, (x, y[, z]) in m; drawn as a red star.
        labels: One legend label per path, or ``None`` for no legend.
        colors: One colour per path; default :func:`sequential_colors`.
        linewidth: Line width in points.
        key: Name the start, end and goal markers in the legend; False for small multiples
            that share one key.

    Returns:
        ``ax``, x and y in m, equal axes; starts are black circles, ends black crosses, the
        goal a red star drawn above the paths.
    """
    paths = [np.asarray(t, dtype=np.float64) for t in trajectories]
    for index, path in enumerate(paths):
        if path.ndim != 2 or path.shape[1] not in (2, 3):
            raise ValueError(f"trajectories[{index}] must be (T, 3) positions, got {path.shape}")
    names = _labels(labels, len(paths), "path")
    palette = _colors(colors, len(paths))
    goal_xy = np.asarray(goal, dtype=np.float64)[:2]
    named = _legend_labels(ax) if key else {START_LABEL, END_LABEL, GOAL_LABEL}
    for path, label, color in zip(paths, names, palette, strict=True):
        if len(path) == 0:
            continue
        ax.plot(path[:, 0], path[:, 1], color=color, linewidth=linewidth, label=label, zorder=2)
        for point, marker, size, name in (
            (path[0], "o", 5, START_LABEL),
            (path[-1], "x", 7, END_LABEL),
        ):
            ax.plot(
                point[0],
                point[1],
                marker=marker,
                color="black",
                markersize=size,
                linestyle="none",
                zorder=4,
                label=None if name in named else name,
            )
            named.add(name)
    goal_name = f"{GOAL_LABEL} = ({goal_xy[0]:g}, {goal_xy[1]:g}) m"
    ax.plot(
        goal_xy[0],
        goal_xy[1],
        marker="*",
        color="red",
        markeredgecolor="black",
        markeredgewidth=0.6,
        markersize=15,
        linestyle="none",
        zorder=6,  # above every path, the thick one of the best tool too
        label=None if GOAL_LABEL in named or any(GOAL_LABEL in n for n in named) else goal_name,
    )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x, world frame (m)")
    ax.set_ylabel("y, world frame (m)")
    ax.grid(True, alpha=0.3)
    if key or (labels is not None and any(len(p) for p in paths)):
        legend(ax)
    return ax


def plot_time_series(
    ax: Axes,
    times: Sequence[float] | np.ndarray,
    series: Mapping[str, Sequence[float] | np.ndarray],
    *,
    ylabel: str = "",
    xlabel: str = "time (s)",
    colors: Mapping[str, object] | None = None,
) -> Axes:
    """Draw named per-step series against time.

    The paper's Figure 4 is one: goal error, negative confidence and free energy per step.

    Args:
        ax: Axes to draw on.
        times: (T,) times in s.
        series: Name to (T,) values; the names become legend labels, in the given order.
        ylabel: y-axis label.
        xlabel: x-axis label.
        colors: Name to colour; matplotlib's cycle for names not given.

    Returns:
        ``ax``.

    Raises:
        ValueError: If a series does not have one value per time.
    """
    t = np.asarray(times, dtype=np.float64)
    for name, values in series.items():
        y = np.asarray(values, dtype=np.float64)
        if y.shape != t.shape:
            raise ValueError(f"series {name!r} has shape {y.shape}, times have {t.shape}")
        color = None if colors is None else colors.get(name)
        ax.plot(t, y, label=name, color=color, linewidth=1.5)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    if series:
        ax.legend(frameon=False, fontsize="small")
    return ax


def save_png(figure: Figure, path: str | os.PathLike[str]) -> Path:
    """Write a figure as PNG, atomically and reproducibly (see ``figure_png_bytes``).

    Args:
        figure: From :func:`new_figure` (or any figure with an Agg canvas).
        path: Target ``.png`` file; parent folders are created.

    Returns:
        The path written.
    """
    return atomic_write_bytes(path, figure_png_bytes(figure))
