"""Items picked per second and the timing of the thesis's tables 4.5 and 4.6, from its columns.

The thesis gives per dataset the accuracy (picked over items), the Time [s] and the profit of its
proximity picker and its Q-learning. Items picked = accuracy x items, so items per second =
accuracy x items / Time. These are the numbers the `calibrated` regime's pauses are set to
(`experiments/reproduce_4_5_calibrated.toml`) and the timing hypothesis of the +13 % finding:
its Q-learning ran longer and picked more items per second than its proximity picker, by the
thesis's own columns.
"""

from __future__ import annotations

import statistics
from dataclasses import dataclass

CALIBRATION_TOLERANCE = 0.05
"""How far (relative) the calibrated regime's proximity may be from the thesis's items per
second, on the mean over table 4.5's datasets."""


def items_picked(t: dict, planner: str) -> list[float]:
    """Items picked per dataset of a table 4.5/4.6 (`thesis_tables()["4.5"]`): accuracy x items."""
    return [a * n for a, n in zip(t[f"accuracy_{planner}"], t["items"], strict=True)]


def items_per_s(t: dict, planner: str) -> list[float]:
    """Items picked per second of its Time, per dataset [1/s]."""
    picked = items_picked(t, planner)
    return [p / s for p, s in zip(picked, t[f"time_{planner}"], strict=True)]


def mean_items_per_s(t: dict, planner: str) -> float:
    """The mean over the datasets of `items_per_s` [1/s]: the calibration's target."""
    return statistics.fmean(items_per_s(t, planner))


@dataclass(frozen=True)
class Timing:
    """The thesis's Q-learning against its proximity picker on one table, means over the
    datasets of the per-dataset ratios, in percent.

    Attributes:
        longer_pct: How much longer its Time was.
        rate_pct: How many more items it picked per second of its Time.
        picked_pct: How many more items it picked.
    """

    longer_pct: float
    rate_pct: float
    picked_pct: float


def timing(t: dict) -> Timing:
    """`Timing` of table `t` (4.5 or 4.6)."""

    def gain(ours: list[float], theirs: list[float]) -> float:
        return 100.0 * statistics.fmean(a / b - 1.0 for a, b in zip(ours, theirs, strict=True))

    return Timing(
        longer_pct=gain(t["time_qlearning"], t["time_proximity"]),
        rate_pct=gain(items_per_s(t, "qlearning"), items_per_s(t, "proximity")),
        picked_pct=gain(items_picked(t, "qlearning"), items_picked(t, "proximity")),
    )
