"""Which true item a new track is of: the evaluation's bookkeeping, never the robot's knowledge.

The metrics count the items perception never reported (`never_detected`,
`sim.episode.metrics`), which needs each track tied to a true item. In truth mode a detection
carries its item's id. A camera detection carries none (a real cell has no such id), so a new
track is attributed to the true item on the belt nearest to the track's position at the
detection time, if one lies within the gate (the tracker's match radius, 0.06 m); otherwise
to none (a phantom). Only the metrics read the result: the tracker, the decision managers and
the pick never see it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from sim.episode.tracking import Track


def attributed_item(
    track: Track,
    t: float,
    belt_speed: float,
    items_xy: Mapping[int, tuple[float, float]],
    gate_m: float,
) -> int | None:
    """The true item a new track is of, or None.

    Args:
        track: The track just created by a detection at time `t`.
        t: Time of the detection [s].
        belt_speed: Belt speed [m/s] (the track's position at `t`).
        items_xy: Belt position (x, y) [m] of every true item on the belt at `t`, by item id.
        gate_m: Farthest an item may be from the track to be attributed [m].

    Returns:
        The track's own item id when perception gave one (truth mode), else the id of the
        nearest item within `gate_m` (the lower id on a tie), else None.
    """
    if track.true_id is not None:
        return int(track.true_id)
    x, y = track.x_at(t, belt_speed), track.y
    distances = {int(i): math.hypot(ix - x, iy - y) for i, (ix, iy) in items_xy.items()}
    within = [(d, item_id) for item_id, d in distances.items() if d <= gate_m]
    return min(within)[1] if within else None
