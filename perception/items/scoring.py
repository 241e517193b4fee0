"""Scores items found in a grid against the true items: centroid error, splits and merges.

Each found item is owned by the nearest true item of its class within `gate_m`; a true item
owning several found items is split (each extra one counts), a true item owning none is missed,
and a found item without an owner is spurious. A found item is a merge when its cells hold the
centre cells of several true items of its class (each extra one counts). The centroid error of
a true item is the distance to its nearest owned item, in mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from perception.items.from_grid import GridItems

COUNTS = ("n_true", "n_found", "matched", "splits", "merges", "missed", "spurious")


@dataclass(frozen=True, eq=False)
class ItemScore:
    """Centroid errors [mm] of the matched true items and the counting mistakes of one method."""

    errors_mm: np.ndarray
    n_true: int
    n_found: int
    matched: int
    splits: int
    merges: int
    missed: int
    spurious: int

    @property
    def median_mm(self) -> float:
        """Median centroid error [mm] (NaN when nothing matched)."""
        return float(np.median(self.errors_mm)) if self.errors_mm.size else float("nan")

    @property
    def p95_mm(self) -> float:
        """95th percentile of the centroid error [mm]."""
        return float(np.percentile(self.errors_mm, 95)) if self.errors_mm.size else float("nan")


def score_items(
    found: GridItems,
    true_b: np.ndarray,
    true_y: np.ndarray,
    true_class: np.ndarray,
    true_cells: np.ndarray,
    gate_m: float = 0.25,
) -> ItemScore:
    """Score `found` against true centres (b, y) [m], classes and centre cells (row, stripe)."""
    true_b, true_y = np.asarray(true_b, float), np.asarray(true_y, float)
    true_class, true_cells = np.asarray(true_class), np.asarray(true_cells).reshape(-1, 2)
    owned = [[] for _ in range(len(true_b))]
    spurious = 0
    for k in range(len(found)):
        same = np.flatnonzero(true_class == found.class_id[k])
        if same.size == 0:
            spurious += 1
            continue
        dist = np.hypot(true_b[same] - found.b[k], true_y[same] - found.y[k])
        best = int(np.argmin(dist))
        if dist[best] > gate_m:
            spurious += 1
            continue
        owned[same[best]].append(float(dist[best]))
    errors = np.array([min(d) for d in owned if d], dtype=float) * 1000.0
    merges = 0
    for k in range(len(found)):
        cells = {tuple(c) for c in np.asarray(found.cells[k]).tolist()}
        same = np.flatnonzero(true_class == found.class_id[k])
        inside = sum(tuple(true_cells[i].tolist()) in cells for i in same)
        merges += max(0, inside - 1)
    return ItemScore(
        errors_mm=errors,
        n_true=len(true_b),
        n_found=len(found),
        matched=int(errors.size),
        splits=int(sum(max(0, len(d) - 1) for d in owned)),
        merges=int(merges),
        missed=int(sum(1 for d in owned if not d)),
        spurious=int(spurious),
    )


def pooled(scores: list[ItemScore]) -> ItemScore:
    """One score of several grids: errors pooled, counts summed."""
    errors = np.concatenate([s.errors_mm for s in scores]) if scores else np.zeros(0)
    return ItemScore(errors, *(int(sum(getattr(s, k) for s in scores)) for k in COUNTS))
