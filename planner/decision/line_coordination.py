"""Coordination of a line of robots over one belt: which items a free robot may choose among.

A line has robots 0..N-1 in series along the belt (0 upstream). Each robot has its own decision
manager and context (its reachable window, its bins); the items are tracked once for the line.
When a robot is free, the coordination hands its decision manager the items it may take:

- `independent`: every tracked item no other robot holds or is picking (each robot picks on
  its own; the upstream robots take what they like first).
- `coordinated` (this project's rule, not the thesis's: the thesis plans for one robot, and
  names the line's planner as future work, 5.2): what a downstream robot can still take, the
  upstream one leaves, but never by idling. The downstream robots' next picks are predicted by
  list scheduling in order of the items' deadlines (their exit from each robot's window): the
  most downstream robot first, each free again a cycle (`pick_time_s`, with slack) after each
  predicted pick, taking the items it can still meet inside its window before they leave it.
  The free robot is offered the items no downstream robot is predicted to take, when one of
  them is in its window within `START_HORIZON_S` (an item the line would otherwise lose);
  otherwise it is offered every item in its window within that time, claimed or not: a robot
  that waits while items pass through its reach wastes capacity the line needs when a
  prediction fails, and an item it takes off a downstream robot's list only gives that robot
  slack. The last robot is offered every item in its window within that time. The claims
  are made again at every decision, over the items in view then.

Pure functions of the tracked items and the robots' windows, times and belt speed; SI units
(m, s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from planner.decision.interface import DecisionContext, TrackedItem
from planner.decision.registry import COORDINATIONS
from planner.decision.robot_materials import items_sorted_by, sorts
from planner.errors import PlannerInputError

CLAIM_SLACK = 1.6
"""A downstream robot's predicted picks are spaced by its pick time times this (its picks vary
about their mean: a claim it cannot keep costs the item). Chosen among 1.3, 1.6 and 2.0 on
two-robot lines at 225 and 300 items in 90 s, seeds 600-602 (held apart from the seeds the
line's results are measured on)."""
CLAIM_MARGIN_S = 0.5
"""A downstream robot claims an item only if it would meet it this long before the item
leaves its window [s]."""


@dataclass(frozen=True, eq=False)
class LineRobot:
    """One robot of the line as the coordination sees it.

    Attributes:
        context: Its decision context (belt speed, its reachable window, its bins, values).
        free_at: When it is free to start its next pick [s] (now for a free robot).
        class_ids: The material classes (2, 3, ...) it sorts; None: all of them
            (`planner.decision.robot_materials`).
    """

    context: DecisionContext
    free_at: float
    class_ids: frozenset[int] | None = None

    def __post_init__(self):
        if not isinstance(self.context, DecisionContext):
            raise PlannerInputError("context", "a DecisionContext", type(self.context).__name__)
        if not math.isfinite(self.free_at):
            raise PlannerInputError("free_at", "a finite time [s]", self.free_at)
        if self.class_ids is not None and not (
            isinstance(self.class_ids, frozenset) and self.class_ids
        ):
            raise PlannerInputError("class_ids", "None or a non-empty frozenset", self.class_ids)


def window_times(
    context: DecisionContext, t: float, item: TrackedItem
) -> tuple[float, float] | None:
    """(entry, exit) times [s] of `item` (at its position at `t`) through the robot's window,
    None when the cup never reaches its lateral position or the belt stands still."""
    bounds = context.window.bounds(item.y)
    v = context.belt_speed
    if bounds is None or v <= 0.0:
        return None
    x_in, x_out = bounds
    return t + (x_in - item.x) / v, t + (x_out - item.x) / v


def downstream_claims(
    items: Sequence[TrackedItem],
    robots: Sequence[LineRobot],
    robot: int,
    t: float,
    pick_time_s: float,
    lead_s: float = 0.0,
) -> set[int]:
    """Ids of the items the robots downstream of `robot` are predicted to take.

    Args:
        items: The tracked items not held or under way, positions at `t`.
        robots: Every robot of the line, upstream first.
        robot: The index of the free robot asking.
        t: Now [s].
        pick_time_s: A pick's duration, from the meet to the next meet [s] (> 0).
        lead_s: Time from a robot's start until its cup meets an item [s] (>= 0).
    """
    if not pick_time_s > 0.0 or not lead_s >= 0.0:
        raise PlannerInputError("pick_time_s, lead_s", "> 0 and >= 0 [s]", (pick_time_s, lead_s))
    claimed: set[int] = set()
    for k in range(len(robots) - 1, robot, -1):
        context = robots[k].context
        free = max(robots[k].free_at, t)
        timed = []
        for item in items:
            if item.item_id in claimed or context.expected_value(item) <= 0.0:
                continue
            if not sorts(robots[k].class_ids, item):
                continue
            times = window_times(context, t, item)
            if times is not None and times[1] > t:
                timed.append((times[1], times[0], item.item_id))
        for deadline, entry, item_id in sorted(timed):
            meet = max(free + lead_s, entry)
            if meet <= deadline - CLAIM_MARGIN_S:
                claimed.add(item_id)
                free = meet + CLAIM_SLACK * pick_time_s - lead_s
    return claimed


START_HORIZON_S = 0.3
"""A free robot is offered the items in its window within this time [s] (chosen among 0, 0.3
and 1 s with `CLAIM_SLACK`: a longer horizon sends the upstream robot after items that have
not reached it yet while nearer ones pass)."""


def offered_items(
    coordination: str,
    items: Sequence[TrackedItem],
    robots: Sequence[LineRobot],
    robot: int,
    t: float,
    pick_time_s: float,
    lead_s: float = 0.0,
) -> list[TrackedItem]:
    """The items the free `robot` may choose among under `coordination` (see the module
    docstring); `items` are those no robot holds or is picking."""
    if coordination not in COORDINATIONS:
        raise PlannerInputError("coordination", " | ".join(COORDINATIONS), coordination)
    if not 0 <= robot < len(robots):
        raise PlannerInputError("robot", f"0..{len(robots) - 1}", robot)
    items = list(items)
    mine = items_sorted_by(items, robots[robot].class_ids)
    if coordination == "independent":
        return mine
    context = robots[robot].context
    soon = [it for it in mine if _in_reach_within(context, t, it, START_HORIZON_S)]
    if not soon or robot == len(robots) - 1:
        return soon  # the last robot: nobody downstream to leave items to
    claimed = downstream_claims(items, robots, robot, t, pick_time_s, lead_s)
    unclaimed = [it for it in soon if it.item_id not in claimed]
    return unclaimed or soon


def _in_reach_within(context: DecisionContext, t: float, item: TrackedItem, horizon: float):
    """The item is in the robot's window at some time in [t, t + horizon]."""
    times = window_times(context, t, item)
    return times is not None and times[1] > t and times[0] <= t + horizon
