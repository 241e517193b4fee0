"""Ground truth of the belt grid: the true class and observation code of every cell.

Pure geometry. The area of every item's footprint inside every cell (grid row x stripe) is
computed exactly (`sim.flow.coverage`: rectangles exact, discs and stadiums as 64-gons of the same
area), which gives the fraction of the cell each item covers. A cell's class is the class
covering most of it, void when under 1 % is covered; its code is the size class of the covered
fraction (all items together, as a camera sees it) with the colour of the item covering most
of it (`perception.codes`), EMPTY_CODE when under 1 %.

Grid rows lie along the belt: row k is centred at x = x_first - k * pitch and spans one pitch,
so later rows sit further upstream (they reach the camera later). Stripe j spans
y in [-W/2 + j W/5, -W/2 + (j + 1) W/5) of a belt W wide: [-0.4 + 0.16 j, -0.4 + 0.16 (j + 1))
on the thesis's 0.8 m belt.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from perception.codes import COLOURS, EMPTY_CODE, MEDIUM_MAX, MIN_FRACTION, SMALL_MAX, VOID
from sim.flow.catalogue import Catalogue, ItemType
from sim.flow.config import BELT_WIDTH_M, N_STRIPES, X_CAMERA, stripe_geometry
from sim.flow.coverage import outline, polygon_rect_areas
from sim.flow.generator import Flow


@dataclass(frozen=True, eq=False)
class GridTruth:
    """True state of a block of grid cells, arrays of shape (rows, 5).

    Attributes:
        classes: Class per cell (1 void, 2 paper, 3 plastic, 4 aluminium).
        codes: Observation code per cell (1..18, EMPTY_CODE = 19).
        covered: Fraction of the cell covered by items, 0..1.
        dominant: Index of the item covering most of the cell, -1 for none.
    """

    classes: np.ndarray
    codes: np.ndarray
    covered: np.ndarray
    dominant: np.ndarray


def grid_truth(
    x: np.ndarray,
    y: np.ndarray,
    yaw: np.ndarray,
    type_index: np.ndarray,
    class_id: np.ndarray,
    colour: np.ndarray,
    catalogue: Catalogue,
    x_first: float,
    pitch: float,
    n_rows: int,
    item_types: Sequence[ItemType] | None = None,
    belt_width_m: float = BELT_WIDTH_M,
) -> GridTruth:
    """True classes and codes of `n_rows` grid rows from item footprints on the belt plane.

    Args:
        x, y, yaw: Item centres [m] and headings [rad] in one belt-plane frame.
        type_index: Catalogue index of each item.
        class_id: Class of each item (2, 3, ...: the catalogue's materials).
        colour: Colour index of each item (`perception.codes.COLOURS`).
        catalogue: Where the footprints come from.
        x_first: x of row 0's centre [m]; row k is centred at x_first - k * pitch.
        pitch: Row length along the belt [m].
        n_rows: Rows to compute.
        item_types: Each item's own (scaled, variant) type (`Flow.item_types`); default the
            catalogue's type of `type_index`.
        belt_width_m: The belt's width [m], which the five stripes share.
    """
    half_belt, stripe = stripe_geometry(belt_width_m)
    shape = (n_rows, N_STRIPES)
    # index = class id (0 unused, 1 void, 2.. the materials)
    by_class = np.zeros((n_rows, N_STRIPES, catalogue.materials.n_states + 1))
    best = np.zeros(shape)
    best_colour = np.zeros(shape, dtype=np.int64)
    dominant = np.full(shape, -1, dtype=np.int64)
    cell_area = pitch * stripe
    if item_types is None:
        item_types = [catalogue.types[int(k)] for k in type_index]
    for i in range(len(x)):
        item_type = item_types[i]
        ex, ey = (float(e) for e in item_type.half_extents(yaw[i]))
        k0 = max(math.ceil((x_first - x[i] - ex) / pitch - 0.5), 0)
        k1 = min(math.floor((x_first - x[i] + ex) / pitch + 0.5), n_rows - 1)
        j0 = max(math.floor((y[i] - ey + half_belt) / stripe), 0)
        j1 = min(math.floor((y[i] + ey + half_belt) / stripe), N_STRIPES - 1)
        if k0 > k1 or j0 > j1:
            continue
        rows, cols = np.arange(k0, k1 + 1), np.arange(j0, j1 + 1)
        # Cells relative to the item's centre, for precision far along long flows.
        kk, jj = (a.ravel() for a in np.meshgrid(rows, cols, indexing="ij"))
        cx = x_first - pitch * kk - float(x[i])
        cy = stripe * (jj + 0.5) - half_belt - float(y[i])
        poly = outline(item_type, 0.0, 0.0, float(yaw[i]))
        areas = polygon_rect_areas(
            poly, cx - pitch / 2, cx + pitch / 2, cy - stripe / 2, cy + stripe / 2
        )
        frac = (areas / cell_area).reshape(len(rows), len(cols))
        block = np.ix_(rows, cols)
        by_class[block[0], block[1], int(class_id[i])] += frac
        better = frac > best[block]
        best[block] = np.where(better, frac, best[block])
        best_colour[block] = np.where(better, int(colour[i]), best_colour[block])
        dominant[block] = np.where(better, i, dominant[block])
    covered = np.minimum(by_class.sum(axis=-1), 1.0)
    empty = covered < MIN_FRACTION
    classes = np.where(empty, VOID, np.argmax(by_class, axis=-1))
    size = np.where(covered <= SMALL_MAX, 0, np.where(covered <= MEDIUM_MAX, 1, 2))
    codes = np.where(empty, EMPTY_CODE, 1 + size * len(COLOURS) + best_colour)
    dominant = np.where(empty, -1, dominant)
    return GridTruth(classes.astype(np.int64), codes.astype(np.int64), covered, dominant)


def flow_rows(flow: Flow, catalogue: Catalogue) -> int:
    """Rows from t = 0 until the last item has fully passed the camera line."""
    types = (*catalogue.types, *flow.item_types(catalogue))
    reach = max(math.hypot(t.half_length, t.half_width) for t in types)
    last = float(flow.tau.max()) if len(flow) else 0.0
    return (
        int(math.ceil(last / flow.config.observation_period_s + reach / flow.config.row_pitch_m))
        + 2
    )


def flow_truth(
    flow: Flow, catalogue: Catalogue, n_rows: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Ground-truth grid sequences of a flow: what passes under the camera, row by row.

    Row k is the belt under the camera band at time k * T, so an item's centre lies in row
    round(tau / T). Items are placed in the belt frame at time 0 (x = X_CAMERA - v tau).

    Args:
        flow: The generated flow.
        catalogue: Its item types.
        n_rows: Rows to compute; default `flow_rows(flow, catalogue)`.

    Returns:
        (classes, codes): int arrays (n_rows, 5), one HMM sequence per stripe (column).
    """
    n_rows = flow_rows(flow, catalogue) if n_rows is None else n_rows
    x = X_CAMERA - flow.config.belt_speed_mps * flow.tau
    truth = grid_truth(
        x, flow.y, flow.yaw, flow.type_index, flow.class_id, flow.colour, catalogue,
        x_first=X_CAMERA, pitch=flow.config.row_pitch_m, n_rows=n_rows,
        item_types=flow.item_types(catalogue), belt_width_m=flow.config.belt_width_m,
    )  # fmt: skip
    return truth.classes, truth.codes


def yaw_from_xmat(xmat: np.ndarray) -> np.ndarray:
    """Heading [rad] of bodies' x axes from MuJoCo's row-major rotation matrices (N, 9)."""
    xmat = np.asarray(xmat).reshape(-1, 9)
    return np.arctan2(xmat[:, 3], xmat[:, 0])


def cell_truth_from_poses(
    xy: np.ndarray,
    yaw: np.ndarray,
    type_index: np.ndarray,
    class_id: np.ndarray,
    colour: np.ndarray,
    catalogue: Catalogue,
    pitch: float,
    x_centre: float = X_CAMERA,
    item_types: Sequence[ItemType] | None = None,
    belt_width_m: float = BELT_WIDTH_M,
) -> tuple[np.ndarray, np.ndarray]:
    """True classes and codes of the camera band's row from items' physical poses.

    Footprints are those of the items' resting poses (`ItemType.pose`) at the given heading.

    Args:
        xy: Item centres (N, 2) or (N, 3) [m] in the world frame (e.g. `data.xpos`).
        yaw: Headings of the items' body x axes [rad] (see `yaw_from_xmat`).
        type_index, class_id, colour: Per item, as in a `Flow`.
        catalogue: Item types.
        pitch: Row length along the belt, belt speed x observation period [m].
        x_centre: Centre of the camera band [m].
        item_types: Each item's own (scaled, variant) type (`ItemPool.item_type`); default the
            catalogue's type of `type_index`.
        belt_width_m: The belt's width [m].

    Returns:
        (classes, codes): int arrays (5,), one per stripe.
    """
    xy = np.asarray(xy, dtype=float).reshape(len(yaw), -1)
    truth = grid_truth(
        xy[:, 0], xy[:, 1], np.asarray(yaw, dtype=float), type_index, class_id, colour,
        catalogue, x_first=x_centre, pitch=pitch, n_rows=1, item_types=item_types,
        belt_width_m=belt_width_m,
    )  # fmt: skip
    return truth.classes[0], truth.codes[0]
