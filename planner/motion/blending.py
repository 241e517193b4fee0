"""Chains of state-to-state segments through waypoints, with blended corners.

Ruckig's free version plans one state-to-state segment at a time, so a path through waypoints is
a chain of segments. At a stop the velocity is given (zero, or the belt's velocity when sealing
on a moving item); at a corner (`Waypoint.velocity is None`) the chain may pass with any velocity.
`plan_chain` searches the corner velocities in the family `alpha * e_in + beta * e_out`, where
`e_in` and `e_out` are the average velocities of the rest-to-rest segments into and out of the
corner, by coordinate descent on the chain's duration. A corner with a `zone` may also be cut:
the chain then passes up to `zone` metres from the corner along its longer leg (as a robot
controller's fly-by zone does), so the vertical move into or out of a pick overlaps the transfer.
The corners at rest and uncut are always a candidate, so a blended chain is never slower than
the same path with stops at its corners.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from planner.errors import PlannerInputError
from planner.motion.ruckig_trajectory import RuckigTrajectoryGenerator
from planner.motion.trajectory import DOF, Chain, Dwell, State, Waypoint

__all__ = [
    "FRACTIONS",
    "CUTS",
    "Z_TOL",
    "Waypoint",
    "plan_chain",
    "search_corners",
    "FINE_FRACTIONS",
    "FINE_CUTS",
]

FRACTIONS = (0.0, 0.5, 1.0, 1.5, 2.0)
"""Multiples of the neighbouring segments' average velocities tried at each corner."""

CUTS = (0.0, 0.5, 1.0)
"""Fractions of a corner's zone tried as the distance by which it is cut."""

FINE_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5)
FINE_CUTS = (0.0, 0.25, 0.5, 0.75, 1.0)
"""Denser grids for paths planned once (ABB's Cycle 1): ~4 times the search time."""

Z_TOL = 1e-9
"""How far [m] a segment may dip below the lower of its two end heights."""

_AT_REST = (0.0,) * DOF


def _goal(wp, corners, k: int) -> State:
    """The state a segment ends in at waypoint `wp` (the `k`-th): its own, or a corner's (offset,
    velocity) from `corners` where the waypoint leaves its velocity free."""
    if wp.velocity is None:
        offset, vel = corners[k]
        return State(wp.position + offset, vel)
    return State(wp.position, wp.velocity)


def _build(start, waypoints, corners, generator, checked):
    """Segments for given corner (offset, velocity) pairs; None if a path constraint fails."""
    segments, state, t = [], start, 0.0
    for k, wp in enumerate(waypoints):
        goal = _goal(wp, corners, k)
        min_dur = None if wp.arrival_time is None else wp.arrival_time - t
        if min_dur is not None and min_dur < 0.0:
            return None
        plan = generator.plan if checked else generator.plan_unchecked
        seg = plan(state, goal, wp.label, min_dur, wp.slow)
        lo, _ = seg.position_range(2)
        if lo < min(state.position[2], goal.position[2]) - Z_TOL:
            return None
        if wp.arrival_time is not None and abs(t + seg.duration - wp.arrival_time) > 1e-9:
            return None
        segments.append(seg)
        t += seg.duration
        state = goal  # exact; the segment ends there to ruckig's precision (< 1e-12)
        if wp.dwell > 0.0:
            segments.append(Dwell(state, wp.dwell, wp.dwell_label))
            t += wp.dwell
            state = State(state.position + state.velocity * wp.dwell, state.velocity)
    return segments


def _legs(start, waypoints, corners) -> list[tuple[State, State]]:
    """(start, goal) state of the segment into each waypoint for given corner (offset,
    velocity) pairs, as `_build` plans them (a dwell carries the state on at its velocity)."""
    legs, state = [], start
    for k, wp in enumerate(waypoints):
        goal = _goal(wp, corners, k)
        legs.append((state, goal))
        state = goal
        if wp.dwell > 0.0 and k + 1 < len(waypoints):  # (the last one's is never used)
            state = State(state.position + state.velocity * wp.dwell, state.velocity)
    return legs


