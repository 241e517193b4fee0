"""Money as a plant counts it: an episode's figures per hour and what one more robot earns.

An episode feeds its items over `duration_s` (the feed) and runs on until the belt is clear.
A line that runs all day sorts, each feed-length of time, what one feed brings, so an episode's
figures per hour are its totals over the feed's length (`feed_s`), not over the simulated
time (which adds the belt's clearing at the end):

- `recovered_items_per_h`: items in the bin of their own material per hour;
- `recovered_kg_per_h`: their mass per hour [kg/h];
- `profit_per_h_eur`: the profit net of the motors' energy (`net_profit_eur`) per hour
  [EUR/h] (the energy of the clearing included: a slight over-count);
- `robot_cost_per_h_eur`: the robots' cost per running hour (`robot_cost_per_h` times the
  robots) [EUR/h], in a column of its own so that a report nets it.

The robots' settings behind that cost (`[economics]`) are written beside it, so a table of a
robots sweep can give the payback of each added robot (`payback_years`) from the CSV alone.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from sim.config.sections import robot_cost_per_h

SECONDS_PER_HOUR = 3600.0
ECONOMICS_COLUMNS = (
    "robot_capital_eur",
    "robot_life_years",
    "hours_per_year",
    "robot_maintenance_eur_per_year",
)
"""The `[economics]` settings each episodes.csv row carries (its energy price has its column
already: `energy_price_eur_per_kwh`)."""


def payback_years(
    capital_eur: float,
    extra_profit_per_h: float,
    hours_per_year: float,
    maintenance_eur_per_year: float,
) -> float:
    """Years for a robot's capital to be paid back by the profit it adds: capital / (extra
    profit per hour x hours per year - maintenance per year).

    Args:
        capital_eur: Its capital cost [EUR].
        extra_profit_per_h: The profit per hour the line earns with it over without it, net of
            energy [EUR/h].
        hours_per_year: Hours the line runs a year [h].
        maintenance_eur_per_year: Its maintenance a year [EUR].

    Returns:
        Years; inf when the extra profit does not cover its maintenance (it never pays back).
    """
    gain = extra_profit_per_h * hours_per_year - maintenance_eur_per_year
    return capital_eur / gain if gain > 0 else math.inf


def per_hour_columns(
    row: Mapping[str, Any], feed_s: float, robots: int, economics: Mapping[str, float]
) -> dict[str, object]:
    """An episode's columns per hour and its robots' economics.

    Args:
        row: The episode's counters (`EpisodeMetrics.row`: picked, wrong_bin, mass_recovered_kg,
            net_profit_eur).
        feed_s: How long the items were fed (the config's `duration_s`, or `horizon_s` when
            that ends the run sooner) [s].
        robots: The robots of the line.
        economics: {`ECONOMICS_COLUMNS` name: value} (`[economics]`).

    Returns:
        {column: value}: the `recovered_items_per_h`, `recovered_kg_per_h`, `profit_per_h_eur`,
        `robot_cost_per_h_eur` and the `ECONOMICS_COLUMNS`.
    """
    hours = feed_s / SECONDS_PER_HOUR
    recovered = int(row["picked"]) - int(row["wrong_bin"])
    kg = row.get("mass_recovered_kg")
    cost = robot_cost_per_h(*(float(economics[c]) for c in ECONOMICS_COLUMNS))
    return {
        "recovered_items_per_h": recovered / hours,
        "recovered_kg_per_h": None if kg is None else float(kg) / hours,
        "profit_per_h_eur": float(row["net_profit_eur"]) / hours,
        "robot_cost_per_h_eur": robots * cost,
        **{c: float(economics[c]) for c in ECONOMICS_COLUMNS},
    }
