"""The feed in a plant's units: the item count of a flow fed at a rate.

A plant states its feed as a belt loading (items per metre of belt), an item rate (items per
second) or a mass rate (kilograms per hour); the episode drops a number of items over its
`duration_s` (`sim.flow.generator`: one per time slot of duration / items). The count is the
rate over the flow's length, rounded to the nearest item:

    items = items_per_m x belt speed [m/s] x duration_s
    items = items_per_s x duration_s
    items = kg_per_h / 3600 / mean item mass [kg] x duration_s

the mean item mass being the catalogue's under the flow's mix (`sim.flow.mix.mean_item_mass_kg`).
A rate within the belt's densest loading never rounds past it (the count is then the most it
allows). Pure functions of numbers.
"""

from __future__ import annotations

import math

FEED_KEYS = ("items_per_m", "items_per_s", "kg_per_h")
"""The `[infeed]` keys, one of which gives the feed (else `items` over `duration_s`)."""
SECONDS_PER_HOUR = 3600.0


def items_per_metre(key: str, rate: float, belt_speed_mps: float, mean_mass_kg: float) -> float:
    """The belt loading of a feed rate [items per metre of belt].

    Args:
        key: One of `FEED_KEYS`.
        rate: The rate in that key's unit (items/m, items/s, kg/h).
        belt_speed_mps: The belt's speed [m/s].
        mean_mass_kg: The mean item mass [kg] (for `kg_per_h`).

    Returns:
        Items per metre of belt.
    """
    per_second = {
        "items_per_m": rate * belt_speed_mps,
        "items_per_s": rate,
        "kg_per_h": rate / SECONDS_PER_HOUR / mean_mass_kg,
    }[key]
    return per_second / belt_speed_mps


def item_count(
    per_metre: float, belt_speed_mps: float, duration_s: float, most_per_metre: float
) -> int:
    """The items a feed of `per_metre` drops over `duration_s`, rounded to the nearest (half
    up); never past `most_per_metre` when the loading itself is within it.

    Args:
        per_metre: The belt loading [items/m].
        belt_speed_mps: The belt's speed [m/s].
        duration_s: The flow's length [s].
        most_per_metre: The densest loading the belt takes [items/m].

    Returns:
        The item count (0 when the feed is too thin for one item).
    """
    metres = belt_speed_mps * duration_s
    count = math.floor(per_metre * metres + 0.5)
    if per_metre <= most_per_metre * (1 + 1e-9):
        count = min(count, math.floor(most_per_metre * metres + 1e-6))
    return int(count)