def _assemble(waypoints, legs, planned) -> list | None:
    """The segments `_build` makes of the planned segment (or error) into each waypoint; None
    where it refuses one (the first refusal in the chain's order, as `_build` meets it). Only
    the first waypoint may have an arrival time (met from the chain's start)."""
    segments = []
    for wp, (state, goal), seg in zip(waypoints, legs, planned, strict=True):
        if isinstance(seg, PlannerInputError):
            return None
        lo, _ = seg.position_range(2)
        if lo < min(state.position[2], goal.position[2]) - Z_TOL:
            return None
        if wp.arrival_time is not None and abs(0.0 + seg.duration - wp.arrival_time) > 1e-9:
            return None
        segments.append(seg)
        if wp.dwell > 0.0:
            segments.append(Dwell(goal, wp.dwell, wp.dwell_label))
    return segments


def build_chains(chains, generator: RuckigTrajectoryGenerator) -> list[list | None]:
    """`_try_build` (motor checks on) of each chain, given as (start, waypoints, corners),
    every segment of every chain planned in one `plan_many` (their motor checks evaluated
    together). A chain with an arrival time past its first waypoint is planned segment after
    segment: those segments' minimum durations follow from the ones before."""
    out: list[list | None] = [None] * len(chains)
    together: list[tuple] = []
    requests: list[tuple] = []
    for i, (start, waypoints, corners) in enumerate(chains):
        if any(wp.arrival_time is not None for wp in waypoints[1:]):
            out[i] = _try_build(start, waypoints, corners, generator, True)
            continue
        first = waypoints[0].arrival_time
        min_dur = None if first is None else first - 0.0  # as `_build` takes it
        if min_dur is not None and min_dur < 0.0:
            continue
        legs = _legs(start, waypoints, corners)
        together.append((i, waypoints, legs, len(requests)))
        for k, (wp, (state, goal)) in enumerate(zip(waypoints, legs, strict=True)):
            requests.append((state, goal, wp.label, min_dur if k == 0 else None, wp.slow))
    planned = generator.plan_many(requests) if requests else []
    for i, waypoints, legs, first in together:
        out[i] = _assemble(waypoints, legs, planned[first : first + len(waypoints)])
    return out


def plan_fixed_chains(chains, generator: RuckigTrajectoryGenerator) -> list:
    """`plan_chain` of each chain, given as (start, waypoints), whose waypoints are no
    corners (each velocity given), all planned together (`build_chains`).

    Returns:
        Per chain, its `Chain`, or the `PlannerInputError` that `plan_chain` would raise.
    """
    if any(not w or any(wp.velocity is None for wp in w) for _, w in chains):
        raise PlannerInputError("waypoints", "non-empty lists of points with velocities", None)
    refused = PlannerInputError("waypoints", "points the robot can pass within its limits", None)
    built = build_chains([(start, waypoints, {}) for start, waypoints in chains], generator)
    return [refused if segments is None else Chain(segments) for segments in built]


def _search_duration(start, plain, corners, generator, cache) -> float:
    """Duration of the chain (inf if infeasible), without building segments: the fast path.

    `start` is the start state as (position, velocity, acceleration) tuples, `plain` holds the
    waypoints as tuples (position, velocity or None, dwell, arrival time, slow) and `corners`
    the corner (position, velocity) tuples, all of plain floats. Segments are memoised on
    their boundary states, so changing one corner re-plans only the segments it touches.
    """
    state = start
    t = 0.0
    for k, (pos, vel, dwell, arrival, slow) in enumerate(plain):
        if vel is None:
            pos, vel = corners[k]
        min_dur = None if arrival is None else arrival - t
        if min_dur is not None and min_dur < 0.0:
            return np.inf
        key = (state, pos, vel, min_dur, slow)
        hit = cache.get(key)
        if hit is None:
            hit = generator.duration_and_lowest(state, (pos, vel, _AT_REST), 2, min_dur, slow)
            cache[key] = hit
        dur, low = hit
        if low < min(state[0][2], pos[2]) - Z_TOL:
            return np.inf
        if arrival is not None and abs(t + dur - arrival) > 1e-9:
            return np.inf
        t += dur + dwell
        if k + 1 < len(plain):  # the next segment starts where the dwell ends
            if dwell:
                pos = tuple(p + v * dwell for p, v in zip(pos, vel, strict=True))
            state = (pos, vel, _AT_REST)
    return t


