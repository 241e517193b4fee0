"""Items as the camera saw them: blobs of item pixels, classed by the stripe HMMs' posteriors.

The stripe HMMs (`perception.hmm.online`) say what material each grid cell holds; the camera's
footprints say where the items are, far finer than a 0.16 m cell. On-line, the cell splits the
two jobs: item pixels (belt coordinates) of a sliding window of rows are rasterised and cut
into 8-connected regions; items lie as little as 5 mm apart, so a region may hold several
touching items, and with `split` settings each region is cut into items by the footprint's
shape and the pixels' heights (`perception.items.split`). On a busy belt touching items chain
into regions longer than the window, never complete: with the window's reported pixels kept,
a growing region is cut too and its items that ended two rows back are reported at once (their
pixels left out from then on). Each blob's class probabilities are
the HMM posteriors of the cells it covers, weighted by how many of its pixels each cell holds.
Segmenting by decoded class instead splits an item whose cells decode to different materials
into two phantom items of two classes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from perception.codes import VOID
from perception.items.split import SplitSettings, split_region


@dataclass(frozen=True)
class Blob:
    """One item seen by the camera.

    Attributes:
        b: Belt coordinate of the centroid: belt travel until it crosses the camera line [m].
        y: Lateral centroid [m].
        probs: (4,) class probabilities over void, paper, plastic, aluminium (void is 0: the
            camera saw the item).
        last_row: Newest window row holding a pixel of the blob.
        pixels: Number of item pixels.
        members: Indices of its pixels in the window's order (row by row, stripe by stripe,
            each cell's pixels in their given order).
    """

    b: float
    y: float
    probs: np.ndarray
    last_row: int
    pixels: int
    members: np.ndarray | None = None


def item_blobs(
    pixel_b: list[list[np.ndarray]],
    pixel_y: list[list[np.ndarray]],
    posteriors: np.ndarray | Callable[[], np.ndarray],
    raster_m: float = 0.006,
    min_pixels: int = 40,
    pixel_height: list[list[np.ndarray]] | None = None,
    split: SplitSettings | None = None,
    complete_row: int | None = None,
    reported: list[list[np.ndarray]] | None = None,
) -> list[Blob]:
    """Blobs of the item pixels of a window of rows.

    Args:
        pixel_b: [row][stripe] arrays of the item pixels' belt coordinates [m].
        pixel_y: [row][stripe] arrays of their lateral positions [m].
        posteriors: (rows, stripes, 4) class posteriors of the window's cells, or a function
            that gives them, called once when the first blob is found (none: never).
        raster_m: Raster pitch the pixels are binned on before labelling [m].
        min_pixels: Blobs with fewer pixels are noise and dropped.
        pixel_height: Optional [row][stripe] arrays of the pixels' heights above the belt [m]
            (from a depth map); with `split`, steps in height separate touching items.
        split: How a region of touching items is cut apart (`split_region`); None keeps each
            8-connected region whole.
        complete_row: When given, only the regions whose newest row is this one are returned,
            all their pieces at once, and only they are split (in a sliding window whose rows
            move up one per observation: the regions the newest row did not add to, each
            complete once).
        reported: With `complete_row` and `split`: [row][stripe] boolean arrays, one flag per
            pixel, of the pixels already reported (left out here); the pixels of the pieces
            returned now are flagged in place. A region still growing (holding pixels of a
            row after `complete_row`) is then split as well, and its pieces that end before
            `complete_row` are returned at once: on a busy belt touching items chain into a
            region longer than the window, which would never be complete.

    Returns:
        The blobs, in no particular order.
    """
    pixels = _WindowPixels.of(pixel_b, pixel_y)
    if pixels is None:
        return []
    b, y, row = pixels.b, pixels.y, pixels.row
    early = reported is not None and split is not None and complete_row is not None
    done = pixels.gathered(reported, bool) if early and reported is not None else None
    label_of_pixel, count = _regions(b, y, raster_m, done)
    wanted, growing = _regions_due(label_of_pixel, count, row, complete_row, early, min_pixels)
    height = None
    if split is not None and pixel_height is not None:
        height = pixels.gathered(pixel_height, float)
    pieces = []
    for label in wanted:
        pieces += _pieces(np.flatnonzero(label_of_pixel == label), b, y, height, split)
    for label in growing:
        cut = _pieces(np.flatnonzero(label_of_pixel == label), b, y, height, split)
        pieces += [mine for mine in cut if row[mine].max() < complete_row]
    if early:
        assert done is not None and reported is not None  # `early` says both are given
        for mine in pieces:
            done[mine] = True
        _flag(reported, pixels.parts, done)
    big = [mine for mine in pieces if len(mine) >= min_pixels]
    if not big:
        return []
    table = posteriors() if callable(posteriors) else posteriors
    return [_blob(mine, b, y, row, pixels.stripe, table) for mine in big]


@dataclass(frozen=True, eq=False)
class _WindowPixels:
    """The window's item pixels in one order (row by row, stripe by stripe, each cell's pixels
    in their given order): belt coordinate `b` and lateral `y` [m], grid row and stripe.
    `parts` lists the non-empty cells (row, stripe, their b, their y) in that order."""

    parts: list
    b: np.ndarray
    y: np.ndarray
    row: np.ndarray
    stripe: np.ndarray

    @classmethod
    def of(
        cls, pixel_b: list[list[np.ndarray]], pixel_y: list[list[np.ndarray]]
    ) -> _WindowPixels | None:
        """The pixels of [row][stripe] arrays; None when there are none."""
        parts = [
            (r, j, np.asarray(b, float), np.asarray(y, float))
            for r, row in enumerate(pixel_b)
            for j, b in enumerate(row)
            if len(b)
            for y in [pixel_y[r][j]]
        ]
        if not parts:
            return None
        sizes = [len(p[2]) for p in parts]
        return cls(
            parts,
            np.concatenate([p[2] for p in parts]),
            np.concatenate([p[3] for p in parts]),
            np.repeat(np.array([p[0] for p in parts], dtype=np.int64), sizes),
            np.repeat(np.array([p[1] for p in parts], dtype=np.int64), sizes),
        )

    def gathered(self, per_cell: list[list[np.ndarray]], dtype) -> np.ndarray:
        """[row][stripe] arrays of one value per pixel, in the window's order."""
        return np.concatenate([np.asarray(per_cell[p[0]][p[1]], dtype) for p in self.parts])


