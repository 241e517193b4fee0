"""Exact search over pick sequences with time windows, and a relaxation bound when it is too big.

`best_sequence` is a depth-first branch and bound over sequences of picks. The state after a
pick is (set of items picked, bin the robot is at, time); profit depends only on the set, and
arriving earlier is never worse, so a state reached no earlier than before with the same set and
bin is cut. The timing rules are those of `planner.decision.candidates`, the ones the planners
and the belt simulator use, so on true classes the result bounds every planner's profit on the
same items.

What the result is (`Plan.exact`, `Plan.bound`):

- Exact: the search ran to its end (within `max_nodes`, if given): `profit` is the best profit
  any sequence reaches and `bound == profit`. Two facts it rests on: the pruning bound below is a
  relaxation (so it never cuts the optimum), and the dominance cut assumes a robot that leaves
  a bin earlier never meets an item later (the timing model's "first in, first out" property;
  it holds when the robot moves much faster than the belt, ~10 m/s against 0.28 m/s here).
- Relaxation: the search hit `max_nodes`: `profit` is the best sequence found (a lower bound)
  and `bound` is the relaxation's value at the start, an upper bound that needs neither the
  dominance cut nor a finished search.

The relaxation (`slot_bound`): every meeting with an item happens before the item leaves the
window, the first one no earlier than the least pick time from where the robot is, and
consecutive ones at least `gap` apart, gap = the least place time plus the least pick time
from a bin over the items. Dropping every other constraint leaves unit jobs with deadlines,
which taking the most valuable first into the latest free slot solves exactly. The times are
proven lower bounds (`pick_lower_bound`, `place_lower_bound`): for the project's cycle-time
models they are the models' formulas with the across-belt (y) and vertical distances only (a
move takes no less time when one axis's distance grows, so they hold wherever along the belt
the item is met); for any other `CycleTimeEstimator` they are 0, and the bound is the sum of the
values of the items that have not left the window.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from planner.decision.candidates import exit_time, intercept
from planner.decision.interface import DecisionContext, RobotState, TrackedItem
from planner.errors import PlannerInputError
from planner.motion.cycle_model import CycleTimeModel, jerk_limited_time
from planner.motion.straight_line_timing import StraightLineCycleModel

EXACT = "exact"
RELAXATION = "relaxation"


@dataclass(frozen=True)
class Plan:
    """Best sequence found and what is known of the best profit.

    Attributes:
        profit: Profit of `sequence` [EUR].
        nodes: Search nodes visited.
        bound: Upper bound on the best profit of any sequence [EUR]; equals `profit` when exact.
        exact: Whether the search finished, so that `profit` is the optimum.
        evaluations: Picks timed (an intercept and a place each).
    """

    sequence: tuple[int, ...]
    profit: float
    nodes: int
    bound: float = math.nan
    exact: bool = True
    evaluations: int = 0

    @property
    def bound_kind(self) -> str:
        """'exact' when the search finished, else 'relaxation'."""
        return EXACT if self.exact else RELAXATION


def _pick_place_bounds(model, pick_z: float):
    """(pick(start_xyz, y), place(y, bin_xyz)) lower bounds [s] of `model`, or None."""
    if isinstance(model, CycleTimeModel):
        lim = model.limits
        vel, acc, jerk = lim.tcp_velocity, lim.tcp_acceleration, lim.tcp_jerk

        def move(dy: float, dz: float) -> float:
            return max(jerk_limited_time(dy, vel, acc, jerk), jerk_limited_time(dz, vel, acc, jerk))

        def pick(start, y):
            dz = abs(start[2] - model.pick_z - model.approach_height) + model.approach_height
            c0, c1 = model.pick_coef
            return c0 + c1 * move(y - start[1], dz)

        def place(y, bin_xyz):
            dz = model.lift_height + abs(bin_xyz[2] - (pick_z + model.lift_height))
            c0, c1 = model.place_coef
            return model.seal_time + model.release_time + c0 + c1 * move(bin_xyz[1] - y, dz)

        return pick, place
    if isinstance(model, StraightLineCycleModel):

        def pick(start, y):
            return (
                model.move_time(math.hypot(y - start[1], start[2] - model.pick_z)) + model.vacuum_s
            )

        def place(y, bin_xyz):
            return model.move_time(math.hypot(bin_xyz[1] - y, bin_xyz[2] - pick_z)) + model.vacuum_s

        return pick, place
    return None


def pick_lower_bound(context: DecisionContext, start_xyz, y: float) -> float:
    """Proven lower bound [s] on the time from `start_xyz` (at rest) until the cup meets an item
    at `y` [m], wherever along the belt it is met.

    For `CycleTimeModel` and `StraightLineCycleModel` it is their formula without the along-belt
    distance (a move takes no less time when one axis's distance grows); 0 for any other
    estimator.
    """
    bounds = _pick_place_bounds(context.cycle_model, context.window.pick_z)
    return 0.0 if bounds is None else bounds[0](tuple(map(float, start_xyz)), float(y))


def place_lower_bound(context: DecisionContext, y: float, bin_class: int) -> float:
    """Proven lower bound [s] on the time from meeting an item at `y` [m] to the end of its
    release over the bin of `bin_class` (as `pick_lower_bound`; 0 for other estimators)."""
    bounds = _pick_place_bounds(context.cycle_model, context.window.pick_z)
    return 0.0 if bounds is None else bounds[1](float(y), context.bin_of(bin_class))


def slot_bound(
    alive: list[int], values: list[float], exits: list[float], t: float, gap: float
) -> float:
    """Most value the `alive` items can still earn if the first meeting is no earlier than t [s]
    and consecutive meetings are at least `gap` [s] apart.

    Meeting k (k = 0, 1, ...) happens no earlier than t + k gap and before the item leaves the
    window: unit jobs with deadlines, solved exactly by taking the most valuable first into the
    latest free slot. With gap 0 every item that has not left by t fits.
    """
    alive = [j for j in alive if exits[j] >= t]
    if not alive:
        return 0.0
    if gap <= 0.0:
        return float(sum(values[j] for j in alive))
    n = len(alive)
    last = {
        j: min(int((exits[j] - t) / gap), n - 1) if math.isfinite(exits[j]) else n - 1
        for j in alive
    }
    taken = [False] * n
    total = 0.0
    for j in sorted(alive, key=lambda j: -values[j]):
        for k in range(last[j], -1, -1):
            if not taken[k]:
                taken[k] = True
                total += values[j]
                break
    return total


class _Stop(Exception):
    """The search's budget is spent."""


class SequenceSearch:
    """Branch and bound over the pick orders of a fixed set of items (shared by `best_sequence`,
    the `seen_best` planner and the look-ahead planner).

    Args:
        items: Items on the belt, x at robot.time [m].
        values: What picking each item earns [EUR].
        bin_classes: Bin each item goes to (material class 2, 3, ...).
        robot: Start position and time.
        context: Belt speed, timing model, window, bins.
    """

    def __init__(
        self,
        items: list[TrackedItem],
        values: list[float],
        bin_classes: list[int],
        robot: RobotState,
        context: DecisionContext,
        time_price: float = 0.0,
    ):
        n = len(items)
        if not (math.isfinite(time_price) and time_price >= 0.0):
            raise PlannerInputError("time_price", "a price >= 0 [EUR/s]", time_price)
        self.time_price = float(time_price)
        if not (len(values) == len(bin_classes) == n):
            raise PlannerInputError("values, bin_classes", "one per item", (len(values), n))
        self.items, self.values, self.context = items, [float(v) for v in values], context
        self.bin_index = [c - 2 for c in bin_classes]
        self.t0, self.start = robot.time, robot.tcp
        self.exits = [exit_time(context, self.t0, it.x, it.y) for it in items]
        self.window = [context.window.bounds(it.y) for it in items]
        # Proven lower bounds: pick from the start (row 0) and from each bin (rows 1..3); place.
        lb = _pick_place_bounds(context.cycle_model, context.window.pick_z)
        starts = (self.start, *context.bins)
        if lb is None:
            self.pick_lb = [[0.0] * n for _ in starts]
            self.place_lb = [0.0] * n
        else:
            self.pick_lb = [[lb[0](s, it.y) for it in items] for s in starts]
            self.place_lb = [
                lb[1](it.y, context.bins[k]) for it, k in zip(items, self.bin_index, strict=True)
            ]
        from_bins = [min(row[j] for row in self.pick_lb[1:]) for j in range(n)]
        self.gap = max(min(from_bins, default=0.0) + min(self.place_lb, default=0.0), 0.0)
        self.by_value = sorted(
            (j for j in range(n) if self.values[j] > 0), key=lambda j: (-self.values[j], j)
        )
        self.nodes = 0
        self.evaluations = 0
        self._timed: dict[tuple[int, int, float], float | None] = {}
        self.best_seq: tuple[int, ...] = ()
        self.best_profit, self.best_end = 0.0, math.inf
        # The order's score: its profit less the robot's time at `time_price` [EUR/s]. At a
        # price the empty order is no candidate (the robot is never better off idle).
        self.best_score = 0.0 if self.time_price == 0.0 else -math.inf

    def bound(self, mask: int, where: int, t: float) -> float:
        """Upper bound on what the items not in `mask` can still earn, the robot free at t [s]
        at the start (`where` 0) or at bin `where` - 1: `slot_bound` with the first meeting no
        earlier than the least pick time from there (written out here: it runs at every node)."""
        exits, row = self.exits, self.pick_lb[where]
        alive = [j for j in self.by_value if not mask >> j & 1 and exits[j] > t]
        if not alive:
            return 0.0
        t1 = t + min(row[j] for j in alive)
        gap, n = self.gap, len(alive)
        taken = [False] * n
        total = 0.0
        for j in alive:  # most valuable first, into the latest free slot before it leaves
            e = exits[j]
            if e < t1:
                continue
            k = n - 1 if gap <= 0.0 or e == math.inf else min(int((e - t1) / gap), n - 1)
            while k >= 0 and taken[k]:
                k -= 1
            if k >= 0:
                taken[k] = True
                total += self.values[j]
        return total

    def relaxation(self) -> float:
        """Upper bound on the best profit from the start (`bound` with nothing picked)."""
        return self.bound(0, 0, self.t0)

    def pick_end(self, j: int, where: int, t: float) -> float | None:
        """When item j is released over its bin if the robot at the start (`where` 0) or at bin
        `where` - 1 goes for it at t [s], or None if it cannot be met. Each is timed once."""
        key = (j, where, t)
        if key in self._timed:
            return self._timed[key]
        self.evaluations += 1
        item, ctx = self.items[j], self.context
        pos = self.start if where == 0 else ctx.bins[where - 1]
        met = None
        if self.window[j] is not None:
            x = item.x + ctx.belt_speed * (t - self.t0)
            met = intercept(ctx, pos, t, x, item.y, self.window[j])
        end = None
        if met is not None:
            meet_xyz = (met[1], item.y, ctx.window.pick_z)
            end = met[0] + ctx.cycle_model.time_to_place(meet_xyz, ctx.bins[self.bin_index[j]])
        self._timed[key] = end
        return end

    def score(self, profit: float, end: float) -> float:
        """An order's score: its profit less its time from the start at `time_price` [EUR]."""
        if self.time_price == 0.0:
            return profit
        return profit - self.time_price * (end - self.t0)

    def offer(self, seq: tuple[int, ...], profit: float, end: float) -> None:
        """Keep `seq` if it scores more than the best so far (or as much, ending earlier)."""
        if not seq and self.time_price > 0.0:
            return
        score = self.score(profit, end)
        if score > self.best_score + 1e-12 or (
            abs(score - self.best_score) <= 1e-12 and end < self.best_end
        ):
            self.best_profit, self.best_end, self.best_seq = profit, end, seq
            self.best_score = score

    def seed_first_picks(self, ends: dict[int, float | None]) -> None:
        """Take the release times [s] of first picks already timed (None: cannot be met), e.g.
        by `planner.decision.candidates`; they count as timed, and each is offered alone."""
        for j, end in ends.items():
            if (j, 0, self.t0) not in self._timed:
                self._timed[(j, 0, self.t0)] = end
                self.evaluations += 1
            if end is not None:
                self.offer((j,), self.values[j], end)

    def follow(self, seq: tuple[int, ...], limit: int | None = None) -> None:
        """Time the picks of `seq` in order from the start, skipping those that cannot be met,
        finish first in, first out (`complete_in_exit_order`) and offer the result; no pick is
        timed once `evaluations` has reached `limit`."""
        done: tuple[int, ...]
        where, t, done = 0, self.t0, ()
        for j in seq:
            if limit is not None and self.evaluations >= limit:
                break
            if self.exits[j] <= t or self.values[j] <= 0:
                continue
            end = self.pick_end(j, where, t)
            if end is not None:
                done, t, where = (*done, j), end, 1 + self.bin_index[j]
        self.complete_in_exit_order(done, where, t, limit)

    def complete_in_exit_order(
        self, seq: tuple[int, ...], where: int, t: float, limit: int | None = None
    ) -> None:
        """Finish `seq` (the robot free at t [s] at `where`, as in `pick_end`) first in, first
        out: the item that leaves first among those that can still be met, and so on; offer
        the result. No pick is timed once `evaluations` has reached `limit`."""
        self.complete_in_order(seq, where, t, lambda j: (self.exits[j], j), limit)

    def complete_in_order(
        self, seq: tuple[int, ...], where: int, t: float, key, limit: int | None = None
    ) -> None:
        """Finish `seq` as `complete_in_exit_order`, trying the items left in the order of
        `key(j)` (smallest first)."""
        done = set(seq)
        profit = sum(self.values[j] for j in seq)
        order = sorted(
            (j for j in range(len(self.items)) if j not in done and self.values[j] > 0), key=key
        )
        for j in order:
            if limit is not None and self.evaluations >= limit:
                break
            if self.exits[j] <= t:
                continue
            end = self.pick_end(j, where, t)
            if end is None:
                continue
            seq, profit, t, where = (*seq, j), profit + self.values[j], end, 1 + self.bin_index[j]
        self.offer(seq, profit, t)

    def complete_greedily(
        self, seq: tuple[int, ...], where: int, t: float, steps: int, limit: int | None = None
    ) -> None:
        """Extend `seq` (the robot free at t [s] at `where`, as in `pick_end`) by up to `steps`
        picks, each the one that adds most to the score from where the robot is (its value less
        its time from now at `time_price`), offering every order on the way. No pick is timed
        once `evaluations` has reached `limit`."""
        done = set(seq)
        profit = sum(self.values[j] for j in seq)
        for _ in range(steps):
            best = None
            for j in range(len(self.items)):
                if j in done or self.values[j] <= 0 or self.exits[j] <= t:
                    continue
                if limit is not None and self.evaluations >= limit:
                    if (j, where, t) not in self._timed:
                        continue
                end = self.pick_end(j, where, t)
                if end is None:
                    continue
                gain = self.values[j] - self.time_price * (end - t)
                if best is None or gain > best[0]:
                    best = (gain, j, end)
            if best is None:
                break
            _, j, t = best
            done.add(j)
            seq, profit, where = (*seq, j), profit + self.values[j], 1 + self.bin_index[j]
            self.offer(seq, profit, t)

    def run(
        self,
        max_nodes: int | None = None,
        max_evaluations: int | None = None,
        deadline: float | None = None,
    ) -> bool:
        """Search from the start; True if it finished, False if a budget stopped it.

        Children are timed one at a time, most valuable per second of lower-bound cycle first,
        and a node stops expanding once its bound no longer beats the best order found.

        Args:
            max_nodes: Most nodes to visit.
            max_evaluations: Most picks to time (deterministic, as max_nodes).
            deadline: `time.thread_time()` [s] past which the search stops.
        """
        n, values, exits = len(self.items), self.values, self.exits
        place_lb, pick_lb, bin_index = self.place_lb, self.pick_lb, self.bin_index
        seen: dict[tuple[int, int], float] = {}

        def search(mask: int, where: int, t: float, profit: float, seq: tuple):
            self.nodes += 1
            if (max_nodes is not None and self.nodes > max_nodes) or (
                deadline is not None and time.thread_time() > deadline
            ):
                raise _Stop
            self.offer(seq, profit, t)
            # Later picks end later: the time already spent is a lower bound on the order's.
            ub = self.score(profit, t) + self.bound(mask, where, t)
            if ub <= self.best_score + 1e-12:
                return
            row = pick_lb[where]
            order = sorted(
                (j for j in range(n) if not mask >> j & 1 and exits[j] > t and values[j] > 0),
                key=lambda j: (-values[j] / max(row[j] + place_lb[j], 1e-6), exits[j], j),
            )
            for j in order:
                if ub <= self.best_score + 1e-12:
                    return
                if (j, where, t) not in self._timed and (
                    max_evaluations is not None and self.evaluations >= max_evaluations
                ):
                    raise _Stop
                end = self.pick_end(j, where, t)
                if end is None:
                    continue
                k = 1 + bin_index[j]
                key = (mask | 1 << j, k)
                if seen.get(key, math.inf) <= end:
                    continue
                seen[key] = end
                search(key[0], k, end, profit + values[j], (*seq, j))

        try:
            search(0, 0, self.t0, 0.0, ())
        except _Stop:
            return False
        return True

    def plan(self, finished: bool) -> Plan:
        """The result so far (`finished`: whether `run` returned True)."""
        bound = self.best_profit if finished else max(self.relaxation(), self.best_profit)
        return Plan(
            tuple(self.items[j].item_id for j in self.best_seq),
            self.best_profit,
            self.nodes,
            bound,
            finished,
            self.evaluations,
        )


def best_sequence(
    items: list[TrackedItem],
    values: list[float],
    bin_classes: list[int],
    robot: RobotState,
    context: DecisionContext,
    max_nodes: int | None = None,
) -> Plan:
    """The most profitable feasible pick order of `items` (positions at robot.time).

    Args:
        items: Items on the belt, x at robot.time [m].
        values: What picking each item earns [EUR] (true values for the bound).
        bin_classes: Bin each item goes to (material class 2, 3, ...).
        robot: Start position and time.
        context: Belt speed, timing model, window, bins.
        max_nodes: Stop after this many nodes (None: search to the end). A stopped search
            returns its best sequence and the relaxation bound (`Plan.exact` False).
    """
    if max_nodes is not None and (
        isinstance(max_nodes, bool) or not isinstance(max_nodes, int) or max_nodes < 1
    ):
        raise PlannerInputError("max_nodes", "an integer >= 1 or None", max_nodes)
    search = SequenceSearch(items, values, bin_classes, robot, context)
    return search.plan(search.run(max_nodes=max_nodes))
