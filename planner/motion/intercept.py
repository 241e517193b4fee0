"""Meeting a moving item: where and when the cup lands on it at the belt's velocity.

An item now at (x0, y) rides the belt at `belt_speed` along +x, so at time T it is at
x0 + belt_speed T. The cup must touch it at T with the belt's velocity (ruckig's target
velocity), so T solves T = D(T), D being the duration of the approach-and-descend chain to where
the item will be at T, planned within every limit (the motors' speed and torque checks slow the
long approaches; an estimate without them is optimistic and its plans fail). The item moves
far slower than the cup, so D changes little with T and the iteration T <- D(T), started where
the item enters the reachable window, settles in two or three plans. The approach of the last
plan is then stretched to touch down exactly at T (ruckig's minimum duration; the cup waits
above the item), and the place half (lift, transfer, release) is planned from the seal's end.
An item that leaves the reachable window (contact, approach, seal and lift points all
reachable) before it can be met is refused with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.errors import PlannerInputError
from planner.motion.kinematics import DeltaGeometry, reachable_mask
from planner.motion.pick_cycle import (
    PickPlaceConfig,
    PickPlan,
    delay_and_place,
    join_pick_place,
    lift_travel,
    pick_place_waypoints,
    plan_pick,
)
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import Chain, State

SCAN_DT = 0.02
"""Grid step of the reachable-window scan [s]."""

TIME_TOL = 1e-3
"""Slack added to each fixed-point iterate of the meeting time [s]: the cup waits at most this
long above the item, and the iteration ends in two or three plans."""

MAX_PLANS = 20
"""Most pick-half plans the fixed-point iteration makes (with the steps past unplannable edges)."""

HORIZON = 10.0
"""Longest wait considered for an item upstream of the window [s]."""

FINE_DT = 0.0005
"""Time step at which a finished plan is checked to stay inside the workspace [s]."""

MAX_LATER = 5
"""Times a plan leaving the workspace between the generator's checks is moved `SCAN_DT` later."""

WINDOW_CHUNK = 176
"""Grid times of the window scan tested at once (3.5 s of the 10 s horizon): the scan stops at
the chunk where the item leaves the window, most often in the second."""


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


def window_mask(
    geom, xs, y, pick_z, belt_speed, config: PickPlaceConfig, lift_travel: float = 0.0
) -> np.ndarray:
    """Whether an item met at each x of `xs` [m] has its contact, approach, seal-end and lift
    points inside the workspace (the lift ending `lift_travel` [m] downstream of the seal's
    end when the cup lifts with the belt)."""
    xs = np.asarray(xs, dtype=float)
    seal = belt_speed * config.seal_time
    pts = []
    for dx, dz in (
        (0.0, 0.0),
        (0.0, config.approach_height),
        (seal, 0.0),
        (seal + lift_travel, config.lift_height),
    ):
        pts.append(np.stack([xs + dx, np.full_like(xs, y), np.full_like(xs, pick_z + dz)], axis=1))
    # One workspace test for the four points of every x (each point's test is its own).
    return np.all(reachable_mask(geom, np.concatenate(pts)).reshape(4, -1), axis=0)


def window_span(inside_at, count: int) -> tuple[int, int] | None:
    """(first, last) index of the first run of True in a mask of `count` entries read in
    chunks of `WINDOW_CHUNK` (`inside_at(slice)` gives the mask there), None when it is all
    False: what the whole mask says, read only until the run ends."""
    first = None
    for lo in range(0, count, WINDOW_CHUNK):
        part = inside_at(slice(lo, lo + WINDOW_CHUNK))
        if first is None:
            hits = np.flatnonzero(part)
            if not hits.size:
                continue
            first = lo + int(hits[0])
        gone = np.flatnonzero(~part[first - lo if first >= lo else 0 :])
        if gone.size:
            return first, max(first, lo) + int(gone[0]) - 1
    return None if first is None else (first, count - 1)


