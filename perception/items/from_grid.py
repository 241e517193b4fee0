"""Items from the stripe HMMs' class grid (thesis 3.3-3.4, 4.1.2): k-means or connected components.

The grid has a row per observation period and a column per stripe. As in the thesis it is
expanded to 27 columns: each stripe becomes 5 columns and a bin column (-1) is added on either
side. Per class (2 paper, 3 plastic, 4 aluminium), in batches of 20 rows, k-means groups the
class's cells into k = round(cells of the class in the batch / expected cells per item of the
class) clusters (the thesis's rule, e.g. 127 paper cells / 25 per paper = 5 items); the expected
cells per item come from labelled data (`cells_per_item`). The alternative labels the connected
regions of each class (scipy.ndimage.label, 8-connectivity) over the whole grid.

Positions are in belt coordinates: `b` [m] is the belt travel until the point crosses the camera
line (row r is seen at time r T, so b = r v T), `y` [m] lateral (stripe 0 on -y). At time t the
point is at world x = x_camera + v t - b. k-means runs on (b, y) in metres, not on cell indices,
so a row and a column weigh what they measure. An item's confidence is the mean posterior of its
class over its cells (1 without posteriors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import ndimage
from sklearn.cluster import KMeans

from perception.codes import N_STATES, VOID
from perception.errors import PerceptionInputError

SUB_COLUMNS = 5
BIN = -1
ITEM_CLASSES = (2, 3, 4)
"""The thesis's material classes (a catalogue may have others: 2..N)."""


@dataclass(frozen=True)
class GridGeometry:
    """Where the grid's cells are on the belt.

    Attributes:
        row_pitch_m: Belt travel per row, v T [m].
        belt_half_width_m: Half the belt's width [m]; the stripes split it evenly.
        stripes: Number of stripes.
    """

    row_pitch_m: float
    belt_half_width_m: float = 0.4
    stripes: int = 5

    def __post_init__(self):
        if not (np.isfinite(self.row_pitch_m) and 0 < self.row_pitch_m < 2):
            raise PerceptionInputError("row_pitch_m", "(0, 2) m", self.row_pitch_m)

    @property
    def column_width_m(self) -> float:
        """Width of an expanded column [m]."""
        return 2 * self.belt_half_width_m / (self.stripes * SUB_COLUMNS)

    def column_y(self, column: np.ndarray) -> np.ndarray:
        """Lateral position [m] of expanded columns 1..25 (their centres)."""
        return -self.belt_half_width_m + (np.asarray(column) - 0.5) * self.column_width_m


@dataclass(frozen=True, eq=False)
class GridItems:
    """Items found in a grid.

    Attributes:
        b: (K,) belt coordinate of each centroid [m].
        y: (K,) lateral position [m].
        class_id: (K,) 2 paper, 3 plastic, 4 aluminium.
        confidence: (K,) mean class posterior over the item's cells (0..1).
        cells: K arrays (n, 2) of the (row, stripe) cells of each item.
    """

    b: np.ndarray
    y: np.ndarray
    class_id: np.ndarray
    confidence: np.ndarray
    cells: list = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.b)


def expand_grid(classes) -> np.ndarray:
    """(rows, 27) grid: each stripe repeated over 5 columns, bin columns 0 and 26 set to -1."""
    grid = _classes(classes, None)
    inner = np.repeat(grid, SUB_COLUMNS, axis=1)
    bins = np.full((grid.shape[0], 1), BIN)
    return np.hstack([bins, inner, bins])


def _classes(classes, n_states: int | None = N_STATES) -> np.ndarray:
    """The grid, checked: integers 1..n_states (any class >= 1 when n_states is None)."""
    grid = np.asarray(classes)
    if grid.ndim != 2 or not np.issubdtype(grid.dtype, np.integer):
        raise PerceptionInputError("classes", "an integer grid (rows, stripes)", grid.shape)
    top = np.iinfo(np.int64).max if n_states is None else n_states
    if grid.size and (grid.min() < 1 or grid.max() > top):
        raise PerceptionInputError("classes", f"classes 1..{top}", (grid.min(), grid.max()))
    return grid


def _confidence(posteriors, cells: np.ndarray, cls: int) -> float:
    if posteriors is None:
        return 1.0
    return float(np.mean(posteriors[cells[:, 0], cells[:, 1], cls - 1]))