def _try_build(start, waypoints, corners, generator, checked):
    try:
        return _build(start, waypoints, corners, generator, checked)
    except PlannerInputError:
        return None


def _duration(segments) -> float:
    return np.inf if segments is None else float(sum(s.duration for s in segments))


def _corner_axes(start, waypoints, generator):
    """Per corner: average velocities in and out (rest-to-rest) and the unit cutting direction."""
    points = [start.position] + [wp.position for wp in waypoints]
    axes = {}
    for k, wp in enumerate(waypoints):
        if wp.velocity is not None or k + 1 >= len(waypoints):
            continue
        prev_p, p, next_p = points[k], points[k + 1], points[k + 2]
        t_in = generator.plan_unchecked(State(prev_p), State(p)).duration
        t_out = generator.plan_unchecked(State(p), State(next_p)).duration
        e_in = (p - prev_p) / t_in if t_in > 0 else np.zeros(DOF)
        e_out = (next_p - p) / t_out if t_out > 0 else np.zeros(DOF)
        leg_in, leg_out = p[:3] - prev_p[:3], next_p[:3] - p[:3]
        longer = leg_out if np.linalg.norm(leg_out) >= np.linalg.norm(leg_in) else -leg_in
        length = np.linalg.norm(longer)
        cut = np.zeros(DOF)
        if length > 0.0:
            cut[:3] = longer / length * min(wp.zone, 0.5 * length)
        axes[k] = (e_in, e_out, cut)
    return axes


def _settled(best: float, before: float, corners: int) -> bool:
    """Whether the coordinate descent is over after a sweep that took its chain duration from
    `before` to `best` [s]: a further sweep would try exactly the trials of this one again,
    with the same results, when this one changed nothing, or when there is a single corner
    (its trials set every corner)."""
    return best == before or corners == 1


def search_corners(
    start: State,
    waypoints: Sequence[Waypoint],
    generator: RuckigTrajectoryGenerator,
    blend: bool = True,
    sweeps: int = 2,
    fractions: Sequence[float] = FRACTIONS,
    cuts: Sequence[float] = CUTS,
) -> tuple[dict, float]:
    """Corner offsets and velocities that shorten the chain, and its duration (no checks of the
    motor limits yet: `plan_chain` applies them). inf when no candidate is feasible.

    Args:
        waypoints: The last one must have a given velocity.
        blend: Search non-zero corner velocities and cuts; False keeps every corner at rest.
        sweeps: Rounds of coordinate descent over the corners.
        fractions: Multiples of the neighbouring average velocities tried at each corner.
        cuts: Fractions of each corner's zone tried.

    Returns:
        ({waypoint index: (offset (4,), velocity (4,))}, duration [s]).
    """
    corners, duration, _ = _search(start, waypoints, generator, blend, sweeps, fractions, cuts)
    return corners, duration