def _regions_due(
    label_of_pixel: np.ndarray,
    count: int,
    row: np.ndarray,
    complete_row: int | None,
    early: bool,
    min_pixels: int,
) -> tuple[np.ndarray, np.ndarray]:
    """(labels of the regions returned whole, labels of the growing regions whose finished
    pieces are returned early), each of at least `min_pixels` pixels (see `item_blobs`)."""
    newest = np.zeros(count + 1, dtype=np.int64)
    np.maximum.at(newest, label_of_pixel, row)
    wanted = np.arange(1, count + 1)
    growing = np.zeros(0, dtype=np.int64)
    if complete_row is not None:
        if early:
            oldest = np.full(count + 1, row.max() + 1, dtype=np.int64)
            np.minimum.at(oldest, label_of_pixel, row)
            growing = wanted[(newest[1:] > complete_row) & (oldest[1:] < complete_row)]
            # A leftover of a region whose pieces were reported may end before complete_row.
            wanted = wanted[newest[1:] <= complete_row]
        else:
            wanted = wanted[newest[1:] == complete_row]
    sizes = np.bincount(label_of_pixel, minlength=count + 1)
    return wanted[sizes[wanted] >= min_pixels], growing[sizes[growing] >= min_pixels]


def _regions(
    b: np.ndarray, y: np.ndarray, raster_m: float, done: np.ndarray | None
) -> tuple[np.ndarray, int]:
    """(label 1..count of each pixel, 0 for the pixels `done`; count): 8-connected regions."""
    # The raster is fixed on the belt (not on the window's pixels), so a region keeps its
    # cells and its connections from one observation to the next: once complete, a region
    # never grows again (a new row lies a row's length past its pixels).
    ib = np.floor(b / raster_m).astype(np.int64)
    iy = np.floor(y / raster_m).astype(np.int64)
    ib -= ib.min()
    iy -= iy.min()
    occupied = np.zeros((ib.max() + 1, iy.max() + 1), dtype=bool)
    live = slice(None) if done is None else ~done
    occupied[ib[live], iy[live]] = True
    labels, count = ndimage.label(occupied, structure=np.ones((3, 3)))
    label_of_pixel = labels[ib, iy]
    if done is not None:
        label_of_pixel[done] = 0
    return label_of_pixel, count


def _pieces(
    region: np.ndarray,
    b: np.ndarray,
    y: np.ndarray,
    height: np.ndarray | None,
    split: SplitSettings | None,
) -> list[np.ndarray]:
    """The pixels (indices) of each item of one region, cut apart with `split`."""
    if split is None:
        return [region]
    piece, n = split_region(b[region], y[region], None if height is None else height[region], split)
    order = np.argsort(piece, kind="stable")
    return np.split(region[order], np.cumsum(np.bincount(piece, minlength=n))[:-1])


def _flag(reported: list[list[np.ndarray]], parts: list, done: np.ndarray) -> None:
    """Writes the window-ordered flags `done` back into `reported`'s [row][stripe] arrays."""
    start = 0
    for r, j, cell_b, _ in parts:
        stop = start + len(cell_b)
        reported[r][j][:] = done[start:stop]
        start = stop


def _blob(
    mine: np.ndarray,
    b: np.ndarray,
    y: np.ndarray,
    row: np.ndarray,
    stripe: np.ndarray,
    posteriors: np.ndarray,
) -> Blob:
    """The blob of the pixels `mine`, classed by the posteriors of the cells they fall in."""
    rows, stripes = posteriors.shape[:2]
    weights = np.bincount(row[mine] * stripes + stripe[mine], minlength=rows * stripes)
    cells = np.flatnonzero(weights)
    probs = (posteriors.reshape(rows * stripes, -1)[cells] * weights[cells, None]).sum(axis=0)
    probs[VOID - 1] = 0.0
    total = probs.sum()
    probs = probs / total if total > 0 else np.array([0.0, 1 / 3, 1 / 3, 1 / 3])
    centroid_b, centroid_y = float(b[mine].mean()), float(y[mine].mean())
    return Blob(centroid_b, centroid_y, probs, int(row[mine].max()), len(mine), mine)
