"""Items as the camera saw them: blobs of item pixels, classed by the stripe HMMs' posteriors.

The stripe HMMs (`perception.hmm.online`) say what material each grid cell holds; the camera's
footprints say where the items are, far finer than a 0.16 m cell. On-line, the cell splits the
two jobs: item pixels (belt coordinates) of a sliding window of rows are rasterised and cut
into 8-connected blobs, one per item (items fall apart on the belt, so blobs rarely touch);
each blob's class probabilities are the HMM posteriors of the cells it covers, weighted by how
many of its pixels each cell holds. Segmenting by decoded class instead splits an item whose
cells decode to different materials into two phantom items of two classes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from perception.codes import VOID


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
    """

    b: float
    y: float
    probs: np.ndarray
    last_row: int
    pixels: int


def item_blobs(
    pixel_b: list[list[np.ndarray]],
    pixel_y: list[list[np.ndarray]],
    posteriors: np.ndarray,
    raster_m: float = 0.006,
    min_pixels: int = 40,
) -> list[Blob]:
    """Blobs of the item pixels of a window of rows.

    Args:
        pixel_b: [row][stripe] arrays of the item pixels' belt coordinates [m].
        pixel_y: [row][stripe] arrays of their lateral positions [m].
        posteriors: (rows, stripes, 4) class posteriors of the window's cells.
        raster_m: Raster pitch the pixels are binned on before labelling [m].
        min_pixels: Blobs with fewer pixels are noise and dropped.

    Returns:
        The blobs, in no particular order.
    """
    parts = [
        (r, j, np.asarray(b, float), np.asarray(y, float))
        for r, row in enumerate(pixel_b)
        for j, b in enumerate(row)
        if len(b)
        for y in [pixel_y[r][j]]
    ]
    if not parts:
        return []
    b = np.concatenate([p[2] for p in parts])
    y = np.concatenate([p[3] for p in parts])
    row = np.concatenate([np.full(len(p[2]), p[0]) for p in parts])
    stripe = np.concatenate([np.full(len(p[2]), p[1]) for p in parts])
    ib = np.floor((b - b.min()) / raster_m).astype(np.int64)
    iy = np.floor((y - y.min()) / raster_m).astype(np.int64)
    occupied = np.zeros((ib.max() + 1, iy.max() + 1), dtype=bool)
    occupied[ib, iy] = True
    labels, count = ndimage.label(occupied, structure=np.ones((3, 3)))
    label_of_pixel = labels[ib, iy]
    blobs = []
    for label in range(1, count + 1):
        mine = label_of_pixel == label
        n = int(mine.sum())
        if n < min_pixels:
            continue
        cells, weights = np.unique(
            np.stack([row[mine], stripe[mine]], axis=1), axis=0, return_counts=True
        )
        probs = (posteriors[cells[:, 0], cells[:, 1]] * weights[:, None]).sum(axis=0)
        probs[VOID - 1] = 0.0
        total = probs.sum()
        probs = probs / total if total > 0 else np.array([0.0, 1 / 3, 1 / 3, 1 / 3])
        blobs.append(
            Blob(float(b[mine].mean()), float(y[mine].mean()), probs, int(row[mine].max()), n)
        )
    return blobs
