"""Figure 3 panels: iterations on a colour bar, the best tool highlighted, no point clipped."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
from matplotlib.colors import to_rgba

from benchmarks.reports import plots
from benchmarks.reports.design_figures import _panel_curves, _panel_free_energy, _panel_paths
from tooldesign_env import ToolSpec

RED = to_rgba("red")


def _bests(n=20):
    f = np.linspace(100.0, 50.0, n)
    f[min(7, n - 1)] = 40.0  # the best is not the last iteration
    return pd.DataFrame({"iteration": np.arange(n), "free_energy": f, "status": "ok"})


def _red_lines(ax):
    # The goal star is red too, but a marker without a line.
    lines = ax.get_lines()
    return [x for x in lines if to_rgba(x.get_color()) == RED and x.get_linestyle() != "None"]


def test_tool_curves_use_a_colour_bar_and_highlight_the_best():
    bests = _bests()
    designs = [np.array([0.0, 0.01 * k, 0.0]) for k in range(len(bests))]
    fig, ax = plots.new_figure()
    _panel_curves(ax, designs, bests, None, ToolSpec())
    assert len(fig.axes) == 2 and fig.axes[1].get_ylabel() == "iteration"
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == ["best tool (iteration 7)"]
    assert _red_lines(ax)


def test_box_paths_highlight_the_best_path():
    bests = _bests(5)
    bests.loc[:, "free_energy"] = [5.0, 4.0, 1.0, 3.0, 2.0]
    paths = [np.c_[np.linspace(0, 1, 4), np.full(4, k), np.zeros(4)] for k in range(5)]
    fig, ax = plots.new_figure()
    _panel_paths(ax, paths, bests, None, (0.0, 1.5, 0.1))
    (red,) = _red_lines(ax)
    np.testing.assert_array_equal(red.get_ydata(), np.full(4, 2.0))
    assert len(fig.axes) == 2


def test_free_energy_axis_shows_every_evaluation_even_an_outlier():
    bests = _bests(4)
    evaluations = pd.DataFrame(
        {
            "iteration": [0, 0, 1, 1, 2, 2, 3, 3],
            "free_energy": [100.0, 20000.0, 90.0, 95.0, 80.0, 85.0, 70.0, 75.0],
            "status": "ok",
            "best_so_far": [100.0, 100.0, 90.0, 90.0, 80.0, 80.0, 70.0, 70.0],
        }
    )
    fig, ax = plots.new_figure()
    _panel_free_energy(ax, evaluations, bests)
    low, high = ax.get_ylim()
    assert low <= evaluations["free_energy"].min() and high >= 20000.0
    assert ax.get_yscale() == "symlog"