def intercept_item(
    start: State,
    item_xy: Sequence[float] | np.ndarray,
    belt_speed: float,
    drop_xyz: Sequence[float] | np.ndarray,
    generator: RuckigTrajectoryGenerator,
    pick_z: float,
    config: PickPlaceConfig | None = None,
    axis4: tuple[float, float] = (0.0, 0.0),
    with_plan: bool = True,
) -> Intercept:
    """When and where the cup can meet an item riding the belt, and the pick planned to do so.

    Args:
        item_xy: The item's position now [m].
        belt_speed: Belt speed along +x [m/s], >= 0.
        drop_xyz: Release point over the item's bin [m].
        generator: Segment planner with the robot's geometry.
        pick_z: TCP height at contact (top of the item) [m].
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
    meeting = _ItemMeeting(
        start, float(item_xy[0]), float(item_xy[1]), pick_z, belt_speed, drop_xyz,
        generator, geom, config or PickPlaceConfig(), axis4,
    )  # fmt: skip
    window = meeting.window()
    if window is None:
        return _refuse(meeting.outside_reason())
    t_enter, t_exit = window
    pick, contact, t = meeting.meeting_time(t_enter, t_exit)
    if pick is None or contact > t + 1e-9 or t > t_exit:
        needs = "" if not np.isfinite(contact) else f" (it needs {contact:.2f} s)"
        return _refuse(
            f"the item leaves the reachable window {t_exit:.2f} s from now, before the cup can "
            f"reach it{needs}"
        )
    if not with_plan:
        return Intercept(True, "", t, meeting.point(t))
    return meeting.planned(pick, t, t_exit)


@dataclass(frozen=True, eq=False)
class _ItemMeeting:
    """One item riding the belt from (x0, y) [m] and the pick meeting it at `pick_z` [m]: what
    every plan of one intercept shares. Each stage of `intercept_item` is a method."""

    start: State
    x0: float
    y: float
    pick_z: float
    belt_speed: float
    drop_xyz: Sequence[float] | np.ndarray
    generator: RuckigTrajectoryGenerator
    geom: DeltaGeometry
    config: PickPlaceConfig
    axis4: tuple[float, float]

    def point(self, t: float) -> np.ndarray:
        """Where the item is `t` [s] from now [m]."""
        return np.array([self.x0 + self.belt_speed * t, self.y, self.pick_z])

    def waypoints(self, t: float):
        """The pick and place's waypoints for meeting the item where it is at `t` [s]."""
        return pick_place_waypoints(
            (self.x0 + self.belt_speed * t, self.y, self.pick_z),
            self.belt_speed, self.drop_xyz, self.config, self.axis4,
        )  # fmt: skip

    def _lift_travel(self) -> float:
        if not self.config.lift_with_belt:
            return 0.0
        return lift_travel(self.config.lift_height, self.belt_speed, self.generator)

    def window(self) -> tuple[float, float] | None:
        """(first, last) time [s] on the scan's grid at which the item is inside the reachable
        window, None when it is not within `HORIZON`."""
        times = np.arange(0.0, HORIZON + SCAN_DT, SCAN_DT)
        travel = self._lift_travel()
        xs = self.x0 + self.belt_speed * times
        span = window_span(
            lambda part: window_mask(
                self.geom, xs[part], self.y, self.pick_z, self.belt_speed, self.config, travel
            ),
            len(xs),
        )
        if span is None:
            return None
        return float(times[span[0]]), float(times[span[1]])

    def outside_reason(self) -> str:
        """Why an item never inside the window within `HORIZON` cannot be met."""
        line = np.linspace(self.x0 - 3.0, self.x0 + 3.0, 601)
        travel = self._lift_travel()
        crossed = window_mask(
            self.geom, line, self.y, self.pick_z, self.belt_speed, self.config, travel
        )
        if np.any(crossed) and self.x0 > line[crossed].max():
            return "the item has already left the reachable window"
        return "the item's path never enters the reachable window"

    def earliest_contact(self, t: float):
        """The time-optimal pick half for meeting the item where it is at `t`, and its contact
        time; (None, inf) when it cannot be planned."""
        try:
            pick = plan_pick(self.start, self.waypoints(t), self.generator, self.config)
        except PlannerInputError:
            return None, np.inf
        return pick, pick.phase_start("seal")

    def meeting_time(self, t: float, t_exit: float):
        """(pick half, its contact time, t): the fixed point t = contact(t) sought from the
        window's entry `t` [s]. The item moves far slower than the cup, so a few plans do; at
        the window's edge a plan may fail (a path leaving the workspace): a little later is
        tried. Met when contact <= t + 1e-9 and t <= `t_exit`."""
        pick, contact = self.earliest_contact(t)
        for _ in range(MAX_PLANS):
            if contact <= t + 1e-9:
                break
            t = contact + TIME_TOL if np.isfinite(contact) else t + SCAN_DT
            if t > t_exit:
                break
            pick, contact = self.earliest_contact(t)
        return pick, contact, t

    def planned(self, pick: Chain, t: float, t_exit: float) -> Intercept:
        """The whole pick and place arriving at `t` [s], its low part checked finely inside
        the workspace; met `SCAN_DT` later, further inside, when it leaves it."""
        for _ in range(MAX_LATER + 1):
            point = self.point(t)
            wps = self.waypoints(t)
            try:
                pick, place = delay_and_place(pick, wps, self.generator, self.config, t)
                plan = join_pick_place(pick, place, point, self.belt_speed)
            except PlannerInputError as exc:
                return _refuse(
                    f"no pick within the motor limits meets the item inside the window ({exc})"
                )
            low = (plan.chain.phase_start("descend"), plan.chain.phase_start("transfer"))
            if path_inside(plan.chain, self.geom, *low):
                return Intercept(True, "", t, point, plan)
            # The descent swings a millimetre or two about the contact point as it matches the
            # belt's velocity; at the window's edge that can leave the workspace between the
            # generator's 2 ms checks: meet the item a little later, further inside.
            t += SCAN_DT
            if t > t_exit:
                break
            pick, contact = self.earliest_contact(t)
            if pick is None or contact > t + 1e-9:
                break
        return _refuse("every plan meeting the item inside the window leaves the workspace")


def path_inside(
    chain, geom: DeltaGeometry, t_start: float = 0.0, t_end: float | None = None, dt=FINE_DT
) -> bool:
    """Whether the TCP of `chain` stays inside the workspace from `t_start` to `t_end` [s]
    (its end when None), sampled every `dt` [s]: finer than the executor's control period,
    which turns every sample into motor set-points. The intercept checks the low part of the
    path (descent, seal, lift), where it runs along the workspace's lower edge."""
    t_end = chain.duration if t_end is None else t_end
    times = np.append(np.arange(t_start, t_end, dt), t_end)
    xyz = chain.states_at(times)[0][:, :3]
    return bool(np.all(reachable_mask(geom, xyz)))
