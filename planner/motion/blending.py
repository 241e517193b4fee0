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


def _build(start, waypoints, corners, generator, checked):
    """Segments for given corner (offset, velocity) pairs; None if a path constraint fails."""
    segments, state, t = [], start, 0.0
    for k, wp in enumerate(waypoints):
        if wp.velocity is None:
            offset, vel = corners[k]
            goal = State(wp.position + offset, vel)
        else:
            goal = State(wp.position, wp.velocity)
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


def _search_duration(start, plain, corners, generator, cache) -> float:
    """Duration of the chain (inf if infeasible), without building segments: the fast path.

    `plain` holds the waypoints as tuples (position, velocity or None, dwell, arrival time) and
    `corners` the corner (position, velocity) tuples. Segments are memoised on their boundary
    states, so changing one corner re-plans only the segments it touches.
    """
    state = (tuple(start.position), tuple(start.velocity), tuple(start.acceleration))
    t = 0.0
    zero = (0.0,) * DOF
    for k, (pos, vel, dwell, arrival, slow) in enumerate(plain):
        if vel is None:
            pos, vel = corners[k]
        min_dur = None if arrival is None else arrival - t
        if min_dur is not None and min_dur < 0.0:
            return np.inf
        key = (state, pos, vel, min_dur, slow)
        hit = cache.get(key)
        if hit is None:
            hit = generator.duration_and_lowest(state, (pos, vel, zero), 2, min_dur, slow)
            cache[key] = hit
        dur, low = hit
        if low < min(state[0][2], pos[2]) - Z_TOL:
            return np.inf
        if arrival is not None and abs(t + dur - arrival) > 1e-9:
            return np.inf
        t += dur + dwell
        if dwell:
            pos = tuple(p + v * dwell for p, v in zip(pos, vel, strict=True))
        state = (pos, vel, zero)
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
        start: State at the chain's start.
        waypoints: Points to pass; the last one must have a given velocity.
        generator: Segment planner.
        blend: Search non-zero corner velocities and cuts; False keeps every corner at rest.
        sweeps: Rounds of coordinate descent over the corners.
        fractions: Multiples of the neighbouring average velocities tried at each corner.
        cuts: Fractions of each corner's zone tried.

    Returns:
        ({waypoint index: (offset (4,), velocity (4,))}, duration [s]).
    """
    if not waypoints or waypoints[-1].velocity is None:
        raise PlannerInputError("waypoints", "a non-empty list ending with a given velocity", None)
    zero = {
        k: (np.zeros(DOF), np.zeros(DOF)) for k, wp in enumerate(waypoints) if wp.velocity is None
    }
    best_corners = dict(zero)
    cache: dict = {}
    plain = [
        (
            tuple(wp.position),
            None if wp.velocity is None else tuple(wp.velocity),
            wp.dwell,
            wp.arrival_time,
            wp.slow,
        )
        for wp in waypoints
    ]
    as_tuples = {k: (tuple(waypoints[k].position + o), tuple(v)) for k, (o, v) in zero.items()}
    best = _search_duration(start, plain, as_tuples, generator, cache)
    if not (blend and zero):
        return best_corners, best
    axes = _corner_axes(start, waypoints, generator)
    max_velocity = generator.limits.max_velocity
    for _ in range(sweeps):
        before = best
        for k, (e_in, e_out, cut) in axes.items():
            for c in cuts if np.any(cut) else (0.0,):
                position = tuple(waypoints[k].position + c * cut)
                for alpha in fractions:
                    for beta in fractions:
                        v = alpha * e_in + beta * e_out
                        if not np.all(np.abs(v) <= max_velocity):
                            continue
                        trial = dict(as_tuples)
                        trial[k] = (position, tuple(v))
                        d = _search_duration(start, plain, trial, generator, cache)
                        if d < best - 1e-12:
                            best, as_tuples = d, trial
                            best_corners = dict(best_corners)
                            best_corners[k] = (c * cut, v)
        if _settled(best, before, len(axes)):
            break
    return best_corners, best


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
        start: State at the chain's start.
        waypoints: Points to pass; the last one must have a given velocity.
        generator: Segment planner (its limits and motor checks apply to every segment).
        blend: Search non-zero corner velocities; False stops at every corner.
        sweeps: Rounds of coordinate descent over the corners.
        fractions: As in `search_corners`.
        cuts: As in `search_corners`.

    Returns:
        The shorter of the blended chain and the chain with zero corner velocities.

    Raises:
        PlannerInputError: no chain meets the limits (e.g. a waypoint outside the workspace).
    """
    best_corners, _ = search_corners(start, waypoints, generator, blend, sweeps, fractions, cuts)
    zero = {k: (np.zeros(DOF), np.zeros(DOF)) for k in best_corners}
    # Without corners the blended chain is the rest-corner chain: built once, below.
    best = _try_build(start, waypoints, best_corners, generator, True) if blend and zero else None
    if best is not None:
        # The rest-corner chain cannot beat its own unchecked duration: skip it when possible.
        _, zero_bound = search_corners(start, waypoints, generator, blend=False)
        if _duration(best) <= zero_bound:
            return Chain(best)
    rest = _try_build(start, waypoints, zero, generator, True)
    chains = [c for c in (best, rest) if c is not None]
    if not chains:
        raise PlannerInputError("waypoints", "points the robot can pass within its limits", None)
    return Chain(min(chains, key=_duration))
