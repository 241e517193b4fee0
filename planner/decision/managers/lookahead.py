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

from planner.decision.candidates import candidates, choice_of
from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.oracle import SequenceSearch
from planner.errors import PlannerInputError

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
    """

    horizon: int = 10
    time_budget_s: float = 0.010
    max_evaluations: int | None = None
    hard_stop_s: float | None = None

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

    @property
    def evaluations(self) -> int:
        """Picks timed per decision: max_evaluations, or the time budget's worth."""
        if self.max_evaluations is not None:
            return self.max_evaluations
        return max(1, round(self.time_budget_s / SECONDS_PER_EVALUATION))


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
        cands = candidates(items, robot, context)[: cfg.horizon]
        if not cands:
            self._plan = ()
            return None
        search = SequenceSearch(
            [c.item for c in cands],
            [c.expected_value for c in cands],
            [c.bin_class for c in cands],
            robot,
            context,
        )
        search.seed_first_picks({j: c.end_time for j, c in enumerate(cands)})
        index = {c.item.item_id: j for j, c in enumerate(cands)}
        if self._plan:  # the rest of the last decision's order, as far as it still holds
            search.follow(tuple(index[i] for i in self._plan if i in index), budget)
        for j, c in enumerate(cands):  # the rollout over first in, first out
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
        return choice_of(
            first,
            f"first of {len(search.best_seq)} picks, {search.best_profit:.2f} EUR, over the "
            f"{len(cands)} most urgent items ({how}, {search.evaluations} picks timed)",
        )
