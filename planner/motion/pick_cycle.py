"""A pick-and-place cycle as a chain of ruckig segments, and ABB's Cycle 1.

Pick and place: approach a point above the item, descend onto it arriving at the belt's
velocity, seal (35 ms) while moving with the belt, lift straight up (still moving with the belt,
so the held item rises straight up from among its neighbours), transfer to the bin's drop
point, release (35 ms). The robot then sets off from the drop point to the next item. The corner
above the item is blended by `planner.motion.blending.plan_chain`; the lift ends with no
vertical speed at its top, so the held item is up before it moves sideways.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from planner.errors import PlannerInputError
from planner.motion.blending import (
    FINE_CUTS,
    FINE_FRACTIONS,
    Waypoint,
    plan_chain,
    plan_fixed_chains,
)
from planner.motion.limits import VACUUM_RELEASE_S, VACUUM_SEAL_S
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import Chain, State

MAX_DWELL_S = 3.0
"""Longest dwell with the cup on the item, or over the bin [s]: the vacuum's 35 ms
(`planner.motion.limits`) and the longest extra pause an episode allows (2 s,
`sim.config.robots.MAX_PAUSE_S`), with room."""


@dataclass(frozen=True)
class PickPlaceConfig:
    """Geometry and timing of one pick and place.

    Attributes:
        approach_height: Height above the pick point of the corner before the descent [m].
        lift_height: Height of the corner after the lift, above the pick point [m].
        seal_time: Vacuum build-up with the cup on the item (ABB Cycle 1: 35 ms) [s].
        release_time: Vacuum release over the bin [s].
        touchdown_slow: The descent onto the item is planned with the limits of a motion this
            many times slower, so the servos have caught up with it when the cup touches down
            (1: full limits, the default). 1.6 keeps the simulated cup within 1 % of the
            belt's velocity while it seals (about 0.1 mm of settling left at touch-down) for
            ~18 ms more per pick; with 1 it is within ~2 % (0.25 mm of settling).
        blend: Pass the corners with non-zero velocity where that is faster.
        lift_with_belt: Keep the belt's velocity along x through the lift (conveyor tracking),
            so the item rises straight up from among its neighbours, which ride on beside it;
            False stops the cup's x during the lift, and a neighbour a few mm upstream runs
            into the held item's low end (a lying can was struck at 0.85 m/s so).
    """

    approach_height: float = 0.025
    lift_height: float = 0.025
    seal_time: float = VACUUM_SEAL_S
    release_time: float = VACUUM_RELEASE_S
    touchdown_slow: float = 1.0
    blend: bool = True
    lift_with_belt: bool = True

    def __post_init__(self):
        limits = {"approach_height": (1.0, "m"), "lift_height": (1.0, "m")}
        limits |= {"seal_time": (MAX_DWELL_S, "s"), "release_time": (MAX_DWELL_S, "s")}
        for name, (high, unit) in limits.items():
            value = getattr(self, name)
            if not (np.isfinite(value) and 0.0 <= value <= high):
                raise PlannerInputError(name, f"0 to {high:g} {unit}", value)
        if not (np.isfinite(self.touchdown_slow) and 1.0 <= self.touchdown_slow <= 4.0):
            raise PlannerInputError("touchdown_slow", "1 to 4", self.touchdown_slow)


@dataclass(frozen=True, eq=False)
class PickPlan:
    """A planned pick and place.

    Attributes:
        chain: The whole trajectory from the start state to the end of the release.
        contact_time: When the cup touches the item and the seal begins [s from start].
        lift_time: When the seal ends and the lift begins [s].
        release_time: When the cup reaches the drop point and releases [s].
        pick_xyz: Where the cup meets the item [m].
        belt_velocity: The belt's velocity along x during the pick [m/s].
    """

    chain: Chain
    contact_time: float
    lift_time: float
    release_time: float
    pick_xyz: np.ndarray
    belt_velocity: float

    @property
    def duration(self) -> float:
        """Start to end of the release [s]."""
        return self.chain.duration


def pick_place_waypoints(
    pick_xyz: Sequence[float],
    belt_velocity: float,
    drop_xyz: Sequence[float] | np.ndarray,
    config: PickPlaceConfig,
    axis4: tuple[float, float] = (0.0, 0.0),
) -> list[Waypoint]:
    """Waypoints of one pick and place (the chain's start is the robot's current state).

    The descent arrives time-optimally; `delay_contact` touches down later.

    Args:
        pick_xyz: Where the cup meets the item (top of the item) [m].
        belt_velocity: Belt speed along +x [m/s]; the cup arrives and seals at this velocity.
        drop_xyz: Release point above the bin [m].
        axis4: Axis-4 angle at the pick and at the drop [rad].
    """
    p = np.asarray(pick_xyz, dtype=float)
    b = np.asarray(drop_xyz, dtype=float)
    vb = float(belt_velocity)
    up = np.array([0.0, 0.0, 1.0])
    sealed = p + np.array([vb * config.seal_time, 0.0, 0.0])
    lift = sealed + config.lift_height * up
    return [
        Waypoint(np.append(p + config.approach_height * up, axis4[0]), label="approach"),
        Waypoint(
            np.append(p, axis4[0]),
            velocity=np.array([vb, 0.0, 0.0, 0.0]),
            dwell=config.seal_time,
            label="descend",
            dwell_label="seal",
            slow=config.touchdown_slow,
        ),
        # Straight up to the lift height, then the transfer: a held item swept sideways while
        # still low hits its neighbours on the belt (a stop costs ~8 ms of a ~0.3 s place).
        # `plan_place` moves this point along with the belt (`lift_with_belt`).
        Waypoint(np.append(lift, axis4[0]), velocity=np.zeros(4), label="lift"),
        Waypoint(
            np.append(b, axis4[1]),
            velocity=np.zeros(4),
            dwell=config.release_time,
            label="transfer",
            dwell_label="release",
        ),
    ]


def _seal_end(descend: Waypoint) -> State:
    """State at the end of the seal: the contact point carried on at the belt's velocity."""
    assert descend.velocity is not None  # the descent rides with the belt
    return State(descend.position + descend.velocity * descend.dwell, descend.velocity)


