"""Receding-horizon sequencing: a budgeted branch and bound over the items in view, replanned at
every decision (ours; not in the thesis).

At each decision the feasible picks (`planner.decision.candidates`, the clock every planner and
the belt simulator share) are sorted by when they leave the reachable window and the `horizon`
most urgent are kept. Over them the planner searches pick orders with their time windows, in
the manner of the branch-and-bound and dynamic-programming sequencing of picks on a conveyor
(Han, Feng, Yu): an item can only be met before it leaves the window, the robot is at the bin
of its last pick when the next one starts, and a partial order is cut when its profit plus a
relaxation (`planner.decision.oracle.slot_bound`) cannot beat the best order found, or when the
same set of items was already picked, ending at the same bin no later
(`planner.decision.oracle.SequenceSearch`, the oracle's search).

Before searching it offers the search two orders: the rest of the order it chose at the last
decision (the items it still holds, then first in, first out), and the rollout over first in,
first out (each first pick finished by taking the item that leaves first among those still
reachable). The best of these is the incumbent: on its model and over the horizon's items, the
order it plays is worth at least the best one-step rollout over FIFO (when the budget covers
the rollouts, as the default does: about a third of it). It plays the first pick of the best
order found; the rest is replanned at the next decision with the items seen since.

Saturated belts. The tables' dense datasets in physics keep more items in reach than the robot
can take (300-400 items: it picks 63-84 % of them); there the robot's time, not the items'
deadlines, limits the profit, and the values of the three materials differ little (0.22-0.27
EUR), so what counts is picks per second. With more feasible items than `SATURATED` horizons
(`horizon_of`) the planner prices the robot's time (`time_price_quantile` of the candidates'
expected value per second of cycle) and, instead of the branch and bound, plays greedy
rollouts: from each of the `saturated_starts` first picks that add most (value less priced
time), `saturated_steps` picks, each the one that adds most from where the robot then is
(`SequenceSearch.complete_greedily`), over the `saturated_horizon` most urgent items and the
`saturated_horizon` the cup meets soonest; the first pick of the best-scoring order is played.
The branch and bound, given the same priced score, chose worse orders on these belts: over a
finite set of items the priced score favours orders that end early and leave the robot where
the next items are not, and it cost 3-6 % of the profit against the rollouts on the kinematic
belt with the tuning seeds (1000-1002). The busy belts of the planner-level benchmark (8-12
items) never reach the threshold. Parameters chosen on tuning seeds 1000-1002 of the four dense
datasets on the kinematic belt (`planner.decision.kinematic_belt`, whose cycle times the
physics' picks match: `sim.episode.cycle_timing`).

Budget. Besides the one timing of every item in view that gives the candidates (as every
planner makes), the planner times at most `max_evaluations` picks per decision (an intercept
and a place on the cycle-time model, the bulk of the work; the horizon's first picks count
among them), a count, so that the choice does not depend on the machine's speed or load. By
default the count is `time_budget_s` (10 ms) over `SECONDS_PER_EVALUATION`, the 99th
percentile of the CPU time per pick timed, search included, with 30 items in view, measured by
`benchmarks/bench_decision.py`, which prints the latencies this gives. `hard_stop_s` adds a
guard on the decision's CPU time that stops the search whatever the count, for a controller
that must never be late; it is off by default, since the choice then depends on the machine.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from planner.decision.candidates import Candidate, candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.oracle import SequenceSearch
from planner.errors import PlannerInputError

SATURATED = 1.5
"""More feasible items than this times the horizon make a saturated belt (`horizon_of`)."""
SECONDS_PER_EVALUATION = 33e-6
"""CPU time per pick timed, search included, 99th percentile with 30 items in view [s]."""


def _positive_time(value) -> bool:
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value > 0.0
    )


@dataclass(frozen=True)
class LookaheadConfig:
    """Parameters of the look-ahead planner.

    Attributes:
        horizon: Most urgent feasible items searched over (>= 1).
        time_budget_s: Budget of one decision [s] (> 0), turned into `evaluations`.
        max_evaluations: Picks timed per decision (>= 1); None: time_budget_s /
            SECONDS_PER_EVALUATION.
        hard_stop_s: CPU time [s] after which the search stops whatever the count (> 0), or
            None (default: results do not depend on the machine).
        saturated_horizon: On a saturated belt, most urgent and soonest met items each (>= 1).
        saturated_starts: On a saturated belt, first picks rolled out (>= 1).
        saturated_steps: On a saturated belt, picks per rollout after the first (>= 0).
        time_price_quantile: On a saturated belt, the price of the robot's time is this
            quantile of the candidates' expected value per second of cycle (0..1).
    """

    horizon: int = 10
    time_budget_s: float = 0.010
    max_evaluations: int | None = None
    hard_stop_s: float | None = None
    saturated_horizon: int = 6
    saturated_starts: int = 6
    saturated_steps: int = 8
    time_price_quantile: float = 0.7

    def __post_init__(self):
        if isinstance(self.horizon, bool) or not isinstance(self.horizon, int) or self.horizon < 1:
            raise PlannerInputError("horizon", "an integer >= 1", self.horizon)
        if not _positive_time(self.time_budget_s):
            raise PlannerInputError("time_budget_s", "a time > 0 [s]", self.time_budget_s)
        m = self.max_evaluations
        if m is not None and (isinstance(m, bool) or not isinstance(m, int) or m < 1):
            raise PlannerInputError("max_evaluations", "an integer >= 1 or None", m)
        if self.hard_stop_s is not None and not _positive_time(self.hard_stop_s):
            raise PlannerInputError("hard_stop_s", "a time > 0 [s] or None", self.hard_stop_s)
        counts = (("saturated_horizon", 1), ("saturated_starts", 1), ("saturated_steps", 0))
        for name, least in counts:
            n = getattr(self, name)
            if isinstance(n, bool) or not isinstance(n, int) or n < least:
                raise PlannerInputError(name, f"an integer >= {least}", n)
        q = self.time_price_quantile
        if isinstance(q, bool) or not isinstance(q, int | float) or not 0.0 <= q <= 1.0:
            raise PlannerInputError("time_price_quantile", "a number in 0..1", q)

    @property
    def evaluations(self) -> int:
        """Picks timed per decision: max_evaluations, or the time budget's worth."""
        if self.max_evaluations is not None:
            return self.max_evaluations
        return max(1, round(self.time_budget_s / SECONDS_PER_EVALUATION))


