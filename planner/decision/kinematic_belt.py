"""A kinematic belt for scoring decision managers without physics.

Items ride the belt at its speed; the robot takes its cycle times from the context's model,
carries each pick to the bin of the predicted class and decides again there; an item that
passes the reachable window unpicked is missed. The timing rules are those of
`planner.decision.candidates`, shared with the planners and the oracle, so profits are comparable
with `oracle.best_sequence` on the same belt.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import cast

import numpy as np

from perception.codes import N_STATES
from planner.decision.candidates import evaluate, exit_time
from planner.decision.interface import (
    MATERIALS,
    DecisionContext,
    DecisionManager,
    RobotState,
    TrackedItem,
)
from planner.decision.oracle import Plan, best_sequence
from planner.errors import PlannerError, PlannerInputError
from planner.motion.belt_speeds import SPEED_X1_MPS

THESIS_SPEED_X1 = SPEED_X1_MPS
# Items per class in the thesis's extreme-value runs (table 4.3, last row): 35 / 42 / 41.
THESIS_CLASS_SHARES = (35 / 118, 42 / 118, 41 / 118)
HOME_TCP = (0.0, 0.0, 0.10)


@dataclass(frozen=True)
class BeltItem:
    """An item of a belt: position at t = 0 [m], true class, what the tracker believes."""

    item_id: int
    x0: float
    y: float
    true_class: int
    class_probs: tuple[float, ...]


@dataclass(frozen=True)
class Belt:
    """Items on a belt moving at `speed` [m/s] along +x."""

    items: tuple[BeltItem, ...]
    speed: float


@dataclass(frozen=True)
class Pick:
    """One executed pick: times [s], classes, what it earned [EUR]."""

    item_id: int
    true_class: int
    bin_class: int
    decided: float
    meet: float
    end: float
    earned: float


@dataclass(frozen=True)
class BeltResult:
    """Outcome of one planner on one belt."""

    planner: str
    picks: tuple[Pick, ...]
    n_items: int
    decision_s: tuple[float, ...]

    @property
    def profit(self) -> float:
        """Sum earned [EUR] (a wrong bin earns nothing)."""
        return float(sum(p.earned for p in self.picks))

    def picked_of(self, class_code: int) -> int:
        """Items of true class `class_code` picked."""
        return sum(p.true_class == class_code for p in self.picks)


def one_hot(class_code: int) -> tuple[float, ...]:
    """Certain class probabilities (truth mode)."""
    return tuple(1.0 if k == class_code - 1 else 0.0 for k in range(N_STATES))


def random_belt(
    rng: np.random.Generator,
    n_items: int,
    length: float,
    speed: float,
    shares: tuple[float, float, float] = THESIS_CLASS_SHARES,
    start_x: float = -0.7,
    half_width: float = 0.35,
) -> Belt:
    """Items spread uniformly over `length` [m] of belt upstream of `start_x` [m], true classes."""
    if n_items < 0 or not (length > 0.0):
        raise PlannerInputError("n_items, length", "n_items >= 0 and length > 0 [m]")
    x0 = start_x - rng.uniform(0.0, length, n_items)
    y = rng.uniform(-half_width, half_width, n_items)
    classes = rng.choice(np.array(MATERIALS), size=n_items, p=np.array(shares) / sum(shares))
    items = tuple(
        BeltItem(i, float(x0[i]), float(y[i]), int(classes[i]), one_hot(int(classes[i])))
        for i in np.argsort(-x0, kind="stable")
    )
    return Belt(items, speed)


def simulate(
    planner: DecisionManager,
    belt: Belt,
    context: DecisionContext,
    start_tcp: tuple[float, float, float] = HOME_TCP,
    view_start: float = -1.5,
    idle_step: float = 0.05,
) -> BeltResult:
    """Run `planner` until every item is picked or lost; `context.belt_speed` must match."""
    if abs(context.belt_speed - belt.speed) > 1e-12:
        raise PlannerInputError("belt_speed", f"the belt's speed {belt.speed}", context.belt_speed)
    planner.reset()
    v, t, tcp = belt.speed, 0.0, cast(tuple[float, float, float], tuple(start_tcp))
    left = {it.item_id: it for it in belt.items}
    picks, latencies = [], []
    while True:
        for k in [k for k, it in left.items() if exit_time(context, t, it.x0 + v * t, it.y) <= t]:
            del left[k]
        if not left or math.isinf(t):
            break
        seen = [
            TrackedItem(it.item_id, it.x0 + v * t, it.y, it.class_probs)
            for it in left.values()
            if it.x0 + v * t >= view_start
        ]
        robot = RobotState(tcp, t)
        tic = time.perf_counter()
        choice = planner.choose(seen, robot, context) if seen else None
        latencies.append(time.perf_counter() - tic)
        if choice is None:
            if v <= 0.0:
                break
            t += idle_step
            continue
        item = left.pop(choice.item_id)
        tracked = next(s for s in seen if s.item_id == choice.item_id)
        cand = evaluate(context, tcp, t, tracked, choice.bin_class)
        if cand is None:
            raise PlannerError(f"{planner.name} chose item {choice.item_id}, which is out of reach")
        earned = context.value_of(item.true_class) if choice.bin_class == item.true_class else 0.0
        picks.append(
            Pick(
                item.item_id,
                item.true_class,
                choice.bin_class,
                t,
                cand.meet_time,
                cand.end_time,
                earned,
            )
        )
        t, tcp = cand.end_time, context.bin_of(choice.bin_class)
    return BeltResult(planner.name, tuple(picks), len(belt.items), tuple(latencies))


def oracle_bound(
    belt: Belt,
    context: DecisionContext,
    start_tcp: tuple[float, float, float] = HOME_TCP,
    max_nodes: int | None = None,
) -> Plan:
    """Best profit any pick sequence reaches on the belt's true classes (items known at t = 0).

    `Plan.bound` is an upper bound on every planner's profit on the belt: the exact best profit
    when the search finished (`Plan.exact`), else the relaxation of `oracle.slot_bound`
    (`max_nodes` caps the search; None searches to the end).
    """
    items = [TrackedItem(it.item_id, it.x0, it.y, one_hot(it.true_class)) for it in belt.items]
    values = [context.value_of(it.true_class) for it in belt.items]
    bins = [it.true_class for it in belt.items]
    return best_sequence(items, values, bins, RobotState(start_tcp, 0.0), context, max_nodes)
