"""`seen_best`: the best pick order over the items in view, replanned at every decision.

At each decision it searches every order of (at most `max_items` of) the items it can meet now
(`planner.decision.oracle.best_sequence`) and takes the first pick of the best one. What it is
not: a bound. It knows nothing of the items still upstream of its view, and the physics' robot
does not keep to the cycle-time model its search times orders with, so in episodes it can earn
less than simpler rules (the planner-level bound over a whole known belt is
`planner.decision.kinematic_belt.oracle_bound`; the bound over a whole flow in physics is
`planner.decision.flow_bound`). Until this name it was called `oracle`; config files and
manifests that name `oracle` are read as `seen_best` (`sim.config.migration`).
"""

from __future__ import annotations

from planner.decision.candidates import Candidate, candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.oracle import best_sequence
from planner.errors import PlannerInputError


class SeenBestPlanner:
    """Replans the best sequence over the items in view at every decision; takes its first pick.

    With one-hot (truth) probabilities it plays the exact optimum of the items it sees; with
    class probabilities it optimises expected value. `max_items` caps the search (the most
    urgent feasible items are kept) because it is exponential in the worst case.
    """

    name = "seen_best"

    def __init__(self, max_items: int = 12):
        if isinstance(max_items, bool) or not isinstance(max_items, int) or max_items < 1:
            raise PlannerInputError("max_items", "an integer >= 1", max_items)
        self.max_items = max_items

    def reset(self) -> None:
        """Stateless: replans from scratch at every decision."""

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """First pick of the best sequence over (at most max_items of) the feasible items."""
        cands: list[Candidate] = candidates(items, robot, context)[: self.max_items]
        if not cands:
            return None
        plan = best_sequence(
            [c.item for c in cands],
            [c.expected_value for c in cands],
            [c.bin_class for c in cands],
            robot,
            context,
        )
        if not plan.sequence:
            return None
        first = next(c for c in cands if c.item.item_id == plan.sequence[0])
        return choice_of(
            first, f"best sequence of {len(plan.sequence)} picks, {plan.profit:.2f} EUR"
        )
