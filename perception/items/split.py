"""Touching items cut apart: the footprint's distance transform, walled by steps in depth.

Items on the belt lie as little as 5 mm apart, and an item's footprint pixels, binned on a
raster, can touch a neighbour's. One connected region of item pixels is cut into items on a
fine raster (`SplitSettings.raster_m`, finer than the gap between items) in five steps:

1. Walls from depth: a raster cell with a neighbour more than `step_m` higher is the foot of a
   step in height, where a lower item meets a taller one (a can beside a tray, a bottle beside
   a sheet) or where a round item's flank falls to the belt. Walls are left out of the
   footprint's core, so items of different heights fall apart even where they touch.
2. Flooding the distance transform from the top (a watershed by immersion): the core's
   distance to the belt or a wall peaks once inside each compact part. Thresholded at rising
   levels, the core breaks up where it narrows: two parts that part at level L (their neck's
   half-width) are two items when L is under `neck_ratio` of each one's peak half-width (two
   discs that touch meet at a neck far thinner than either); a long sheet or a lying bottle
   has a flat ridge that only breaks, into bumps of its own height, near its top, and stays
   whole. Parts whose peak half-width is under `min_core_m` (slivers) are not items.
3. Each item is its part at the level it parted at; every other pixel of the region (walls,
   rims) goes to the nearest one.
4. Cuts at concave notches (with `concave_ratio`): every item's footprint is convex (a
   rectangle, a disc or a stadium), so a piece whose outline has two deep notches (convexity
   defects of at least `concave_depth_m`) joined by a chord inside it no longer than
   `concave_ratio` times their summed depths is two items touching along that chord, and is
   cut there (again in each part, up to `MAX_CUTS` cuts). This parts what the neck test
   cannot: a small item pressed against a larger one's side over most of its own width (a
   can against a carton), or two items of one height side by side, offset (on busy belts
   the commonest merges, measured in `sim.evaluation.segmentation_density`).
5. Rejoining (with `rejoin`): by the same token two touching pieces whose union is convex
   (no notch of `concave_depth_m`) and of one height (their median heights within `step_m`)
   are one item the distance transform cut across (a lying bottle whose end met a
   neighbour), and are joined again.

(`scipy.ndimage.watershed_ift` and `cv2.watershed` flood by the differences between
neighbouring values, a gradient image's, not by the distance transform's levels, so the levels
are flooded here by labelling each threshold.) The function is pure: pixels in, labels out, in
metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage

from perception.errors import PerceptionInputError

_KERNEL = np.ones((3, 3), np.uint8)
_EIGHT = np.ones((3, 3), dtype=bool)
LEVELS_CELLS = (1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 14, 17, 20, 24, 28, 33, 39, 46)
"""Thresholds of the distance transform [raster cells] at which the core is labelled."""
MAX_CUTS = 8
"""Most cuts at concave notches made in one piece of the distance transform's split."""