def _item(geo, rows, cols, posteriors, cls, items, first_row=0):
    """Append the item of expanded cells (rows, cols) to `items` (a dict of lists)."""
    items["b"].append((first_row + float(np.mean(rows))) * geo.row_pitch_m)
    items["y"].append(float(np.mean(geo.column_y(cols))))
    cells = np.unique(np.stack([rows, (cols - 1) // SUB_COLUMNS], axis=1), axis=0)
    items["class_id"].append(cls)
    items["confidence"].append(_confidence(posteriors, cells, cls))
    items["cells"].append(cells)


def _finish(items: dict) -> GridItems:
    return GridItems(
        np.array(items["b"], dtype=float),
        np.array(items["y"], dtype=float),
        np.array(items["class_id"], dtype=int),
        np.array(items["confidence"], dtype=float),
        items["cells"],
    )


def items_kmeans(
    classes,
    geometry: GridGeometry,
    cells_per_item,
    posteriors=None,
    batch_rows: int = 20,
    seed: int = 0,
    first_row: int = 0,
) -> GridItems:
    """Items by k-means per class and batch of rows (thesis 3.4, 4.1.2).

    Args:
        classes: (rows, S) decoded classes 1..N (1 void, 2.. the materials).
        cells_per_item: (N,) expected expanded cells per item of classes 1..N (index class-1);
            N = 4 for the thesis's three materials.
        posteriors: Optional (rows, S, N) class posteriors for the confidences.
        batch_rows: Rows per batch (20 in the thesis).
        seed: Seed of k-means's initialisation.
        first_row: Index of the grid's first row since the episode began (sets `b`).

    Returns:
        The items; `cells` hold (row, stripe) indices into `classes`.
    """
    size = np.asarray(cells_per_item, dtype=float)
    if size.ndim != 1 or len(size) < 2 or np.any(size[1:] <= 0):
        allowed = "N >= 2 expected cell counts, > 0 for the materials 2..N"
        raise PerceptionInputError("cells_per_item", allowed, size)
    _classes(classes, len(size))
    expanded = expand_grid(classes)
    if int(batch_rows) != batch_rows or batch_rows < 1:
        raise PerceptionInputError("batch_rows", "an integer >= 1", batch_rows)
    items: dict[str, list[Any]] = {"b": [], "y": [], "class_id": [], "confidence": [], "cells": []}
    for start in range(0, expanded.shape[0], int(batch_rows)):
        batch = expanded[start : start + int(batch_rows)]
        for cls in range(2, len(size) + 1):
            rows, cols = np.nonzero(batch == cls)
            if rows.size == 0:
                continue
            rows = rows + start
            points = np.stack([rows * geometry.row_pitch_m, geometry.column_y(cols)], axis=1)
            distinct = len(np.unique(points, axis=0))
            # MATLAB's round (halves away from zero); at least one item where the class is.
            k = int(min(max(1, math.floor(rows.size / size[cls - 1] + 0.5)), distinct))
            km = KMeans(n_clusters=k, n_init=4, random_state=seed).fit(points)
            for label in range(k):
                sel = km.labels_ == label
                _item(geometry, rows[sel], cols[sel], posteriors, cls, items, first_row)
    return _finish(items)


def items_components(
    classes, geometry: GridGeometry, posteriors=None, first_row: int = 0
) -> GridItems:
    """Items as 8-connected regions of one class in the (rows, S) grid (args as items_kmeans)."""
    grid = _classes(classes, None)
    items: dict[str, list[Any]] = {"b": [], "y": [], "class_id": [], "confidence": [], "cells": []}
    for cls in range(2, int(grid.max(initial=VOID)) + 1):
        labels, count = ndimage.label(grid == cls, structure=np.ones((3, 3)))
        for label in range(1, count + 1):
            rows, stripes = np.nonzero(labels == label)
            cols = 1 + stripes * SUB_COLUMNS + SUB_COLUMNS // 2
            _item(geometry, rows, cols, posteriors, cls, items, first_row)
    return _finish(items)


def cells_per_item(classes_grids, item_counts) -> np.ndarray:
    """(N,) expected expanded cells per item of each class, from labelled grids.

    Args:
        classes_grids: (rows, S) true class grids.
        item_counts: (N,) number of items of each class (index class-1) in those grids.
    """
    n_states = len(item_counts)
    cells = np.zeros(n_states)
    for grid in classes_grids:
        counted = np.bincount(_classes(grid, n_states).ravel() - 1, minlength=n_states)
        cells += counted * SUB_COLUMNS
    counts = np.asarray(item_counts, dtype=float)
    out = np.where(counts > 0, cells / np.maximum(counts, 1), np.inf)
    out[VOID - 1] = np.inf
    return out
