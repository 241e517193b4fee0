"""Whether a planned cup path clears the items on the belt other than the one it picks.

The empty cup flies from the last drop point down to the item it picks. Ruckig's segments are
time-optimal per coordinate, not straight lines, so where the cup passes low and sideways depends
on the plan: the check is made on the plan itself, sampled in time, against each neighbour as it
moves with the belt. A neighbour is an `Obstacle`: its footprint on the belt (a rectangle
grown by a radius, which covers discs, lying bottles seen from above and flat boxes) and the
height of its top. The cup is a disc of the lip's radius whose lowest point is the TCP.

`planner` never reads the simulation: the caller measures the neighbours (a stereo camera on a
real cell) and passes them in.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

CHECK_DT = 0.004
"""Time step at which a path is checked [s] (the cup moves at most ~1.5 cm in it)."""
MARGIN_XY = 0.01
"""Horizontal gap kept between the lip's edge and a neighbour's outline [m]."""
MARGIN_Z = 0.015
"""Vertical gap kept between the lip and a neighbour's top when passing over it [m]."""
TOUCH_MARGIN_XY = 0.003
"""Horizontal gap kept between the lip's edge and a neighbour's outline on the last, nearly
vertical, way down onto the item [m]: the cup lands within a millimetre of where it is
planned, and items on the belt lie at least 5 mm apart, so the lip passes a neighbour as
tall as the item by about 8 mm."""


@dataclass(frozen=True)
class Obstacle:
    """An item on the belt the cup must not touch, as it lies now.

    Its footprint is the rectangle of half sizes (`half_x`, `half_y`) about (`x`, `y`), its
    first axis along `heading`, grown by `radius` (a disc: both half sizes 0; a lying bottle:
    `half_y` 0). It moves with the belt.

    Attributes:
        x, y: Centre of the footprint [m].
        heading: Direction of the footprint's first axis [rad].
        half_x, half_y: Half sizes of the rectangle [m].
        radius: Rounding radius added all round [m].
        top: Height of its highest point [m].
    """

    x: float
    y: float
    heading: float
    half_x: float
    half_y: float
    radius: float
    top: float


def footprint_distances(obstacles: Sequence[Obstacle], xy: np.ndarray, shift_x: np.ndarray):
    """Distance [m] from points to each obstacle's footprint (0 inside).

    Args:
        obstacles: The neighbours (k of them).
        xy: Points (n, 2) [m].
        shift_x: How far each obstacle has moved along +x when the cup is at each point (n,)
            [m] (the belt's travel).

    Returns:
        (k, n) distances.
    """
    if not obstacles:
        return np.zeros((0, len(xy)))
    o = np.array([(b.x, b.y, b.heading, b.half_x, b.half_y, b.radius) for b in obstacles])
    dx = xy[None, :, 0] - (o[:, 0, None] + shift_x[None, :])
    dy = xy[None, :, 1] - o[:, 1, None]
    c, s = np.cos(o[:, 2])[:, None], np.sin(o[:, 2])[:, None]
    along, across = np.abs(c * dx + s * dy), np.abs(-s * dx + c * dy)
    out = np.hypot(np.maximum(along - o[:, 3, None], 0.0), np.maximum(across - o[:, 4, None], 0.0))
    return np.maximum(out - o[:, 5, None], 0.0)


def outline_points(obstacle: Obstacle, n: int = 9) -> np.ndarray:
    """Points (n * n, 2) [m] covering an obstacle's footprint: an n x n grid over its rectangle
    grown by its radius (edges included), each point outside the footprint (the grid's corners
    beyond a rounded corner) moved onto its nearest point of the footprint's outline, so that the
    outline's corners are always among the points (a plain grid misses a tilted box's corners,
    and a neighbour's corner over them would go unseen)."""
    return outline_points_of([obstacle], n)[0]


def outline_points_of(obstacles: Sequence[Obstacle], n: int = 9) -> np.ndarray:
    """`outline_points` of each obstacle, (k, n * n, 2) [m], computed for all at once (each
    obstacle's points with the same operations as alone)."""
    o = np.array([(b.x, b.y, b.heading, b.half_x, b.half_y, b.radius) for b in obstacles])
    x, y, heading, half_x, half_y, radius = (o[:, k, None] for k in range(6))  # each (k, 1)
    u = np.linspace(-1.0, 1.0, n)
    k = len(o)
    # np.meshgrid's grid, raveled: point i n + j at (u_j (half_x + r), u_i (half_y + r)).
    a = np.broadcast_to((u * (half_x + radius))[:, None, :], (k, n, n)).reshape(k, n * n)
    c_ = np.broadcast_to((u * (half_y + radius))[:, :, None], (k, n, n)).reshape(k, n * n)
    core_a, core_b = np.clip(a, -half_x, half_x), np.clip(c_, -half_y, half_y)
    da, db = a - core_a, c_ - core_b
    out = np.hypot(da, db)
    pull = np.where(out > radius, radius / np.maximum(out, 1e-300), 1.0)
    la, lb = core_a + da * pull, core_b + db * pull
    c, s = np.cos(heading), np.sin(heading)
    return np.stack([x + c * la - s * lb, y + s * la + c * lb], axis=2)


@dataclass(frozen=True)
class Conflict:
    """A neighbour the planned cup comes too close to.

    Attributes:
        index: Its index in the obstacles given.
        time: When, from the plan's start [s].
        cup_z: Height of the lip then [m].
        top: The neighbour's top [m].
        gap: Horizontal gap between the lip's edge and its outline then [m] (< MARGIN_XY).
    """

    index: int
    time: float
    cup_z: float
    top: float
    gap: float


def path_conflicts(
    chain,
    t_end: float,
    obstacles: Sequence[Obstacle],
    belt_speed: float,
    cup_radius: float,
    margin_xy: float = MARGIN_XY,
    margin_z: float = MARGIN_Z,
    t_start: float = 0.0,
) -> list[Conflict]:
    """The neighbours the cup of `chain` comes too close to between `t_start` and `t_end`.

    Too close: the lip's edge within `margin_xy` of the neighbour's outline while the lip is
    less than `margin_z` above its top. One `Conflict` per neighbour, the lowest pass.

    Args:
        chain: The plan (`states_at(times)` gives the TCP, the lip's centre, first).
        t_end: End of the checked span [s from the plan's start] (e.g. the touch-down).
        obstacles: The neighbours, as they lie at the plan's start.
        belt_speed: Belt speed along +x [m/s] (the neighbours move with it).
        cup_radius: Radius of the lip [m].
        margin_xy: Horizontal margin [m].
        margin_z: Vertical margin [m].
        t_start: Start of the checked span [s].
    """
    if not obstacles or t_end <= t_start:
        return []
    times = np.append(np.arange(t_start, t_end, CHECK_DT), t_end)
    tcp = chain.states_at(times)[0][:, :3]
    gaps = footprint_distances(obstacles, tcp[:, :2], belt_speed * times) - cup_radius
    tops = np.array([b.top for b in obstacles])
    close = (gaps < margin_xy) & (tcp[None, :, 2] < tops[:, None] + margin_z)
    out = []
    for k in np.flatnonzero(close.any(axis=1)):
        hits = np.flatnonzero(close[k])
        j = hits[np.argmin(tcp[hits, 2])]
        out.append(
            Conflict(int(k), float(times[j]), float(tcp[j, 2]), float(tops[k]), float(gaps[k, j]))
        )
    return out
