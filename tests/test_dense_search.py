"""The dense grid search: grid shape, bounds, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.suites.dense_search import grid
from tooldesign_env import default_bounds


def test_grid_spans_the_bounds_and_contains_the_straight_tool():
    g = grid(5)
    assert g.shape == (125, 3)
    bounds = default_bounds(3)
    np.testing.assert_array_equal(g.min(axis=0), bounds[:, 0])
    np.testing.assert_array_equal(g.max(axis=0), bounds[:, 1])
    assert any(np.all(row == 0.0) for row in g)
    assert len({tuple(r) for r in g}) == 125


@pytest.mark.parametrize("points", [1, 0, -3, 2.5, "11"])
def test_grid_rejects_bad_point_counts(points):
    with pytest.raises(ValueError, match="points"):
        grid(points)