def horizon_of(
    cands: list[Candidate], horizon: int, saturated_horizon: int = 6, quantile: float = 0.7
) -> tuple[list[Candidate], float]:
    """The candidates searched over and the price of the robot's time [EUR/s].

    On a busy belt the `horizon` most urgent feasible items are searched and time is free: the
    order that earns most wins. On a saturated belt, more than `SATURATED` times `horizon`
    items in reach (a queue the robot cannot clear: the dense datasets of tables 4.5 and 4.6
    in physics, not the planner-level benchmark's busy belts of 8-12 items), every second the
    robot spends is taken from items it will leave: the search then takes the
    `saturated_horizon` most urgent items and the `saturated_horizon` the cup meets soonest,
    and prices the robot's time at the `quantile` of the candidates' expected value over cycle
    time, so that a long chase after an item about to leave is worth its value less the picks
    it costs.
    """
    if len(cands) <= SATURATED * horizon:
        return cands[:horizon], 0.0
    k = saturated_horizon
    soonest = sorted(cands, key=lambda c: (c.meet_time, c.item.item_id))[:k]
    chosen = {c.item.item_id for c in cands[:k]} | {c.item.item_id for c in soonest}
    rates = sorted(c.expected_value / max(c.cycle_s, 1e-3) for c in cands)
    rate = float(np.quantile(rates, quantile))
    return [c for c in cands if c.item.item_id in chosen], rate


class LookaheadPlanner:
    """First pick of the best pick order found over the most urgent items within the budget."""

    name = "lookahead"

    def __init__(self, config: LookaheadConfig | None = None):
        self.config = config or LookaheadConfig()
        self._plan: tuple[int, ...] = ()

    def reset(self) -> None:
        """Forget the last decision's order (start of an episode)."""
        self._plan = ()

    def choose(
        self, items: list[TrackedItem], robot: RobotState, context: DecisionContext
    ) -> Choice | None:
        """The first pick of the best order found over the `horizon` most urgent feasible
        items."""
        cfg = self.config
        tic = time.thread_time()
        budget = cfg.evaluations
        cands, time_price = horizon_of(
            candidates(items, robot, context),
            cfg.horizon,
            cfg.saturated_horizon,
            cfg.time_price_quantile,
        )
        if not cands:
            self._plan = ()
            return None
        search = SequenceSearch(
            [c.item for c in cands],
            [c.expected_value for c in cands],
            [c.bin_class for c in cands],
            robot,
            context,
            time_price=time_price,
        )
        search.seed_first_picks({j: c.end_time for j, c in enumerate(cands)})
        if time_price > 0.0:
            return self._saturated(search, cands, time_price, budget)
        index = {c.item.item_id: j for j, c in enumerate(cands)}
        if self._plan:  # the rest of the last decision's order, as far as it still holds
            search.follow(tuple(index[i] for i in self._plan if i in index), budget)
        for j, c in enumerate(cands):  # the rollout over FIFO
            left = budget - search.evaluations
            if left <= 0:
                break
            search.complete_in_exit_order((j,), 1 + search.bin_index[j], c.end_time, left)
        deadline = None if cfg.hard_stop_s is None else tic + cfg.hard_stop_s
        finished = search.evaluations < budget and search.run(
            max_evaluations=budget, deadline=deadline
        )
        if not search.best_seq:
            self._plan = ()
            return None
        first = cands[search.best_seq[0]]
        self._plan = tuple(cands[j].item.item_id for j in search.best_seq[1:])
        how = "optimal over them" if finished else "budget spent"
        searched = f"the {len(cands)} most urgent items"
        return choice_of(
            first,
            f"first of {len(search.best_seq)} picks, {search.best_profit:.2f} EUR, over "
            f"{searched} ({how}, {search.evaluations} picks timed)",
        )

    def _saturated(
        self, search: SequenceSearch, cands: list[Candidate], time_price: float, budget: int
    ) -> Choice | None:
        """Greedy rollouts at a priced time from the first picks that add most."""
        cfg = self.config
        self._plan = ()
        firsts = sorted(
            range(len(cands)),
            key=lambda j: (-(cands[j].expected_value - time_price * cands[j].cycle_s), j),
        )
        for j in firsts[: cfg.saturated_starts]:
            search.complete_greedily(
                (j,), 1 + search.bin_index[j], cands[j].end_time, cfg.saturated_steps, budget
            )
        if not search.best_seq:
            return None
        return choice_of(
            cands[search.best_seq[0]],
            f"first of {len(search.best_seq)} picks, {search.best_profit:.2f} EUR, greedy "
            f"rollouts over {len(cands)} most urgent and soonest met items at "
            f"{time_price:.2f} EUR/s ({search.evaluations} picks timed"
            f"{', budget spent' if search.evaluations >= budget else ''})",
        )
