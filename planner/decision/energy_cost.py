"""What a pick's motor energy costs, as the decision managers price it (ours; the thesis's 5.2
names the robot's energy as the next term of its reward).

A pick's electrical energy is modelled as linear in the thesis's distance d (start -> item ->
bin, in the belt's plane): E(d) = `fixed_j` + `per_metre_j` x d, fitted to the energy the
physics measures per pick (`sim.monitors.energy`, the regenerative-free electrical
estimate) by `benchmarks/pick_energy.py` on truth episodes of seeds 100-104 (disjoint from the
evaluation seeds). At `price_eur_per_kwh` a pick costs E(d) / 3.6e6 x price, and every planner
ranks and keeps items by their expected value net of that cost (`DecisionContext.net_value`):
an item that costs more to pick than it earns is left on the belt. A look-ahead order prices
each of its picks from where the robot stands at the decision (the first pick's distance), an
approximation for the later picks, which start from a bin.

At a tariff (0.1-0.5 EUR/kWh) a pick costs 1e-5 to 4e-5 EUR against 0.22-0.27 EUR of value:
energy changes no decision; `docs/results.md` has the trade-off at a tariff and at a stress
price.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.errors import PlannerInputError

JOULES_PER_KWH = 3.6e6

PICK_ENERGY_FIXED_J = 18.8
"""Electrical energy of a pick at zero distance (seal, lift, release, holding) [J]."""
PICK_ENERGY_PER_METRE_J = 158.6
"""Electrical energy per metre of the thesis's distance [J/m]. Fitted with the above on the 500
picks of `python -m sim.experiments.energy_tradeoff fit` (median 255 J electrical, 165 J
mechanical, d median 1.56 m); R^2 0.40: the rest is the lift's height, axis 4's turn and the
move's timing, which the thesis's distance does not see."""


@dataclass(frozen=True)
class EnergyPrice:
    """The price of the motors' energy and the pick-energy model it is applied to.

    Attributes:
        price_eur_per_kwh: Electricity price [EUR/kWh]; 0 leaves every planner as without it.
        fixed_j: Energy of a pick at zero distance [J].
        per_metre_j: Energy per metre of start -> item -> bin distance [J/m].
    """

    price_eur_per_kwh: float = 0.0
    fixed_j: float = PICK_ENERGY_FIXED_J
    per_metre_j: float = PICK_ENERGY_PER_METRE_J

    def __post_init__(self):
        for name in ("price_eur_per_kwh", "fixed_j", "per_metre_j"):
            value = getattr(self, name)
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not (ok and math.isfinite(value) and value >= 0.0):
                raise PlannerInputError(name, "a finite number >= 0", value)

    def energy_j(self, distance_m):
        """Predicted electrical energy of a pick over `distance_m` [m] (scalar or array) [J]."""
        return self.fixed_j + self.per_metre_j * np.asarray(distance_m, dtype=float)

    def cost_eur(self, distance_m):
        """Cost of a pick over `distance_m` [m] at the price [EUR] (0 when the price is 0)."""
        if self.price_eur_per_kwh == 0.0:
            return np.zeros_like(np.asarray(distance_m, dtype=float))
        return self.energy_j(distance_m) / JOULES_PER_KWH * self.price_eur_per_kwh