def _search(start, waypoints, generator, blend, sweeps, fractions, cuts):
    """`search_corners`, and the duration of the chain with every corner at rest, uncut (its
    first candidate) [s]."""
    if not waypoints or waypoints[-1].velocity is None:
        raise PlannerInputError("waypoints", "a non-empty list ending with a given velocity", None)
    zero = {
        k: (np.zeros(DOF), np.zeros(DOF)) for k, wp in enumerate(waypoints) if wp.velocity is None
    }
    best_corners = dict(zero)
    cache: dict = {}
    # Plain floats: the same values, far cheaper to add and hash than numpy scalars.
    first = (tuple(start.position.tolist()), tuple(start.velocity.tolist()))
    first += (tuple(start.acceleration.tolist()),)
    plain = [
        (
            tuple(wp.position.tolist()),
            None if wp.velocity is None else tuple(wp.velocity.tolist()),
            wp.dwell,
            wp.arrival_time,
            wp.slow,
        )
        for wp in waypoints
    ]
    as_tuples = {
        k: (tuple((waypoints[k].position + o).tolist()), tuple(v.tolist()))
        for k, (o, v) in zero.items()
    }
    best = rest = _search_duration(first, plain, as_tuples, generator, cache)
    if not (blend and zero):
        return best_corners, best, rest
    axes = _corner_axes(start, waypoints, generator)
    max_velocity = generator.limits.max_velocity
    for _ in range(sweeps):
        before = best
        for k, (e_in, e_out, cut) in axes.items():
            velocities = _corner_velocities(e_in, e_out, fractions, max_velocity)
            for c in cuts if np.any(cut) else (0.0,):
                position = tuple((waypoints[k].position + c * cut).tolist())
                for v, as_floats in velocities:
                    trial = dict(as_tuples)
                    trial[k] = (position, as_floats)
                    d = _search_duration(first, plain, trial, generator, cache)
                    if d < best - 1e-12:
                        best, as_tuples = d, trial
                        best_corners = dict(best_corners)
                        best_corners[k] = (c * cut, v)
        if _settled(best, before, len(axes)):
            break
    return best_corners, best, rest


def _corner_velocities(e_in, e_out, fractions, max_velocity) -> list[tuple[np.ndarray, tuple]]:
    """The corner velocities alpha e_in + beta e_out (alpha, then beta, over `fractions`)
    within `max_velocity` per coordinate, each as an array and as a tuple of floats."""
    f = np.asarray(fractions, dtype=float)
    # Each velocity as alpha * e_in + beta * e_out computes it alone, for all pairs at once.
    grid = (f[:, None, None] * e_in + f[None, :, None] * e_out).reshape(-1, DOF)
    allowed = np.all(np.abs(grid) <= max_velocity, axis=1)
    return [(v, tuple(v.tolist())) for v in grid[allowed]]


def plan_chain(
    start: State,
    waypoints: Sequence[Waypoint],
    generator: RuckigTrajectoryGenerator,
    blend: bool = True,
    sweeps: int = 2,
    fractions: Sequence[float] = FRACTIONS,
    cuts: Sequence[float] = CUTS,
) -> Chain:
    """The chain through `waypoints`, with corner velocities chosen to shorten it.

    Args:
        waypoints: The last one must have a given velocity.
        generator: Its limits and motor checks apply to every segment).
        blend: Search non-zero corner velocities; False stops at every corner.
        sweeps, fractions, cuts: As in `search_corners`.

    Returns:
        The shorter of the blended chain and the chain with zero corner velocities.

    Raises:
        PlannerInputError: no chain meets the limits (e.g. a waypoint outside the workspace).
    """
    best_corners, _, zero_bound = _search(
        start, waypoints, generator, blend, sweeps, fractions, cuts
    )
    zero = {k: (np.zeros(DOF), np.zeros(DOF)) for k in best_corners}
    if blend and zero:
        # The rest-corner chain is planned along with the blended one (their motor checks
        # evaluated together): the motor limits slow most blended chains past its unchecked
        # duration, which it cannot beat, so it is nearly always needed.
        chains = [(start, waypoints, best_corners), (start, waypoints, zero)]
        best, rest = build_chains(chains, generator)
        if best is not None and _duration(best) <= zero_bound:
            return Chain(best)
    else:
        # Without corners the blended chain is the rest-corner chain: built once.
        best, rest = None, build_chains([(start, waypoints, zero)], generator)[0]
    built = [c for c in (best, rest) if c is not None]
    if not built:
        raise PlannerInputError("waypoints", "points the robot can pass within its limits", None)
    return Chain(min(built, key=_duration))