def plan_pick(
    start: State,
    waypoints: Sequence[Waypoint],
    generator: RuckigTrajectoryGenerator,
    config: PickPlaceConfig,
) -> Chain:
    """The pick half (approach, descend, seal) of `pick_place_waypoints`, time-optimal within
    every limit: its "seal" phase starts at the earliest possible contact (`delay_contact`
    moves the contact later).

    Raises:
        PlannerInputError: no such chain within the limits.
    """
    return plan_chain(start, list(waypoints[:2]), generator, blend=config.blend)


def delay_contact(
    pick: Chain, descend: Waypoint, generator: RuckigTrajectoryGenerator, contact_time: float
) -> Chain:
    """`pick` (from `plan_pick`) touching down at `contact_time` [s] instead of its earliest.

    The approach is stretched (ruckig's minimum duration) to reach the point above the item
    later, in the same state, so the descent and the touch-down stay as planned: the cup waits
    above the item, not on the way down. When the stretched approach breaks a limit, the
    descent is stretched instead.

    Raises:
        PlannerInputError: `contact_time` is earlier than `pick`'s contact, or neither stretch
            stays within the limits.
    """
    stretch = _Stretch.of(pick, contact_time)
    if stretch is None:
        return pick
    [longer] = plan_fixed_chains([stretch.chain], generator)
    return stretch.apply(pick, descend, generator, contact_time, longer)


