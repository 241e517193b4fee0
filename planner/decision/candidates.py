"""Which items can still be picked, when the cup would meet them, and what each pick costs.

Every planner and the belt simulator share these rules, so the oracle's bound is computed on the
same physics the planners are scored on:

- The cup meets an item where the item will be when the cup arrives (the cycle-time model's
  `time_to_pick`); if that point is still upstream of the reachable window, the robot waits
  for the item at the window's entry.
- A meeting point past the window's downstream edge means the item is lost: not a candidate.
- After the pick the robot carries the item to the bin of its most probable class
  (`time_to_place`), where it is when the next decision is due.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem


@dataclass(frozen=True)
class Candidate:
    """A feasible pick evaluated from the robot's state.

    Attributes:
        expected_value: p(bin class) * value(bin class) [EUR], net of the pick's energy cost
            when the context prices energy (`DecisionContext.net_value`).
        bin_class: Destination class (2..4).
        meet_time: Time the cup meets the item [s].
        meet_xy: Where the item is then [m].
        end_time: Time the item is released over its bin [s].
        exit_time: Time the item would leave the reachable window [s].
        start_time: Decision time these times are counted from [s].
        waits: Whether the robot must wait at the window's entry for the item.
    """

    item: TrackedItem
    expected_value: float
    bin_class: int
    meet_time: float
    meet_xy: tuple[float, float]
    end_time: float
    exit_time: float
    start_time: float
    waits: bool = False

    @property
    def cycle_s(self) -> float:
        """Decision to release, waiting included [s]."""
        return self.end_time - self.start_time


def intercept(
    context: DecisionContext,
    start_xyz,
    t0: float,
    x: float,
    y: float,
    bounds: tuple[float, float] | None = None,
) -> tuple[float, float, bool] | None:
    """Earliest meeting with an item at (x, y) at time t0, or None if it is lost.

    `bounds` is the window's (entry, exit) x at y [m] when the caller has it already
    (`context.window.bounds(y)`, which must not be None).

    Returns:
        (meet_time [s], meet_x [m], waits): waits is True when the robot must wait at the
        window's entry for the item.
    """
    if bounds is None:
        bounds = context.window.bounds(y)
        if bounds is None:
            return None
    x_in, x_out = bounds
    if x > x_out:
        return None
    v = context.belt_speed
    dt = context.cycle_model.time_to_pick(start_xyz, (x, y), v)
    x_meet = x + v * dt
    if x_meet < x_in:
        if v <= 0.0:
            return None
        return t0 + (x_in - x) / v, x_in, True
    if x_meet > x_out:
        return None
    return t0 + dt, x_meet, False


def exit_time(context: DecisionContext, t0: float, x: float, y: float) -> float:
    """When an item at (x, y) at t0 passes the window's downstream edge [s].

    inf on a stopped belt; t0 for a y the cup never reaches.
    """
    bounds = context.window.bounds(y)
    if bounds is None:
        return t0
    v = context.belt_speed
    return t0 + (bounds[1] - x) / v if v > 0.0 else math.inf


def evaluate(
    context: DecisionContext,
    start_xyz,
    t0: float,
    item: TrackedItem,
    bin_class: int | None = None,
    expected_value: float | None = None,
    with_place: bool = True,
) -> Candidate | None:
    """One item's pick from `start_xyz` at time t0 (item.x is its position at t0), or None.

    Without `with_place` the place is not timed (end_time is nan): for planners that never
    look at it, as the place time is a third of a candidate's cost.
    """
    met = intercept(context, start_xyz, t0, item.x, item.y)
    if met is None:
        return None
    meet_time, meet_x, waits = met
    c = item.bin_class if bin_class is None else bin_class
    ev = context.expected_value(item) if expected_value is None else expected_value
    bin_xyz = context.bin_of(c)
    if context.energy.price_eur_per_kwh > 0.0:
        distance = math.dist(start_xyz[:2], (meet_x, item.y)) + math.dist(
            (meet_x, item.y), bin_xyz[:2]
        )
        ev = float(context.net_value(ev, distance))
    end = math.nan
    if with_place:
        meet_xyz = (meet_x, item.y, context.window.pick_z)
        end = meet_time + context.cycle_model.time_to_place(meet_xyz, bin_xyz)
    return Candidate(
        item=item,
        expected_value=ev,
        bin_class=c,
        meet_time=meet_time,
        meet_xy=(meet_x, item.y),
        end_time=end,
        exit_time=exit_time(context, t0, item.x, item.y),
        start_time=t0,
        waits=waits,
    )


def candidates(
    items: list[TrackedItem],
    robot: RobotState,
    context: DecisionContext,
    immediate_only: bool = False,
    with_place: bool = True,
) -> list[Candidate]:
    """Feasible picks worth something (expected value > 0, net of the energy cost when the
    context prices it), most urgent (earliest exit) first.

    With `immediate_only`, items the robot would have to wait for at the window's entry are
    left out: planners blind to time use it so they never commit to idling for an item while
    others pass (they decide again once it has entered the window). `with_place`: see
    `evaluate`.
    """
    out = []
    for item in items:
        if context.expected_value(item) <= 0.0:
            continue
        cand = evaluate(context, robot.tcp, robot.time, item, with_place=with_place)
        if cand is not None and cand.expected_value > 0.0:
            out.append(cand)
    out.sort(key=lambda c: (c.exit_time, c.item.item_id))
    if immediate_only:
        out = [c for c in out if not c.waits]
    return out


def choice_of(cand: Candidate, reason: str) -> Choice:
    """The Choice that picks `cand`."""
    return Choice(
        item_id=cand.item.item_id,
        expected_value=cand.expected_value,
        meet_time=cand.meet_time,
        bin_class=cand.bin_class,
        reason=reason,
    )
