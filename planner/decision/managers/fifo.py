"""First in, first out: the most downstream reachable item first (the item about to be lost)."""

from __future__ import annotations

from planner.decision.candidates import candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem


class FifoPlanner:
    """The reachable item that leaves the window first, whatever its value or distance."""

    name = "fifo"

    def reset(self) -> None:
        """Stateless."""

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The candidate with the earliest exit time (candidates come sorted that way)."""
        cands = candidates(items, robot, context, with_place=False)
        if not cands:
            return None
        first = cands[0]
        return choice_of(first, f"first out: leaves in {first.exit_time - robot.time:.2f} s")
