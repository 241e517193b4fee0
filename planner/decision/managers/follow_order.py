"""Replaying a pick order found off-line on a whole known flow, in an episode.

The order names the flow's items (their ids); the episode's tracker names tracks. At each
decision every item in view is matched to the flow item nominally nearest it (each flow item at
x0 + v t, its y; within `MATCH_M`), and the candidate (`planner.decision.candidates`) that comes
first in the order is picked. When no item of the order can be met now, the candidate that
leaves the window first is picked instead, so the robot does not idle while physics departs from
the order (a pick order all the same). Not in the registry: it needs its order and its flow.
"""

from __future__ import annotations

import numpy as np

from planner.decision.candidates import candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem

MATCH_M = 0.08
"""Farthest a tracked item may be from a flow item's nominal place to be taken for it [m]."""


class FollowOrderPlanner:
    """Picks the items of `order` in that order, as far as physics lets it.

    Args:
        order: Flow item ids, in the order to pick them.
        x0: Each flow item's x at t = 0, riding at the belt's speed [m] (by flow id).
        y: Each flow item's y [m].
    """

    name = "best_known_order"

    def __init__(self, order, x0, y):
        self.order = tuple(int(i) for i in order)
        self.rank = {item: k for k, item in enumerate(self.order)}
        self.x0 = np.asarray(x0, dtype=float)
        self.y = np.asarray(y, dtype=float)
        self.chosen: set[int] = set()
        """Flow items of the order chosen so far (the other choices filled in where none of it
        was reachable)."""

    @property
    def followed(self) -> int:
        """Items of the order chosen (a choice the cell refused and chose again counts once)."""
        return len(self.chosen)

    def reset(self) -> None:
        """Start of an episode: nothing followed yet."""
        self.chosen = set()

    def flow_id(self, item: TrackedItem, t: float, speed: float) -> int | None:
        """The flow item nominally nearest `item` at t [s], or None beyond `MATCH_M`."""
        if not len(self.x0):
            return None
        dist = np.hypot(self.x0 + speed * t - item.x, self.y - item.y)
        k = int(np.argmin(dist))
        return k if dist[k] <= MATCH_M else None

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The candidate first in the order, else the one that leaves first."""
        cands = candidates(items, robot, context)
        if not cands:
            return None
        ranked = []
        for c in cands:
            fid = self.flow_id(c.item, robot.time, context.belt_speed)
            if fid is not None and fid in self.rank:
                ranked.append((self.rank[fid], fid, c))
        if ranked:
            k, fid, best = min(ranked, key=lambda rc: rc[0])
            self.chosen.add(fid)
            return choice_of(best, f"order: pick {k + 1} of {len(self.order)}")
        first = min(cands, key=lambda c: (c.exit_time, c.item.item_id))
        return choice_of(first, "order: none reachable, the first to leave")
