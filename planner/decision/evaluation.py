"""Scoring decision managers on seeded random belts against the oracle's bound.

Experiments on the kinematic belt of `planner.decision.kinematic_belt`:

- `oracle_fractions`: many short belts (8-12 items, arrival rate 2-8 items/s, speed factors
  x1, x1.2, x1.5); on each, every planner's profit divided by the oracle's bound. The bound is
  exact (the best profit any pick sequence reaches on the true classes) when the oracle's
  search finishes within `ORACLE_MAX_NODES`, and the relaxation of
  `planner.decision.oracle.slot_bound` (an upper bound, not reached) on a belt too large for
  it; `OracleComparison.exact` says which, belt by belt. By default the belt is a snapshot of
  a busy stream (the first items already in the window, some about to leave); with front_x
  upstream of the window (e.g. -0.7 m) the robot sees the items arrive and can usually pick
  them all. Planners are tuned on `TUNING_SEEDS` and reported on `HELD_OUT_SEEDS`.
- `extreme_value_picks`: the thesis's table 4.3 in the planner alone: picks per class with the
  values of table 3.3 and with one class's value raised by 150.
- `objective_variants`: section 4.1.3, the three objectives of the Q-learning reward.

The long belts (118 items in 45 s, 2.6 items/s) load our robot about as the thesis's 118 items
in 90 s loaded its slower one: it picks 80-90 % of them at x1 (thesis table 4.3: 94 of 118).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import numpy as np

from planner.decision.interface import MATERIALS, THESIS_VALUES, DecisionContext
from planner.decision.kinematic_belt import (
    THESIS_SPEED_X1,
    Belt,
    oracle_bound,
    random_belt,
    simulate,
)
from planner.decision.registry import make_planner
from planner.motion.belt_speeds import SPEED_FACTORS

ContextFor = Callable[[float, tuple[float, float, float]], DecisionContext]

PLANNERS = ("qlearning", "rollout", "lookahead", "learned", "proximity", "fifo", "greedy")
"""The planners scored against the bound (the oracle planner reaches it on belts it sees whole)."""
TUNING_SEEDS = range(1000, 1200)
"""Belts the planners' parameters were chosen on."""
HELD_OUT_SEEDS = range(0, 200)
"""Belts the figures are reported on, disjoint from the tuning ones."""
ORACLE_MAX_NODES = 200_000
"""Nodes after which the oracle's search stops and the relaxation is the bound."""


def short_belt(seed: int, items=(8, 12), rate=(2.0, 8.0), front_x: float = 0.4) -> Belt:
    """A snapshot of a busy belt: item count, arrival rate [items/s] and speed factor drawn per
    seed; the items lie upstream of `front_x` [m], so the first ones are already in the window
    when the robot starts and some are about to leave it."""
    rng = np.random.default_rng(seed)
    speed = THESIS_SPEED_X1 * float(rng.choice(SPEED_FACTORS))
    n = int(rng.integers(items[0], items[1] + 1))
    length = n * speed / rng.uniform(*rate)
    return random_belt(rng, n, length, speed, start_x=front_x)


@dataclass(frozen=True)
class OracleComparison:
    """Per-belt profits [EUR] of each planner and the oracle's bound.

    Attributes:
        profits: (n_belts, n_planners) profit of each planner [EUR].
        bound: (n_belts,) upper bound on any planner's profit [EUR].
        exact: (n_belts,) True where the bound is the exact best profit, False where it is the
            relaxation.
        nodes: (n_belts,) nodes of the oracle's search.
    """

    planners: tuple[str, ...]
    profits: np.ndarray
    bound: np.ndarray
    exact: np.ndarray
    nodes: np.ndarray

    def bound_used(self) -> str:
        """Which bound the fractions are over, in one line."""
        n, k = self.exact.size, int(self.exact.sum())
        line = f"exact on {k} of {n} belts (search finished, at most {int(self.nodes.max())} nodes)"
        if k < n:
            line += f"; relaxation on {n - k} (search stopped at {ORACLE_MAX_NODES} nodes)"
        return line

    def fractions(self) -> np.ndarray:
        """(n_belts, n_planners) profit / bound."""
        return self.profits / self.bound[:, None]

    def summary(self) -> dict[str, tuple[float, float, float]]:
        """name -> (mean fraction, min fraction, total profit [EUR])."""
        f = self.fractions()
        return {
            name: (float(f[:, k].mean()), float(f[:, k].min()), float(self.profits[:, k].sum()))
            for k, name in enumerate(self.planners)
        }


