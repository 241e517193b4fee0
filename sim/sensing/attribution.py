"""Which true item a new track is of: the evaluation's bookkeeping, never the robot's knowledge.

The metrics count the items perception never reported (`never_detected`,
`sim.results.metrics`), which needs each track tied to a true item. In truth mode a detection
carries its item's id. A camera detection carries none (a real cell has no such id), so a new
track is attributed to the true item whose footprint (grown by `FOOTPRINT_MARGIN_M`) holds the
track's position at the detection time (the nearest centre among several), else to the item
nearest to it if one lies within the gate (the tracker's match radius, 0.06 m); otherwise to
none (a phantom). The footprint counts a track on either end of a long bottle, 10 cm from its
centre, as the bottle's. Only the metrics read the result: the tracker, the decision managers and
the pick never see it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from sim.flow.catalogue import ItemType
from sim.flow.footprint_polygons import contains_grown, to_body
from sim.sensing.tracking import Track

FOOTPRINT_MARGIN_M = 0.01
"""A track within this of an item's footprint lies on it [m] (centroids of items cut apart
lie well inside)."""


def attributed_item(
    track: Track,
    t: float,
    belt_speed: float,
    items_xy: Mapping[int, tuple[float, float]],
    gate_m: float,
    shapes: Mapping[int, tuple[float, ItemType]] | None = None,
) -> int | None:
    """The true item a new track is of, or None.

    Args:
        track: The track just created by a detection at time `t`.
        t: Time of the detection [s].
        belt_speed: Belt speed [m/s] (the track's position at `t`).
        items_xy: Belt position (x, y) [m] of every true item on the belt at `t`, by item id.
        gate_m: Farthest an item's centre may be from the track to be attributed [m] (when
            no footprint holds the track).
        shapes: (yaw [rad], scaled item type) of the items, by item id; None: centres only.

    Returns:
        The track's own item id when perception gave one (truth mode), else the id of the
        nearest item within `gate_m` (the lower id on a tie), else None.
    """
    if track.true_id is not None:
        return int(track.true_id)
    x, y = track.x_at(t, belt_speed), track.y
    distances = {int(i): math.hypot(ix - x, iy - y) for i, (ix, iy) in items_xy.items()}
    if shapes:
        on = [(distances[i], i) for i in distances if _on_footprint(shapes, i, x, y, items_xy)]
        if on:
            return min(on)[1]
    within = [(d, item_id) for item_id, d in distances.items() if d <= gate_m]
    return min(within)[1] if within else None


def _on_footprint(
    shapes, item_id: int, x: float, y: float, items_xy: Mapping[int, tuple[float, float]]
) -> bool:
    """Whether (x, y) [m] lies on item `item_id`'s footprint grown by FOOTPRINT_MARGIN_M."""
    if item_id not in shapes:
        return False
    yaw, item_type = shapes[item_id]
    lx, ly = to_body(np.array([x]), np.array([y]), *items_xy[item_id], yaw)
    return bool(contains_grown(item_type, lx, ly, FOOTPRINT_MARGIN_M)[0])