@dataclass(frozen=True, eq=False)
class _Stretch:
    """The approach of a pick stretched to touch down later (`delay_contact`).

    Attributes:
        k: Index of the descent among the pick's segments.
        chain: (start, [the point above the item, reached `later`]) of the stretched approach.
        corner: State (position, velocity) at the point above the item.
        t_corner: When the pick reaches it [s].
    """

    k: int
    chain: tuple
    corner: tuple
    t_corner: float

    @classmethod
    def of(cls, pick: Chain, contact_time: float) -> _Stretch | None:
        """The stretch of `pick` to touch down at `contact_time` [s]; None when it touches
        down then already.

        Raises:
            PlannerInputError: `contact_time` is earlier than `pick`'s contact, or `pick` has
                no approach before its descent.
        """
        earliest = pick.phase_start("seal")
        if contact_time < earliest - 1e-9:
            raise PlannerInputError(
                "contact_time", f">= {earliest:.4f} s (the earliest)", contact_time
            )
        if contact_time <= earliest + 1e-12:
            return None
        labels = [s.label for s in pick.segments]
        k = labels.index("descend")
        if k == 0:
            raise PlannerInputError("pick", "a chain with an approach before its descent", labels)
        delay = contact_time - earliest
        approach = pick.segments[k - 1]
        corner = approach.at_time(approach.duration)
        start = State(*approach.at_time(0.0))
        t_corner = pick.phase_start(approach.label) + approach.duration
        later = approach.duration + delay
        above = Waypoint(corner[0], corner[1], label=approach.label, arrival_time=later)
        return cls(k, (start, [above]), corner, t_corner)

    def apply(self, pick, descend, generator, contact_time, longer) -> Chain:
        """`pick` with the stretched approach `longer` (a `Chain`, or the error planning it
        raised), else with its descent stretched instead."""
        k = self.k
        if not isinstance(longer, PlannerInputError):
            return Chain(pick.segments[: k - 1] + longer.segments + pick.segments[k:])
        down = State(self.corner[0], self.corner[1])
        wait = replace(descend, arrival_time=contact_time - self.t_corner)
        tail = plan_chain(down, [wait], generator, blend=False)
        return Chain(pick.segments[:k] + tail.segments)


def lift_travel(
    lift_height: float, belt_velocity: float, generator: RuckigTrajectoryGenerator
) -> float:
    """How far [m] the belt carries an item while the cup lifts it by `lift_height` [m] (the
    rest-to-rest time of the vertical move, at the robot's nominal pose)."""
    if belt_velocity == 0.0 or lift_height <= 0.0:
        return 0.0
    rise = generator.plan_unchecked(
        State.at_rest([0.0, 0.0, 0.0]), State.at_rest([0.0, 0.0, lift_height])
    )
    return float(belt_velocity) * rise.duration


def plan_place(
    waypoints: Sequence[Waypoint], generator: RuckigTrajectoryGenerator, config: PickPlaceConfig
) -> Chain:
    """The place half (lift, transfer, release) of `pick_place_waypoints`, from the seal's end.

    The seal's end state is fixed (contact point and belt velocity), so the two halves are
    planned apart: their corners do not interact. With `config.lift_with_belt` the lift ends
    where the belt has carried the item by then, still at the belt's velocity: ruckig then
    moves x at exactly the belt's velocity (the z move sets the duration), so the held item
    rises straight up relative to the belt.
    """
    start, place = _place_waypoints(waypoints, generator, config)
    return plan_chain(start, place, generator, blend=config.blend)


def _place_waypoints(waypoints, generator, config) -> tuple[State, list[Waypoint]]:
    """The start state and waypoints of `plan_place`'s chain."""
    start = _seal_end(waypoints[1])
    place = list(waypoints[2:])
    vb = float(waypoints[1].velocity[0])
    if config.lift_with_belt and vb != 0.0:
        lift = place[0]
        travel = lift_travel(lift.position[2] - start.position[2], vb, generator)
        along = np.array([travel, 0.0, 0.0, 0.0])
        place[0] = replace(
            lift, position=lift.position + along, velocity=np.array([vb, 0.0, 0.0, 0.0])
        )
    return start, place


def delay_and_place(
    pick: Chain,
    waypoints: Sequence[Waypoint],
    generator: RuckigTrajectoryGenerator,
    config: PickPlaceConfig,
    contact_time: float,
) -> tuple[Chain, Chain]:
    """`delay_contact(pick, waypoints[1], generator, contact_time)` and `plan_place(waypoints,
    generator, config)`, the stretched approach and the place chain planned together (their
    motor checks evaluated in one pass): neither depends on the other.

    Raises:
        PlannerInputError: as `delay_contact`, or else `plan_place`, raises it.
    """
    stretch = _Stretch.of(pick, contact_time)
    try:
        start, place = _place_waypoints(waypoints, generator, config)
    except PlannerInputError:
        place = None
    if place is None or any(wp.velocity is None for wp in place):
        # Corners to search, or a place that cannot be planned: one after the other.
        delayed = delay_contact(pick, waypoints[1], generator, contact_time)
        return delayed, plan_place(waypoints, generator, config)
    chains = [(start, place)] + ([stretch.chain] if stretch is not None else [])
    planned = plan_fixed_chains(chains, generator)
    delayed = pick
    if stretch is not None:
        delayed = stretch.apply(pick, waypoints[1], generator, contact_time, planned[1])
    if isinstance(planned[0], PlannerInputError):
        raise planned[0]
    return delayed, planned[0]


