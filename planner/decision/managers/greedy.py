"""Greedy on rate: the highest expected value per second of cycle time.

The cycle is counted from the decision to the release over the bin, waiting for the item
included, so an item far upstream is charged for the time the robot would idle.
"""

from __future__ import annotations

from planner.decision.candidates import candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem


class GreedyPlanner:
    """Maximises expected value [EUR] / cycle time [s]; ties go to the earliest exit."""

    name = "greedy"

    def reset(self) -> None:
        """Stateless."""

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The candidate with the highest expected value per second."""
        cands = candidates(items, robot, context)
        if not cands:
            return None
        rates = [c.expected_value / max(c.cycle_s, 1e-6) for c in cands]
        k = max(range(len(cands)), key=lambda i: (rates[i], -i))
        return choice_of(cands[k], f"rate {rates[k]:.3f} EUR/s over {cands[k].cycle_s:.2f} s")