@dataclass(frozen=True)
class SplitSettings:
    """How a region of item pixels is cut into items.

    Attributes:
        raster_m: Pitch of the raster the pixels are binned on [m]; under the 5 mm gap the
            flow keeps between items and over the footprint's 2.5 mm pixel pitch, so an item
            covers its raster without holes.
        step_m: A cell with a neighbour higher by more than this is a wall [m].
        neck_ratio: Two parts are two items when the neck between them is narrower than this
            fraction of each one's peak half-width.
        min_core_m: A part whose peak half-width (walls left out) is under this is no item [m].
        height_median_cells: Side of the median filter over the cells' heights before walls
            are found (1: none; 3 or 5).
        concave_ratio: A piece is cut along a chord between two concave notches of its
            outline no longer than this times their summed depths (0: no such cuts).
        concave_depth_m: Shallowest notch of the outline a cut may start from [m].
        rejoin: Join two touching pieces again when their union is convex and of one height.
    """

    raster_m: float = 0.003
    step_m: float = 0.010
    neck_ratio: float = 0.6
    min_core_m: float = 0.012
    height_median_cells: int = 5
    concave_ratio: float = 0.0
    concave_depth_m: float = 0.012
    rejoin: bool = False

    def __post_init__(self) -> None:
        if not 0.0005 <= self.raster_m <= 0.02:
            raise PerceptionInputError("raster_m", "0.0005..0.02 m", self.raster_m)
        if not self.step_m > 0.0:
            raise PerceptionInputError("step_m", "> 0 m", self.step_m)
        if not 0.0 < self.neck_ratio <= 1.0:
            raise PerceptionInputError("neck_ratio", "(0, 1]", self.neck_ratio)
        if not self.min_core_m >= 0.0:
            raise PerceptionInputError("min_core_m", ">= 0 m", self.min_core_m)
        if self.height_median_cells not in (1, 3, 5):
            raise PerceptionInputError("height_median_cells", "1, 3 or 5", self.height_median_cells)
        if not self.concave_ratio >= 0.0:
            raise PerceptionInputError("concave_ratio", ">= 0", self.concave_ratio)
        if not self.concave_depth_m > 0.0:
            raise PerceptionInputError("concave_depth_m", "> 0 m", self.concave_depth_m)


