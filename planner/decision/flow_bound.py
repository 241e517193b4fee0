"""An upper bound, under the cycle-time model, on the profit any pick order can earn on a whole
known flow.

It bounds every order a robot that keeps to the cycle-time model's least times could play; it
is not proven for the physics' robot, which may move faster than the model somewhere (the
times can be scaled down by a measured ratio, `scale`, and every physics run is checked against
it: `sim.evaluation.flow_bound.time_scale`, `tests/test_flow_bound.py`).

The relaxation keeps two facts of every pick a single robot makes and drops everything else:

- the cup meets item j inside its reach window: no earlier than r_j, when the item enters the
  window, and no later than d_j, when it leaves it (`reach_windows`, from the item's position
  at t = 0 and the belt's speed, widened by a margin on both sides);
- between meeting item k and meeting the next item m lie at least P_k + K_m: P_k the least
  time from meeting k to releasing it over its bin, K_m the least time from any bin to meeting
  m (`pick_place_times`: the lower bounds the oracle's relaxation uses,
  `planner.decision.oracle.pick_lower_bound` and `place_lower_bound`, with the pauses of the
  context's cycle model inside them, times `scale` <= 1 where physics was measured faster).

Then for any interval [a, b], the items S met whose windows lie inside it satisfy
sum over S of (P_k + K_k) <= (b - a) + max P + max K (the first meeting's K and the last's P
fall outside), and they number at most floor((b - a) / gap) + 1, gap = min P + min K.
`interval_bound` maximises the value picked, each item taken by a fraction in [0, 1], under
both for every interval from a window's start to a window's end at most `span_s` later (a
linear programme, scipy's HiGHS). Every constraint holds for every order feasible under the
model, so the optimum bounds every such order's profit; dropping constraints only loosens it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.decision.interface import DecisionContext
from planner.decision.oracle import pick_lower_bound, place_lower_bound
from planner.errors import PlannerInputError

WINDOW_MARGIN_M = 0.05
"""Each reach window is widened by this much upstream and downstream [m]: an item in physics
rides a little off its nominal place (bumps, settling), and a wider window only loosens the
bound."""
SPAN_S = 30.0
"""Longest interval whose capacity is a constraint [s]; longer ones add little."""


@dataclass(frozen=True)
class FlowBound:
    """The bound on one flow.

    Attributes:
        bound: Most any pick order can earn under the cycle-time model [EUR].
        reachable_value: Value of the items the robot can reach at all [EUR] (no time limit).
        gap_s: Least time between two meetings used [s].
        constraints: Interval constraints that cut something.
    """

    bound: float
    reachable_value: float
    gap_s: float
    constraints: int


def reach_windows(
    context: DecisionContext,
    x0: np.ndarray,
    y: np.ndarray,
    margin_m: float = WINDOW_MARGIN_M,
) -> tuple[np.ndarray, np.ndarray]:
    """(release, deadline) [s] of each item: when its centre, at x0 [m] at t = 0 and riding at
    the belt's speed, enters and leaves the reach window at its y [m], widened by `margin_m`;
    (nan, nan) where the window does not reach its y."""
    v = context.belt_speed
    if not v > 0.0:
        raise PlannerInputError("belt_speed", "> 0 m/s for a flow's windows", v)
    release = np.full(len(x0), np.nan)
    deadline = np.full(len(x0), np.nan)
    for j, (x, yj) in enumerate(zip(x0, y, strict=True)):
        bounds = context.window.bounds(float(yj))
        if bounds is not None:
            release[j] = (bounds[0] - margin_m - x) / v
            deadline[j] = (bounds[1] + margin_m - x) / v
    return release, deadline


def pick_place_times(
    context: DecisionContext, y: np.ndarray, bin_classes: np.ndarray, scale: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """(K, P) [s] of each item at y [m]: the least time from any bin to meeting it, and from
    meeting it to its release over the bin of its class, wherever along the belt it is met,
    times `scale`."""
    pick = np.array(
        [min(pick_lower_bound(context, b, float(yj)) for b in context.bins) for yj in y]
    )
    place = np.array(
        [
            place_lower_bound(context, float(yj), int(c))
            for yj, c in zip(y, bin_classes, strict=True)
        ]
    )
    return scale * pick, scale * place


def _capacity_rows(release, deadline, busy, gap: float, slack: float, span_s: float):
    """The interval constraints that cut, as (items, weights, capacity): for each interval from
    a window's start to a window's end at most `span_s` later, the meetings' count and their
    busy times (module docstring)."""
    by_deadline = np.argsort(deadline, kind="stable")
    rows: list[tuple[tuple[int, ...], tuple[float, ...] | None, float]] = []
    for a in np.unique(release):
        inside: list[int] = []
        used = 0.0
        for k in by_deadline:
            b = deadline[k]
            if b - a > span_s:
                break
            if release[k] < a:
                continue
            inside.append(int(k))
            used += busy[k]
            cap = math.floor((b - a) / gap + 1e-9) + 1 if gap > 0.0 else len(inside)
            if len(inside) > cap:
                rows.append((tuple(inside), None, float(cap)))
            if used > (b - a) + slack:
                rows.append((tuple(inside), tuple(float(x) for x in busy[inside]), (b - a) + slack))
    return rows


def interval_bound(
    release: np.ndarray,
    deadline: np.ndarray,
    values: np.ndarray,
    pick_s: np.ndarray,
    place_s: np.ndarray,
    span_s: float = SPAN_S,
) -> FlowBound:
    """The most value a single robot can pick (module docstring): items with a window (finite
    release) and a value > 0, met inside their windows, pick_s (K) and place_s (P) [s] as
    `pick_place_times`.

    Raises:
        PlannerInputError: arrays of different lengths, times not finite and >= 0, a span
            not > 0, or the linear programme fails.
    """
    from scipy.optimize import linprog
    from scipy.sparse import csr_matrix

    release, deadline = np.asarray(release, float), np.asarray(deadline, float)
    values = np.asarray(values, float)
    pick_s, place_s = np.asarray(pick_s, float), np.asarray(place_s, float)
    if not (len(release) == len(deadline) == len(values) == len(pick_s) == len(place_s)):
        raise PlannerInputError("release, deadline, values, times", "one per item", len(values))
    times = np.concatenate([pick_s, place_s])
    if not (np.all(np.isfinite(times)) and np.all(times >= 0.0) and span_s > 0.0):
        raise PlannerInputError("pick_s, place_s, span_s", "times >= 0 [s], span > 0 [s]", span_s)
    keep = np.isfinite(release) & np.isfinite(deadline) & (values > 0.0)
    r, d, w = release[keep], deadline[keep], values[keep]
    k_s, p_s = pick_s[keep], place_s[keep]
    total = float(w.sum())
    if not len(w):
        return FlowBound(0.0, 0.0, 0.0, 0)
    gap = float(p_s.min() + k_s.min())
    rows = _capacity_rows(r, d, k_s + p_s, gap, float(p_s.max() + k_s.max()), span_s)
    if not rows:
        return FlowBound(total, total, gap, 0)
    cols = [k for items, _, _ in rows for k in items]
    data = [x for items, wts, _ in rows for x in (wts if wts is not None else [1.0] * len(items))]
    starts = [i for i, (items, _, _) in enumerate(rows) for _ in items]
    a_ub = csr_matrix((np.array(data), (starts, cols)), shape=(len(rows), len(w)))
    b_ub = np.array([cap for _, _, cap in rows], dtype=float)
    result = linprog(-w, A_ub=a_ub, b_ub=b_ub, bounds=(0.0, 1.0), method="highs")
    if result.status != 0:
        raise PlannerInputError("interval_bound", "a solved linear programme", result.message)
    return FlowBound(float(-result.fun), total, gap, len(rows))
