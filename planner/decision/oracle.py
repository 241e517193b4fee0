"""Exact search over pick sequences with time windows: the best profit any sequence can reach.

Depth-first branch and bound over sequences of picks. The state after a pick is (set of items
picked, bin the robot is at, time); profit depends only on the set, and arriving earlier is never
worse (the robot can wait), so a state reached no earlier than before with the same set and bin
is cut. The bound adds the value of every unpicked item that has not yet left the window. The
timing rules are those of `planner.decision.candidates`, the ones the planners and the belt
simulator
use, so on true classes the result bounds every planner's profit on the same items.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.decision.candidates import Candidate, candidates, choice_of, exit_time, intercept
from planner.decision.interface import MATERIALS, Choice, DecisionContext, RobotState, TrackedItem
from planner.errors import PlannerInputError


@dataclass(frozen=True)
class Plan:
    """Best sequence found: item ids in pick order, its profit [EUR], nodes searched."""

    sequence: tuple[int, ...]
    profit: float
    nodes: int


def _segment_bounds(context: DecisionContext, item: TrackedItem, bin_class: int):
    """Lower bounds [s] on picking `item` from any bin and on placing it, over its window path.

    The minimum over 41 points of the item's path through the window, less 3 % for what the
    sampling could miss; inf when the item's y is never reachable.
    """
    bounds = context.window.bounds(item.y)
    if bounds is None:
        return math.inf, math.inf
    model, z = context.cycle_model, context.window.pick_z
    pick, place = math.inf, math.inf
    for px in [bounds[0] + (bounds[1] - bounds[0]) * k / 40 for k in range(41)]:
        point = (px, item.y, z)
        place = min(place, model.time_to_place(point, context.bin_of(bin_class)))
        for b in context.bins:
            pick = min(pick, model.time_to_pick(b, (px, item.y), 0.0))
    return 0.97 * pick, 0.97 * place


def _slot_bound(alive: list[int], values: list[float], exits: list[float], t: float, gap: float):
    """Most value the alive items can still earn if meetings are at least `gap` [s] apart.

    Meeting k (k = 0, 1, ...) happens no earlier than t + k gap and before the item leaves:
    unit jobs with deadlines, solved exactly by taking the most valuable first into the latest
    free slot.
    """
    last = {j: int((exits[j] - t) / gap) for j in alive}
    taken = [False] * (min(max(last.values()), len(alive)) + 1)
    total = 0.0
    for j in sorted(alive, key=lambda j: -values[j]):
        for k in range(min(last[j], len(taken) - 1), -1, -1):
            if not taken[k]:
                taken[k] = True
                total += values[j]
                break
    return total


def best_sequence(
    items: list[TrackedItem],
    values: list[float],
    bin_classes: list[int],
    robot: RobotState,
    context: DecisionContext,
) -> Plan:
    """The most profitable feasible pick order of `items` (positions at robot.time).

    Args:
        items: Items on the belt, x at robot.time [m].
        values: What picking each item earns [EUR] (true values for the bound).
        bin_classes: Bin each item goes to (2..4).
        robot: Start position and time.
        context: Belt speed, timing model, window, bins.
    """
    n = len(items)
    if not (len(values) == len(bin_classes) == n):
        raise PlannerInputError("values, bin_classes", "one per item", (len(values), n))
    v = context.belt_speed
    t0 = robot.time
    exits = [exit_time(context, t0, it.x, it.y) for it in items]
    lower = [_segment_bounds(context, it, c) for it, c in zip(items, bin_classes, strict=True)]
    gap = max(
        min((lb[0] for lb in lower), default=1.0) + min((lb[1] for lb in lower), default=1.0), 1e-3
    )
    seen: dict[tuple[int, int], float] = {}
    best = {"profit": 0.0, "end": math.inf, "seq": ()}
    nodes = 0

    def search(mask: int, pos: tuple, t: float, profit: float, seq: tuple, end: float):
        nonlocal nodes
        nodes += 1
        if profit > best["profit"] + 1e-12 or (
            abs(profit - best["profit"]) <= 1e-12 and end < best["end"]
        ):
            best.update(profit=profit, end=end, seq=seq)
        alive = [j for j in range(n) if not mask >> j & 1 and exits[j] > t and values[j] > 0]
        if not alive:
            return
        # Consecutive meetings are at least one place plus one pick apart.
        bound = profit + _slot_bound(alive, values, exits, t, gap)
        if bound <= best["profit"] + 1e-12:
            return
        children = []
        for j in range(n):
            if mask >> j & 1 or values[j] <= 0 or exits[j] <= t:
                continue
            y = items[j].y
            met = intercept(context, pos, t, items[j].x + v * (t - t0), y)
            if met is not None:
                k = MATERIALS.index(bin_classes[j])
                meet_xyz = (met[1], y, context.window.pick_z)
                end_j = met[0] + context.cycle_model.time_to_place(meet_xyz, context.bins[k])
                children.append((j, k, end_j))
        # Most valuable per second first: good sequences early make the bound cut more.
        children.sort(key=lambda c: -values[c[0]] / max(c[2] - t, 1e-6))
        for j, k, end_j in children:
            key = (mask | 1 << j, k)
            if seen.get(key, math.inf) <= end_j:
                continue
            seen[key] = end_j
            search(key[0], context.bins[k], end_j, profit + values[j], (*seq, j), end_j)

    search(0, robot.tcp, t0, 0.0, (), t0)
    return Plan(tuple(items[j].item_id for j in best["seq"]), best["profit"], nodes)


class OraclePlanner:
    """Replans the best sequence over the items in view at every decision; takes its first pick.

    With one-hot (truth) probabilities it plays the exact optimum of the items it sees; with
    class probabilities it optimises expected value. `max_items` caps the search (the most
    urgent feasible items are kept) because it is exponential in the worst case.
    """

    name = "oracle"

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