def split_region(
    b: np.ndarray,
    y: np.ndarray,
    height: np.ndarray | None = None,
    settings: SplitSettings = SplitSettings(),
) -> tuple[np.ndarray, int]:
    """Cuts one region of item pixels into items.

    Args:
        b: (N,) belt coordinates of the pixels [m].
        y: (N,) lateral positions [m].
        height: (N,) heights above the belt [m] of the surface seen at each pixel, or None
            (no depth: the footprint's shape alone decides).

    Returns:
        (piece, count): the piece 0..count-1 of each pixel, and the number of pieces.
    """
    b, y = np.asarray(b, float), np.asarray(y, float)
    if b.size == 0:
        return np.zeros(0, dtype=np.int64), 0
    pitch = settings.raster_m
    # The raster is fixed on the belt, so the same pixels are cut the same way in any window;
    # one empty cell of margin all round, so that the distance transform sees the belt there.
    ib = np.floor(b / pitch).astype(np.int64)
    iy = np.floor(y / pitch).astype(np.int64)
    ib -= ib.min() - 1
    iy -= iy.min() - 1
    shape = (int(ib.max()) + 2, int(iy.max()) + 2)
    occupied = np.zeros(shape, dtype=bool)
    occupied[ib, iy] = True
    core = occupied
    if height is not None:
        # Each cell's height is its highest pixel's (1-D, one dtype: numpy's fast path).
        top: np.ndarray = np.zeros(shape[0] * shape[1], dtype=np.float32)
        np.maximum.at(top, ib * shape[1] + iy, np.asarray(height, np.float32))
        top = top.reshape(shape)
        if settings.height_median_cells > 1:
            # Stereo depth is noisy: a median over a few cells keeps real steps and drops
            # the noise's.
            top = cv2.medianBlur(top, settings.height_median_cells)
        core = occupied & (cv2.dilate(top, _KERNEL) - top <= settings.step_m)
    dist = cv2.distanceTransform(core.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    markers = _item_markers(dist, settings.neck_ratio, settings.min_core_m / pitch)
    if markers.max() <= 1:
        cell_piece = occupied.astype(np.int64)
    else:
        cell_piece = np.where(occupied, _nearest_marker(markers), 0)
    if settings.concave_ratio > 0:
        cell_piece = _cut_concave(cell_piece, settings)
    if settings.rejoin and cell_piece.max() > 1:
        heights = top if height is not None else None
        cell_piece = _rejoin(cell_piece, heights, settings)
    piece = cell_piece[ib, iy] - 1
    return piece, int(cell_piece.max())


def _nearest_marker(markers: np.ndarray, touching: bool = False) -> np.ndarray:
    """Every cell labelled with its nearest marker's label."""
    # The distance to the zero cells of `outside` labels each cell with the marker (a
    # connected group of zero cells) it is nearest to.
    outside = (markers == 0).astype(np.uint8)
    kind = cv2.DIST_LABEL_PIXEL if touching else cv2.DIST_LABEL_CCOMP
    _, nearest = cv2.distanceTransformWithLabels(
        outside, cv2.DIST_L2, cv2.DIST_MASK_5, labelType=kind
    )
    marker_of = np.zeros(int(nearest.max()) + 1, dtype=np.int64)
    marker_of[nearest[markers > 0]] = markers[markers > 0]
    return marker_of[nearest]


def _cut_concave(cell_piece: np.ndarray, settings: SplitSettings) -> np.ndarray:
    """The pieces (cell labels 1..n, 0 outside) cut further at their concave notches."""
    out = np.zeros_like(cell_piece)
    count = 0
    min_cells = math.pi * (settings.min_core_m / settings.raster_m) ** 2
    min_depth = settings.concave_depth_m / settings.raster_m
    for label in range(1, int(cell_piece.max()) + 1):
        todo = [(cell_piece == label).astype(np.uint8)]
        if not todo[0].any():
            continue
        cuts = 0
        while todo:
            mask = todo.pop()
            parts = None
            if cuts < MAX_CUTS:
                parts = _cut_once(mask, settings.concave_ratio, min_depth, min_cells)
            if parts is None:
                count += 1
                out[mask > 0] = count
            else:
                cuts += 1
                todo += parts
    return out


def _deepest_notch(mask: np.ndarray) -> float:
    """Depth of the deepest concave notch of `mask`'s outline [cells] (0: convex)."""
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if len(contours) != 1:
        return math.inf
    outline = contours[0]
    if len(outline) < 8:
        return 0.0
    hull = cv2.convexHull(outline, returnPoints=False)
    try:
        defects = cv2.convexityDefects(outline, hull)
    except cv2.error:
        return math.inf
    return 0.0 if defects is None else float(defects.reshape(-1, 4)[:, 3].max()) / 256.0


def _rejoin(cell_piece: np.ndarray, top: np.ndarray | None, settings: SplitSettings):
    """Pieces joined again, two at a time, while two that touch make a convex whole (no notch
    of `concave_depth_m`) of one height (medians within `step_m`): one item the distance
    transform cut across (a long bottle whose end met a neighbour)."""
    min_depth = settings.concave_depth_m / settings.raster_m
    pieces = cell_piece.copy()
    while True:
        grown = cv2.dilate(pieces.astype(np.float32), _KERNEL).astype(np.int64)
        touching = (pieces > 0) & (grown != pieces) & (grown > 0)
        pairs = sorted(
            {(int(a), int(b)) for a, b in zip(pieces[touching], grown[touching], strict=True)}
        )
        for a, b in pairs:
            union = ((pieces == a) | (pieces == b)).astype(np.uint8)
            if top is not None:
                ha = float(np.median(top[pieces == a]))
                hb = float(np.median(top[pieces == b]))
                if abs(ha - hb) > settings.step_m:
                    continue
            if _deepest_notch(union) < min_depth:
                pieces[pieces == max(a, b)] = min(a, b)
                break
        else:
            break
    _, pieces = np.unique(pieces, return_inverse=True)
    return pieces.reshape(cell_piece.shape)


def _cut_once(
    mask: np.ndarray, max_ratio: float, min_depth: float, min_cells: float
) -> list[np.ndarray] | None:
    """`mask` (uint8) cut in two along the best chord between two concave notches, or None.

    The notches are the convexity defects of the mask's outline at least `min_depth` deep
    [cells]; a chord between two of them is a cut when it lies inside the mask and its length
    is at most `max_ratio` times the sum of their depths; the shortest such cut relative to
    its notches is made, when both sides keep at least `min_cells` cells.
    """
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    outline = max(contours, key=len)
    if len(outline) < 8:
        return None
    hull = cv2.convexHull(outline, returnPoints=False)
    try:
        defects = cv2.convexityDefects(outline, hull)
    except cv2.error:  # an outline that crosses itself (a one-cell bridge): left whole
        return None
    if defects is None:
        return None
    defects = defects.reshape(-1, 4)
    defects = defects[defects[:, 3] >= min_depth * 256]  # depths in 1/256 cell
    if len(defects) < 2:
        return None
    points = outline[defects[:, 2], 0].astype(np.float64)  # (column, row)
    depth = defects[:, 3] / 256.0
    i, j = np.triu_indices(len(points), 1)
    length = np.hypot(*(points[i] - points[j]).T)
    ratio = length / (depth[i] + depth[j])
    steps = np.linspace(0.0, 1.0, 24)[:, None]
    for k in np.argsort(ratio, kind="stable"):
        if ratio[k] > max_ratio:
            return None
        p, q = points[i[k]], points[j[k]]
        chord = np.rint(p * (1.0 - steps) + q * steps).astype(np.int64)
        if mask[chord[:, 1], chord[:, 0]].mean() < 0.8:
            continue
        parts = _cut_along(mask, p, q, min_cells)
        if parts is not None:
            return parts
    return None


def _cut_along(
    mask: np.ndarray, p: np.ndarray, q: np.ndarray, min_cells: float
) -> list[np.ndarray] | None:
    """The parts of `mask` the chord p-q (column, row) cuts it into, each cell of the chord
    and of a crumb given to the nearest part; None unless two parts hold `min_cells`."""
    cut = mask.copy()
    cv2.line(cut, (int(p[0]), int(p[1])), (int(q[0]), int(q[1])), 0, 1, cv2.LINE_8)
    n, labels = cv2.connectedComponents(cut, connectivity=4)
    sizes = np.bincount(labels.ravel(), minlength=n)
    sizes[0] = 0
    big = np.flatnonzero(sizes >= min_cells)
    if len(big) < 2:
        return None
    near = _nearest_marker(np.where(np.isin(labels, big), labels, 0), touching=True)
    return [((mask > 0) & (near == k)).astype(np.uint8) for k in big]


def _item_markers(dist: np.ndarray, neck_ratio: float, min_core_cells: float) -> np.ndarray:
    """Markers 1..n of the items in a distance transform [cells] (0 elsewhere)."""
    top_level = max(neck_ratio * float(dist.max()), 1.0)
    levels = [lv for lv in LEVELS_CELLS if lv <= top_level]
    labels: list[np.ndarray] = []
    peaks: list[np.ndarray] = []
    parents: list[np.ndarray] = []
    for k, level in enumerate(levels):
        lab, n = ndimage.label(dist >= level, structure=_EIGHT)
        peak = np.zeros(n + 1, dtype=np.float32)
        np.maximum.at(peak, lab.ravel(), dist.ravel())
        parent = np.zeros(n + 1, dtype=np.int64)
        if k:  # a part of this level lies inside one part of the level below
            parent[lab] = labels[-1]
            parent[0] = 0
        labels.append(lab)
        peaks.append(peak)
        parents.append(parent)

    def items(k: int, c: int) -> list[tuple[int, int]]:
        """The item parts (level index, label) of part c of level k (an item itself)."""
        if k + 1 == len(levels):
            return [(k, c)]
        wide = [
            q
            for q in np.flatnonzero(parents[k + 1] == c)  # its parts at the next level
            if q > 0
            and peaks[k + 1][q] >= min_core_cells
            and levels[k + 1] <= neck_ratio * peaks[k + 1][q]
        ]
        if len(wide) == 1:
            below = items(k + 1, int(wide[0]))
            return below if len(below) > 1 else [(k, c)]
        if len(wide) > 1:
            return [part for q in wide for part in items(k + 1, int(q))]
        return [(k, c)]

    roots = [c for c in range(1, len(peaks[0])) if peaks[0][c] >= min_core_cells]
    markers = np.zeros(dist.shape, dtype=np.int64)
    for n, (k, c) in enumerate((p for r in roots for p in items(0, r)), start=1):
        markers[labels[k] == c] = n
    return markers
