"""The best pick order found with the whole flow known, replayed: `best_order`.

Given the episode's whole flow (each item's x at t = 0 riding at the belt's speed, its y and
class: the episode runner passes them, `sim.episode.builder.known_flow`), the planner searches
an order at its first decision of each episode, when it first has its robot's decision context:
`SEARCH` (the look-ahead planner) run on the kinematic belt (`planner.decision.kinematic_belt`)
with every item of the flow in view from the start. It then follows that order
(`follow_order.FollowOrderPlanner`: the candidate first in the order, else the one that leaves
first). The order is timed on the cycle-time model, which the physics' robot does not keep to
exactly, so what it earns in physics is what the best known order earns there, not the most any
order can: an oracle's order, no bound (the bound is `planner.decision.flow_bound`).
"""

from __future__ import annotations

import math

import numpy as np

from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.managers.follow_order import FollowOrderPlanner
from planner.errors import PlannerInputError

SEARCH = "lookahead"
"""The planner whose run over the whole known flow gives the best known order."""


def search_order(
    x0: np.ndarray, y: np.ndarray, classes: np.ndarray, context: DecisionContext
) -> tuple[tuple[int, ...], float]:
    """(order of flow ids, its profit on the kinematic belt [EUR]) of `SEARCH` with every item
    of the flow (x0, y [m], class ids) in view from the start."""
    from planner.decision.kinematic_belt import Belt, BeltItem, one_hot, simulate
    from planner.decision.registry import make_planner

    items = tuple(
        BeltItem(j, float(x), float(yj), int(c), one_hot(int(c)))
        for j, (x, yj, c) in enumerate(zip(x0, y, classes, strict=True))
    )
    belt = Belt(items, context.belt_speed)
    result = simulate(make_planner(SEARCH), belt, context, view_start=-math.inf)
    return tuple(p.item_id for p in result.picks), result.profit


class BestOrderPlanner:
    """Follows the order `search_order` finds on the episode's whole flow.

    Args:
        x0: Each flow item's x at t = 0, riding at the belt's speed [m] (by flow id).
        y: Each flow item's y [m].
        classes: Each flow item's class id.
    """

    name = "best_order"

    def __init__(self, x0=None, y=None, classes=None):
        if x0 is None or y is None or classes is None:
            raise PlannerInputError(
                "best_order", "the episode's flow (x0, y, classes; the episode runner's)", None
            )
        self.x0 = np.asarray(x0, dtype=float)
        self.y = np.asarray(y, dtype=float)
        self.classes = np.asarray(classes, dtype=int)
        if not len(self.x0) == len(self.y) == len(self.classes):
            raise PlannerInputError("best_order flow", "x0, y, classes: one per item", len(y))
        self.order: tuple[int, ...] = ()
        self.planned_profit = math.nan
        """The order's profit on the kinematic belt [EUR] (nan before the first decision)."""
        self._follow: FollowOrderPlanner | None = None

    @property
    def followed(self) -> int:
        """Items of the order chosen so far."""
        return 0 if self._follow is None else self._follow.followed

    def reset(self) -> None:
        """Start of an episode: the order is searched again at the first decision."""
        self._follow = None
        self.order, self.planned_profit = (), math.nan

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The candidate first in the order (searched now if not yet), else the one that leaves
        first."""
        if self._follow is None:
            self.order, self.planned_profit = search_order(self.x0, self.y, self.classes, context)
            self._follow = FollowOrderPlanner(self.order, self.x0, self.y)
        return self._follow.choose(items, robot, context)