def oracle_fractions(
    context_for: ContextFor,
    seeds,
    planners=PLANNERS,
    max_nodes: int | None = ORACLE_MAX_NODES,
    **belt_kw,
) -> OracleComparison:
    """Each planner's profit on `short_belt(seed, **belt_kw)` for every seed, and the oracle's
    bound (exact, or the relaxation past `max_nodes`)."""
    profits, bound, exact, nodes = [], [], [], []
    for seed in seeds:
        belt = short_belt(seed, **belt_kw)
        ctx = context_for(belt.speed, THESIS_VALUES)
        plan = oracle_bound(belt, ctx, max_nodes=max_nodes)
        bound.append(plan.bound)
        exact.append(plan.exact)
        nodes.append(plan.nodes)
        profits.append([simulate(make_planner(p), belt, ctx).profit for p in planners])
    return OracleComparison(
        tuple(planners),
        np.array(profits, dtype=float).reshape(len(bound), len(planners)),
        np.array(bound),
        np.array(exact, dtype=bool),
        np.array(nodes, dtype=int),
    )


def extreme_value_picks(
    context_for: ContextFor,
    planner: str,
    seeds,
    n_items: int = 118,
    duration_s: float = 45.0,
    boost: float = 150.0,
) -> dict[str, np.ndarray]:
    """Picks per true class (paper, plastic, aluminium), summed over seeds, for the normal
    values and for each class's value raised by `boost` [EUR] (x1 belt speed)."""
    variants = {"normal": THESIS_VALUES}
    for k, code in enumerate(MATERIALS):
        raised = list(THESIS_VALUES)
        raised[k] += boost
        variants[f"class {code} +{boost:g}"] = cast(tuple[float, float, float], tuple(raised))
    out = {name: np.zeros(3, dtype=int) for name in variants}
    for seed in seeds:
        belt = random_belt(
            np.random.default_rng(seed), n_items, duration_s * THESIS_SPEED_X1, THESIS_SPEED_X1
        )
        for name, values in variants.items():
            result = simulate(make_planner(planner), belt, context_for(belt.speed, values))
            out[name] += [result.picked_of(c) for c in MATERIALS]
    return out


def objective_variants(
    context_for: ContextFor,
    seeds,
    speed_factor: float = 1.0,
    n_items: int = 118,
    duration_s: float = 45.0,
    planner: str = "qlearning",
) -> dict[str, tuple[float, float]]:
    """Section 4.1.3 in the planner alone: `planner` (qlearning or rollout) with d = 1, v = 1 and
    v/d on the same belts; objective -> (mean share of items picked, mean profit per belt
    [EUR])."""
    speed = THESIS_SPEED_X1 * speed_factor
    out = {}
    for objective in ("d=1", "v=1", "v/d"):
        share, profit = [], []
        for seed in seeds:
            belt = random_belt(
                np.random.default_rng(seed), n_items, duration_s * THESIS_SPEED_X1, speed
            )
            result = simulate(
                make_planner(planner, objective=objective),
                belt,
                context_for(speed, THESIS_VALUES),
            )
            share.append(len(result.picks) / n_items)
            profit.append(result.profit)
        out[objective] = (float(np.mean(share)), float(np.mean(profit)))
    return out