def join_pick_place(pick: Chain, place: Chain, pick_xyz, belt_velocity: float) -> PickPlan:
    """The pick and place halves as one plan."""
    chain = Chain(pick.segments + place.segments)
    return PickPlan(
        chain=chain,
        contact_time=chain.phase_start("seal"),
        lift_time=chain.phase_start("lift"),
        release_time=chain.phase_start("release"),
        pick_xyz=np.asarray(pick_xyz, dtype=float),
        belt_velocity=float(belt_velocity),
    )


def plan_pick_place(
    start: State,
    pick_xyz: Sequence[float],
    belt_velocity: float,
    drop_xyz: Sequence[float],
    generator: RuckigTrajectoryGenerator,
    config: PickPlaceConfig | None = None,
    axis4: tuple[float, float] = (0.0, 0.0),
    contact_time: float | None = None,
) -> PickPlan:
    """Plans one pick and place from the robot's current state (see `pick_place_waypoints`).

    Raises:
        PlannerInputError: a point is out of reach or the contact time cannot be met.
    """
    config = config or PickPlaceConfig()
    wps = pick_place_waypoints(pick_xyz, belt_velocity, drop_xyz, config, axis4)
    pick = plan_pick(start, wps, generator, config)
    if contact_time is not None:
        pick = delay_contact(pick, wps[1], generator, contact_time)
    return join_pick_place(pick, plan_place(wps, generator, config), pick_xyz, belt_velocity)


def cycle1_waypoints(
    a_xyz: Sequence[float] | np.ndarray,
    across: float = 0.305,
    height: float = 0.025,
    axis4_turn: float = np.pi / 2.0,
    vacuum_time: float = 0.035,
    zone: float = 0.025,
) -> list[Waypoint]:
    """ABB's Cycle 1 from `a_xyz` at rest: up, across (+x), down, vacuum, and back, vacuum.

    Axis 4 turns by `axis4_turn` on the way out and back on the way home, spread over the path
    in proportion to distance. Corners (top of the ups and downs) are free for blending and may
    be cut by up to `zone` along the 305 mm leg.

    Args:
        a_xyz: Pick point A [m]; B is `across` further along +x.
        across: Horizontal distance (ABB: 305 mm) [m].
        height: Vertical moves (ABB: 25 mm) [m].
        axis4_turn: Axis-4 rotation (ABB: 90 deg) [rad].
        vacuum_time: Vacuum time at each end (ABB: 35 ms) [s].
        zone: Corner zone [m]; 0 keeps the path on the exact up-across-down lines.
    """
    a = np.asarray(a_xyz, dtype=float)
    b = a + np.array([across, 0.0, 0.0])
    up = np.array([0.0, 0.0, height])
    share = height / (2.0 * height + across)
    th = [axis4_turn * share, axis4_turn * (1.0 - share)]
    stop = np.zeros(4)
    return [
        Waypoint(np.append(a + up, th[0]), label="up", zone=zone),
        Waypoint(np.append(b + up, th[1]), label="across", zone=zone),
        Waypoint(np.append(b, axis4_turn), stop, vacuum_time, "down", "vacuum_place"),
        Waypoint(np.append(b + up, th[1]), label="up_back", zone=zone),
        Waypoint(np.append(a + up, th[0]), label="across_back", zone=zone),
        Waypoint(np.append(a, 0.0), stop, vacuum_time, "down_back", "vacuum_pick"),
    ]


def plan_cycle1(
    a_xyz: Sequence[float] | np.ndarray, generator: RuckigTrajectoryGenerator, blend: bool = True
) -> Chain:
    """ABB's Cycle 1 starting at rest at A with axis 4 at 0 (see `cycle1_waypoints`), its
    corners searched on the fine grids (it is planned once)."""
    return plan_chain(
        State.at_rest(a_xyz),
        cycle1_waypoints(a_xyz),
        generator,
        blend=blend,
        fractions=FINE_FRACTIONS,
        cuts=FINE_CUTS,
    )
