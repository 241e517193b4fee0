"""Meeting a moving item: where and when the cup lands on it at the belt's velocity.

An item now at (x0, y) rides the belt at `belt_speed` along +x, so at time T it is at
x0 + belt_speed T. The cup must touch it at T with the belt's velocity (ruckig's target
velocity), so T solves T = D(T), D being the duration of the approach-and-descend chain to where
the item will be at T. We scan T on a grid with the cheap rest-corner duration, bracket the
first T with D(T) <= T, and bisect it with the blended duration. The pick is then planned to
arrive exactly at T (ruckig's minimum duration stretches the descent). An item that leaves the
reachable window (contact, approach, seal and lift points all reachable) before it can be met
is refused with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.blending import search_corners
from planner.errors import PlannerInputError
from planner.kinematics import DeltaGeometry, reachable_mask
from planner.pick_cycle import PickPlaceConfig, PickPlan, pick_place_waypoints, plan_pick_place
from planner.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.trajectory import State

SCAN_DT = 0.02
"""Grid step of the meeting-time scan [s]."""

TIME_TOL = 2e-3
"""Bisection tolerance on the meeting time [s]: the pick is then planned to arrive exactly at the
bracket's upper end, so this only trades a few ms of waiting for planning time."""

HORIZON = 10.0
"""Longest wait considered for an item upstream of the window [s]."""


@dataclass(frozen=True, eq=False)
class Intercept:
    """The answer for one item.

    Attributes:
        feasible: Whether the item can be met inside the reachable window.
        reason: Why not (empty when feasible).
        meet_time: When the cup touches the item, from now [s] (nan when refused).
        pick_xyz: Where it touches it [m] (nan when refused).
        plan: The planned pick and place (None when refused or not requested).
    """

    feasible: bool
    reason: str
    meet_time: float
    pick_xyz: np.ndarray
    plan: PickPlan | None = None


def _refuse(reason: str) -> Intercept:
    return Intercept(False, reason, float("nan"), np.full(3, np.nan))


def window_mask(geom, xs, y, pick_z, belt_speed, config: PickPlaceConfig) -> np.ndarray:
    """Whether an item met at each x of `xs` [m] has its contact, approach, seal-end and lift
    points inside the workspace."""
    xs = np.asarray(xs, dtype=float)
    seal = belt_speed * config.seal_time
    pts = []
    for dx, dz in (
        (0.0, 0.0),
        (0.0, config.approach_height),
        (seal, 0.0),
        (seal, config.lift_height),
    ):
        pts.append(np.stack([xs + dx, np.full_like(xs, y), np.full_like(xs, pick_z + dz)], axis=1))
    return np.all([reachable_mask(geom, p) for p in pts], axis=0)


def intercept_item(
    start: State,
    item_xy: Sequence[float],
    belt_speed: float,
    drop_xyz: Sequence[float],
    generator: RuckigTrajectoryGenerator,
    pick_z: float,
    config: PickPlaceConfig | None = None,
    axis4: tuple[float, float] = (0.0, 0.0),
    with_plan: bool = True,
) -> Intercept:
    """When and where the cup can meet an item riding the belt, and the pick planned to do so.

    Args:
        start: The robot's state now.
        item_xy: The item's position now [m].
        belt_speed: Belt speed along +x [m/s], >= 0.
        drop_xyz: Release point over the item's bin [m].
        generator: Segment planner with the robot's geometry.
        pick_z: TCP height at contact (top of the item) [m].
        config: Heights and times of the pick.
        axis4: Axis-4 angle at the pick and at the drop [rad].
        with_plan: Also plan the whole pick and place (arriving exactly at the meeting time).

    Returns:
        The meeting (feasible) or the reason it cannot happen.
    """
    geom: DeltaGeometry | None = generator.geometry
    if geom is None:
        raise PlannerInputError("generator.geometry", "a DeltaGeometry (for the window)", None)
    if not (np.isfinite(belt_speed) and belt_speed >= 0.0):
        raise PlannerInputError("belt_speed", "a finite speed >= 0 [m/s]", belt_speed)
    config = config or PickPlaceConfig()
    x0, y = float(item_xy[0]), float(item_xy[1])
    times = np.arange(0.0, HORIZON + SCAN_DT, SCAN_DT)
    inside = window_mask(geom, x0 + belt_speed * times, y, pick_z, belt_speed, config)
    if not np.any(inside):
        line = np.linspace(x0 - 3.0, x0 + 3.0, 601)
        crossed = window_mask(geom, line, y, pick_z, belt_speed, config)
        if np.any(crossed) and x0 > line[crossed].max():
            return _refuse("the item has already left the reachable window")
        return _refuse("the item's path never enters the reachable window")
    first_in = int(np.argmax(inside))
    gone = np.flatnonzero(~inside[first_in:])
    last_in = first_in + int(gone[0]) - 1 if gone.size else len(times) - 1

    def arrival(t: float, blend: bool) -> float:
        pick = (x0 + belt_speed * t, y, pick_z)
        wps = pick_place_waypoints(pick, belt_speed, drop_xyz, config, axis4)[:2]
        _, total = search_corners(start, wps, generator, blend)
        return total - config.seal_time

    def meets(t: float, blend: bool) -> bool:
        ok = window_mask(geom, [x0 + belt_speed * t], y, pick_z, belt_speed, config)[0]
        return bool(ok) and arrival(t, blend) <= t

    hit = next((k for k in range(first_in, last_in + 1) if meets(times[k], False)), None)
    if hit is None:
        t_exit = times[last_in]
        return _refuse(
            f"the item leaves the reachable window {t_exit:.2f} s from now, before the cup can "
            f"reach it (it needs {arrival(t_exit, False):.2f} s)"
        )
    # Blended corners may meet earlier than the rest-corner scan found: step back, then bisect.
    while hit > first_in and meets(times[hit - 1], True):
        hit -= 1
    lo, hi = times[max(hit - 1, 0)], times[hit]
    if hit == 0:
        lo = hi
    else:  # lo fails (outside the window or too early), hi meets: bisect the boundary
        while hi - lo > TIME_TOL:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if meets(mid, True) else (mid, hi)
    pick = np.array([x0 + belt_speed * hi, y, pick_z])
    plan = None
    if with_plan:
        for _ in range(5):
            try:
                plan = plan_pick_place(
                    start, pick, belt_speed, drop_xyz, generator, config, axis4, contact_time=hi
                )
                break
            except PlannerInputError:  # the motor limits slowed it: meet a little later
                hi += SCAN_DT
                pick = np.array([x0 + belt_speed * hi, y, pick_z])
        in_window = window_mask(geom, [pick[0]], y, pick_z, belt_speed, config)[0]
        if plan is None or not in_window:
            return _refuse(
                "no pick within the motor limits and the workspace meets the item inside the window"
            )
    return Intercept(True, "", float(hi), pick, plan)
