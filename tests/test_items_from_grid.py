"""Items from the class grid: expansion, k-means rule, connected components, scoring."""

from __future__ import annotations

import numpy as np
import pytest

from perception.errors import PerceptionInputError
from perception.items.from_grid import (
    GridGeometry,
    cells_per_item,
    expand_grid,
    items_components,
    items_kmeans,
)
from perception.items.scoring import pooled, score_items

GEO = GridGeometry(row_pitch_m=0.0925)


def rasterise(rows, items):
    """(rows, 5) class grid of axis-aligned items (b, y, half_b, half_y, class)."""
    grid = np.ones((rows, 5), dtype=int)
    r = np.arange(rows)[:, None] * GEO.row_pitch_m
    lo = -0.4 + 0.16 * np.arange(5)
    for b, y, hb, hy, cls in items:
        inside = (np.abs(r - b) <= hb) & (lo + 0.16 > y - hy) & (lo < y + hy)
        grid[inside] = cls
    return grid


def truth_of(items):
    arr = np.array(items, dtype=float)
    cells = np.stack(
        [np.rint(arr[:, 0] / GEO.row_pitch_m), np.floor((arr[:, 1] + 0.4) / 0.16)], axis=1
    )
    return arr[:, 0], arr[:, 1], arr[:, 4].astype(int), cells.astype(int)


def test_expansion_has_bins_and_five_columns_per_stripe():
    grid = np.array([[1, 2, 3, 4, 1]])
    out = expand_grid(grid)
    assert out.shape == (1, 27) and out[0, 0] == out[0, 26] == -1
    assert out[0, 1:26].tolist() == [1] * 5 + [2] * 5 + [3] * 5 + [4] * 5 + [1] * 5


def test_kmeans_k_follows_the_thesis_rule():
    # 127 paper cells at 25 per paper -> 5 items (thesis 4.1.2).
    grid = np.ones((20, 5), dtype=int)
    grid.flat[:26] = 2  # 26 stripe cells = 130 expanded cells -> round(130 / 25) = 5
    items = items_kmeans(grid, GEO, cells_per_item=[np.inf, 25, 20, 10])
    assert len(items) == 5 and set(items.class_id) == {2}


def test_isolated_items_are_found_by_both_methods():
    rng = np.random.default_rng(0)
    items = []
    for k in range(12):
        stripe = int(rng.integers(0, 5))
        items.append((0.3 + 0.6 * k, -0.32 + 0.16 * stripe, 0.1, 0.05, int(rng.integers(2, 5))))
    grid = rasterise(140, items)
    size = cells_per_item([grid], np.bincount([i[4] for i in items], minlength=5)[1:])
    truth = truth_of(items)
    for found in (items_kmeans(grid, GEO, size, batch_rows=200), items_components(grid, GEO)):
        score = score_items(found, *truth)
        assert score.matched == 12 and score.splits == 0 and score.merges == 0
        assert score.median_mm < 30 and score.spurious == 0


def test_touching_items_merge_in_components_but_kmeans_counts_them():
    items = [(1.0, 0.0, 0.14, 0.05, 3), (1.3, 0.0, 0.14, 0.05, 3)]
    grid = rasterise(40, items)
    size = [np.inf, 30, grid[grid == 3].size * 5 / 2, 10]
    truth = truth_of(items)
    comp = score_items(items_components(grid, GEO), *truth)
    km = score_items(items_kmeans(grid, GEO, size, batch_rows=40), *truth)
    assert comp.merges == 1 and comp.matched == 1
    assert km.merges == 0 and km.matched == 2
    assert pooled([comp, km]).n_true == 4


def test_first_row_shifts_the_belt_coordinate():
    grid = rasterise(10, [(0.4, 0.0, 0.1, 0.05, 2)])
    base = items_components(grid, GEO)
    later = items_components(grid, GEO, first_row=100)
    assert np.isclose(later.b[0] - base.b[0], 100 * GEO.row_pitch_m)
    km = items_kmeans(grid, GEO, [np.inf, 1e3, 1e3, 1e3], first_row=100)
    assert np.isclose(km.b[0], later.b[0])


def test_confidence_is_the_mean_posterior_of_the_class():
    grid = rasterise(10, [(0.4, 0.0, 0.1, 0.05, 4)])
    post = np.zeros((10, 5, 4))
    post[..., 0] = 1.0
    post[grid == 4] = [0.1, 0.0, 0.2, 0.7]
    found = items_components(grid, GEO, posteriors=post)
    assert len(found) == 1 and np.isclose(found.confidence[0], 0.7)


def test_refusals():
    with pytest.raises(PerceptionInputError, match="classes"):
        expand_grid(np.array([[0, 1, 1, 1, 1]]))
    with pytest.raises(PerceptionInputError, match="cells_per_item"):
        items_kmeans(np.ones((3, 5), dtype=int), GEO, [1, 0, 1, 1])
    with pytest.raises(PerceptionInputError, match="row_pitch_m"):
        GridGeometry(row_pitch_m=0.0)
