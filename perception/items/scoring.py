"""Scores found items against the true items: centroid error, splits and merges.

Items of a decoded class grid (`score_items`): each found item is owned by the nearest true
item of its class within `gate_m`; a true item owning several found items is split (each extra
one counts), a true item owning none is missed, and a found item without an owner is spurious.
A found item is a merge when its cells hold the centre cells of several true items of its class
(each extra one counts). The centroid error of a true item is the distance to its nearest owned
item, in mm.

Segments of item pixels (`score_segments`, the camera's blobs): found and true items are matched
by the pixels they share, each true item is detected, split, merged or missed.
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
    owned: list[list[float]] = [[] for _ in range(len(true_b))]
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


SEGMENT_KINDS = ("detected", "split", "merged", "missed")
"""What became of a true item: found once on its own, cut into several, found together with a
neighbour, not found."""


@dataclass(frozen=True, eq=False)
class SegmentScore:
    """What became of each true item in a segmentation, and the centroid errors.

    Attributes:
        kinds: (n_true,) index into SEGMENT_KINDS of each true item.
        errors_mm: Centroid errors [mm] of the detected true items.
        n_found: Found items.
        spurious: Found items mostly made of pixels of no true item.
    """

    kinds: np.ndarray
    errors_mm: np.ndarray
    n_found: int
    spurious: int

    @property
    def n_true(self) -> int:
        return int(self.kinds.size)

    def count(self, kind: str) -> int:
        """True items of `kind` (one of SEGMENT_KINDS)."""
        return int(np.sum(self.kinds == SEGMENT_KINDS.index(kind)))

    def share(self, kind: str) -> float:
        """Share of the true items of `kind` (NaN without true items)."""
        return self.count(kind) / self.n_true if self.n_true else float("nan")

    @property
    def median_mm(self) -> float:
        """Median centroid error of the detected items [mm] (NaN when none)."""
        return float(np.median(self.errors_mm)) if self.errors_mm.size else float("nan")


def score_segments(
    overlap: np.ndarray,
    found_pixels: np.ndarray,
    distance_m: np.ndarray,
    merge_share: float = 0.3,
) -> SegmentScore:
    """Scores found items against true items by the pixels they share.

    A true item's main found item is the one holding most of its pixels. The true item is
    merged when its main found item also holds at least `merge_share` of another true item's
    pixels; else split when two or more found items are each mostly its pixels; else detected,
    with the distance from its main found item's centroid as the centroid error; missed when no
    found item holds a pixel of it.

    Args:
        overlap: (n_found, n_true) pixels of each found item inside each true item's footprint.
        found_pixels: (n_found,) pixels of each found item.
        distance_m: (n_found, n_true) distance [m] from each found item's centroid to each
            true item's centre.
        merge_share: Share of a second true item's pixels that makes a found item a merge.
    """
    overlap = np.asarray(overlap, dtype=float)
    found_pixels = np.asarray(found_pixels, dtype=float)
    n_found, n_true = overlap.shape
    seen = overlap.sum(axis=0)
    mostly = overlap >= 0.5 * found_pixels[:, None]
    kinds = np.full(n_true, SEGMENT_KINDS.index("missed"))
    errors = []
    for i in np.flatnonzero(seen > 0):
        main = int(np.argmax(overlap[:, i]))
        shares = overlap[main] / np.maximum(seen, 1.0)
        shares[i] = 0.0
        if np.any(shares >= merge_share):
            kinds[i] = SEGMENT_KINDS.index("merged")
        elif int(mostly[:, i].sum()) >= 2:
            kinds[i] = SEGMENT_KINDS.index("split")
        else:
            kinds[i] = SEGMENT_KINDS.index("detected")
            errors.append(1000.0 * float(distance_m[main, i]))
    spurious = int(np.sum(~mostly.any(axis=1)))
    return SegmentScore(kinds, np.array(errors, dtype=float), n_found, spurious)


def pooled_segments(scores: list[SegmentScore]) -> SegmentScore:
    """One score of several flows: kinds and errors pooled, counts summed."""
    if not scores:
        return SegmentScore(np.zeros(0, dtype=np.int64), np.zeros(0), 0, 0)
    return SegmentScore(
        np.concatenate([s.kinds for s in scores]),
        np.concatenate([s.errors_mm for s in scores]),
        sum(s.n_found for s in scores),
        sum(s.spurious for s in scores),
    )
