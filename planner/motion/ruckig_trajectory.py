"""Ruckig backend of the trajectory interface: time-optimal, jerk-limited state-to-state segments.

Each segment is one offline `ruckig.Ruckig.calculate` in the four TCP coordinates (x, y, z,
axis4), time-synchronised so every coordinate arrives together. Ruckig knows only per-coordinate
limits; the motors' speed limit is checked afterwards through the delta Jacobian
(`planner.motion.kinematics.jacobian`), and the motors' torque through the lumped dynamics
(`planner.motion.dynamics`) when given, and where either is exceeded the segment is re-planned
with the limits of a uniformly slowed motion (`MotionLimits.slowed`) until both hold.

`plan_many` plans several segments so: each goes through exactly the re-plans it would go
through alone, while the checks of all the segments still open are evaluated together, one
numpy pass per round (`planner.motion.motor_rates.segment_peaks`), which costs far less than
one pass per segment and re-plan.

A segment is evaluated in numpy from its phase tables, one segment or many at once: a ruckig
profile is seven jerk-constant phases per coordinate, and from the phase's start state the
position is p + t (v + t (a/2 + t j/6)). Evaluated with exactly ruckig's operations, every number
is ruckig's own to the bit (`RuckigSegment.states_at`), and the samples the motor checks take
along many segments are evaluated in one pass over all of them (`stacked_xyz`): each sample's
numbers are computed on their own, so they are the ones the segment gives alone.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from ruckig import InputParameter, Result, Ruckig, RuckigError
from ruckig import Trajectory as _RuckigTrajectory

from planner.errors import PlannerInputError
from planner.motion.dynamics import LumpedDynamics
from planner.motion.kinematics import DeltaGeometry
from planner.motion.limits import MotionLimits
from planner.motion.motor_rates import motor_rates, segment_peaks
from planner.motion.trajectory import DOF, Segment, State, TrajectoryGenerator

CHECK_DT = 0.002
"""Time step at which motor speeds, torques and reachability are checked along a segment [s]."""

JERK_NUDGE = 1.0 - 1e-6
"""Ruckig 0.19 throws on inputs that sit exactly on a profile boundary (a rest-to-rest move of
exactly 2 a^3 / j^2, e.g. 45 mm at 100 m/s^2 and a 15 ms jerk ramp); such a segment is planned
again with the jerk limits lowered by one part in a million, which stays inside the limits."""

TORQUE_MARGIN = 0.90
"""Share of the motors' torque limit a plan may use: the lumped model reads about 5 % under the
simulated torques (rod inertia), and the servo feedback needs some headroom."""

_NOT_BUILT = object()


class RuckigSegment(Segment):
    """A segment backed by a `ruckig.Trajectory`."""

    def __init__(self, trajectory: _RuckigTrajectory, limits: MotionLimits, label: str = ""):
        self._traj = trajectory
        self._duration = float(trajectory.duration)
        self.limits = limits
        self.label = label
        self._tables = _NOT_BUILT  # the phase tables of `states_at`, built on first use

    @property
    def duration(self) -> float:
        return self._duration

    def at_time(self, t: float):
        p, v, a = self._traj.at_time(min(max(t, 0.0), self._duration))
        return np.array(p), np.array(v), np.array(a)

    def states_at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations (n, 4) at `times` (n,) [s] (clamped to the
        segment), bit for bit what ruckig's `at_time` gives, evaluated in numpy for every
        coordinate at once: each coordinate's profile is seven jerk-constant phases,
        p + t (v + t (a/2 + t j/6)) from the phase's start state, and after its last phase
        (at the segment's end, or earlier for a coordinate that finishes early) it keeps its
        final acceleration (jerk 0). Falls back to ruckig per time where a profile has a brake
        phase (a start outside the limits) or the segment has several sections."""
        t = np.minimum(np.maximum(np.asarray(times, dtype=float), 0.0), self._duration)
        tables = self._phase_tables()
        if tables is None:
            return super().states_at(t)
        return evaluate(tables, t, self._duration, DOF)

    def _phase_tables(self):
        """Per coordinate (rows of (4, 8) arrays): phase start times (0, then the ends of the
        seven phases) [s], start positions, velocities, accelerations and jerks (0 after the
        last phase); None where the vectorised evaluation does not apply (brake phases,
        several sections, phase ends out of order). Built on first use."""
        if self._tables is _NOT_BUILT:
            self._tables = phase_tables_of(self._traj)
        return self._tables

    def position_range(self, dof: int) -> tuple[float, float]:
        """Lowest and highest position of coordinate `dof` over the segment (exact)."""
        ext = self._traj.position_extrema[dof]
        return ext.min, ext.max

    def breakpoints(self) -> np.ndarray:
        """Times [s] where some coordinate's jerk switches (its acceleration peaks there)."""
        tables = self._phase_tables()
        if tables is not None:
            # The phase starts, offset by the zero brake phase as below (0.0 + -0.0 is 0.0).
            return np.clip(0.0 + tables[0].ravel(), 0.0, self._duration)
        times = []
        for section in self._traj.profiles:
            for prof in section:
                t0 = prof.brake.duration
                times.append(t0 + np.concatenate([[0.0], np.cumsum(prof.t)]))
        return np.clip(np.concatenate(times), 0.0, self._duration)

    def sample_times(self, dt: float) -> np.ndarray:
        """Times (N,) every `dt` [s], at every jerk switch and at the end, sorted, each once."""
        grid = np.append(np.arange(0.0, self._duration, dt), self._duration)
        return sorted_once(np.concatenate([grid, self.breakpoints()]))

    def sample_states(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Times (N,) every `dt` [s], at every jerk switch and at the end, and the positions,
        velocities and accelerations (N, 4) there."""
        times = self.sample_times(dt)
        return (times, *self.states_at(times))

    def sample_xyz(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The TCP's positions, velocities and accelerations (N, 3) at `sample_times(dt)`: the
        numbers `sample_states` gives, without axis 4 (the motor checks' samples)."""
        pos, vel, acc = self.states_at(self.sample_times(dt))
        return (
            np.ascontiguousarray(pos[:, :3]),
            np.ascontiguousarray(vel[:, :3]),
            np.ascontiguousarray(acc[:, :3]),
        )


def motor_speeds(geom: DeltaGeometry, xyz: np.ndarray, vxyz: np.ndarray) -> np.ndarray:
    """Motor speeds [rad/s] (n, 3) for TCP positions (n, 3) [m] and velocities (n, 3) [m/s]."""
    return motor_rates(geom, xyz, vxyz).qdot


def motor_torques(geom: DeltaGeometry, dynamics: LumpedDynamics, xyz, vxyz, axyz) -> np.ndarray:
    """Motor torques [N m] (n, 3) of TCP positions, velocities and accelerations (n, 3) under
    the lumped dynamics."""
    r = motor_rates(geom, xyz, vxyz, axyz)
    return dynamics.torque(r.q, r.qdot, r.qddot, r.jac, axyz)


class RuckigTrajectoryGenerator(TrajectoryGenerator):
    """Plans segments with ruckig, then enforces the motor-speed limit by slowing down.

    Args:
        limits: Cartesian, axis-4 and motor limits.
        geometry: Robot geometry for the motor checks; `None` skips them.
        dynamics: Lumped dynamics for the torque check (needs `geometry`); `None` skips it.
        max_retimes: How many slowed re-plans to try before refusing.
    """

    def __init__(
        self,
        limits: MotionLimits,
        geometry: DeltaGeometry | None = None,
        dynamics: LumpedDynamics | None = None,
        max_retimes: int = 8,
    ):
        self.limits = limits
        self.geometry = geometry
        self.dynamics = dynamics
        self.max_retimes = max_retimes
        self._otg = Ruckig(DOF)
        self._inp = InputParameter(DOF)
        self.last_retimes = 0

    def _calculate(
        self, start: State, goal: State, limits: MotionLimits, minimum_duration: float | None
    ) -> _RuckigTrajectory:
        inp = self._inp
        inp.minimum_duration = minimum_duration
        inp.current_position = start.position.tolist()
        inp.current_velocity = start.velocity.tolist()
        inp.current_acceleration = start.acceleration.tolist()
        inp.target_position = goal.position.tolist()
        inp.target_velocity = goal.velocity.tolist()
        inp.target_acceleration = goal.acceleration.tolist()
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = limits.ruckig_limits
        traj = _RuckigTrajectory(DOF)
        result = self._robust_calculate(inp, traj)
        if result not in (Result.Working, Result.Finished):
            raise PlannerInputError(
                "start/goal", "states whose velocity and acceleration lie inside the limits", result
            )
        return traj

    def _robust_calculate(self, inp: InputParameter, traj: _RuckigTrajectory) -> Result:
        """`Ruckig.calculate`, once more with nudged jerk limits if ruckig throws (JERK_NUDGE)."""
        try:
            return self._otg.calculate(inp, traj)
        except RuckigError:
            inp.max_jerk = (np.asarray(inp.max_jerk) * JERK_NUDGE).tolist()
            return self._otg.calculate(inp, traj)

    def duration_and_lowest(
        self,
        start: tuple,
        goal: tuple,
        dof: int,
        minimum_duration: float | None = None,
        slow: float = 1.0,
    ) -> tuple[float, float]:
        """Fast path for searches: duration [s] and lowest value of coordinate `dof`.

        Args:
            start: (position, velocity, acceleration), each a sequence of 4 floats.
            goal: (position, velocity, acceleration) of the goal.
            dof: Coordinate whose minimum is returned (2: z).
            minimum_duration: As in `plan`.
            slow: As in `plan`.

        Returns:
            (duration, lowest); (inf, -inf) when ruckig refuses the input.
        """
        inp = self._inp
        inp.minimum_duration = minimum_duration
        inp.current_position, inp.current_velocity, inp.current_acceleration = start
        inp.target_position, inp.target_velocity, inp.target_acceleration = goal
        lim = self.limits if slow == 1.0 else self.limits.slowed(slow)
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = lim.ruckig_limits
        traj = _RuckigTrajectory(DOF)
        if self._robust_calculate(inp, traj) not in (Result.Working, Result.Finished):
            return np.inf, -np.inf
        return traj.duration, traj.position_extrema[dof].min

    def plan_unchecked(
        self,
        start: State,
        goal: State,
        label: str = "",
        minimum_duration: float | None = None,
        slow: float = 1.0,
    ) -> RuckigSegment:
        """The ruckig segment alone, without the motor checks."""
        limits = self.limits if slow == 1.0 else self.limits.slowed(slow)
        traj = self._calculate(start, goal, limits, minimum_duration)
        return RuckigSegment(traj, limits, label)

    def limit_ratios(self, segment: RuckigSegment) -> tuple[float, float]:
        """Peak motor speed / speed limit and peak torque / (margin x torque limit) over the
        segment (each <= 1 is inside; inf when the segment leaves the workspace)."""
        return self.limit_ratios_of([segment])[0]

    def limit_ratios_of(self, segments: Sequence[RuckigSegment]) -> list[tuple[float, float]]:
        """`limit_ratios` of each segment, from one evaluation of all their samples (every
        number is computed per sample, so each segment's are those it has alone)."""
        if self.geometry is None:
            return [(0.0, 0.0)] * len(segments)
        sizes, pos, vel, acc = _check_samples(segments)
        inside, speeds, torques = segment_peaks(self.geometry, self.dynamics, pos, vel, acc, sizes)
        speeds = speeds / self.limits.motor_velocity
        if self.dynamics is not None:
            torques = torques / (TORQUE_MARGIN * self.dynamics.torque_limit)
        ratios = [(np.inf, np.inf)] * len(segments)
        for k, speed, torque in zip(np.flatnonzero(inside), speeds, torques, strict=True):
            ratios[k] = (float(speed), float(torque))
        return ratios

    def plan(
        self,
        start: State,
        goal: State,
        label: str = "",
        minimum_duration: float | None = None,
        slow: float = 1.0,
    ) -> RuckigSegment:
        """The fastest segment found within every limit, motor speeds included.

        Args:
            minimum_duration: Make the segment last at least this long [s] (e.g. to arrive at a
                moving item exactly when it gets there); `None` for time-optimal.
            slow: Plan with the limits of the motion played `slow` (>= 1) times slower, e.g.
                for a gentle touch-down.

        Raises:
            PlannerInputError: the states are outside the limits, the segment leaves the
                workspace, or no slowed re-plan meets the motor speed and torque limits.
        """
        [job] = self._plan_jobs([(start, goal, label, minimum_duration, slow)])
        self.last_retimes = job.retimes
        if job.error is not None:
            raise job.error
        return job.planned()

    def plan_many(self, requests: Sequence[tuple]) -> list[RuckigSegment | PlannerInputError]:
        """`plan` of several segments, each (start, goal, label, minimum_duration, slow) as
        `plan` takes them: each is planned and re-planned slower exactly as `plan` alone would,
        with the motor checks of every segment still open made together, one evaluation per
        round of re-plans (far fewer, larger numpy calls).

        Returns:
            Per request, its segment, or the `PlannerInputError` that `plan` would raise.
        """
        return [
            job.planned() if job.error is None else job.error for job in self._plan_jobs(requests)
        ]

    def _plan_jobs(self, requests: Sequence[tuple]) -> list[_Job]:
        """The `_Job` of each request of `plan_many`, run to its end."""
        jobs = [_Job(*request) for request in requests]
        for job in jobs:
            limits = self.limits if job.slow == 1.0 else _guarded(self.limits.slowed, job.slow)
            self._replan(job, limits)
        for _ in range(self.max_retimes + 1):
            open_ = [job for job in jobs if job.error is None and not job.done]
            if not open_:
                break
            for job, (speed, torque) in zip(
                open_, self.limit_ratios_of([job.planned() for job in open_]), strict=True
            ):
                if speed <= 1.0 and torque <= 1.0:
                    job.done = True
                elif not (np.isfinite(speed) and np.isfinite(torque)):
                    job.error = PlannerInputError(
                        "goal", "a segment inside the reachable workspace", job.label
                    )
                else:
                    # Speeds scale with 1/factor, the inertial part of the torque with 1/factor^2.
                    job.factor *= min(max(speed, np.sqrt(torque)), 2.0) * 1.01
                    self._replan(job, _guarded(self.limits.slowed, job.factor))
                    job.retimes += 1
        for job in jobs:
            if job.error is None and not job.done:
                job.error = PlannerInputError(
                    "goal", "boundary states within the motor limits", job.label
                )
        return jobs

    def _replan(self, job: _Job, limits: MotionLimits | PlannerInputError) -> None:
        """Plan `job`'s segment (again) with `limits`, or record why it cannot be."""
        if isinstance(limits, PlannerInputError):
            job.error = limits
            return
        try:
            traj = self._calculate(job.start, job.goal, limits, job.minimum_duration)
        except PlannerInputError as exc:
            job.error = exc
            return
        job.segment = RuckigSegment(traj, limits, job.label)


@dataclass(eq=False)
class _Job:
    """One segment of `RuckigTrajectoryGenerator.plan_many` on its way through the re-plans."""

    start: State
    goal: State
    label: str = ""
    minimum_duration: float | None = None
    slow: float = 1.0
    segment: RuckigSegment | None = None
    factor: float = field(init=False)
    retimes: int = 0
    done: bool = False
    error: PlannerInputError | None = None

    def __post_init__(self):
        self.factor = self.slow

    def planned(self) -> RuckigSegment:
        """The segment of a job without an error (every such job has one)."""
        assert self.segment is not None
        return self.segment


def _guarded(slowed, factor: float) -> MotionLimits | PlannerInputError:
    """`slowed(factor)`, or the `PlannerInputError` it raises."""
    try:
        return slowed(factor)
    except PlannerInputError as exc:
        return exc


def _check_samples(segments: Sequence[RuckigSegment]):
    """(samples per segment (S,), TCP positions, velocities and accelerations (N, 3)) of the
    segments' check samples (`RuckigSegment.sample_xyz` every `CHECK_DT`), stacked."""
    tables = [s._phase_tables() for s in segments]
    if all(t is not None for t in tables):
        return stacked_xyz(tables, [s.duration for s in segments], CHECK_DT)
    samples = [s.sample_xyz(CHECK_DT) for s in segments]  # a brake phase somewhere: one by one
    sizes = np.array([len(p) for p, _, _ in samples])
    return (sizes, *(np.concatenate(column) for column in zip(*samples, strict=True)))


PHASES = 7
"""Jerk-constant phases of a ruckig profile."""

_COORDINATES = np.arange(4)


def phase_tables_of(traj) -> np.ndarray | None:
    """A ruckig trajectory's phase tables: (5, 4, 8) per coordinate (rows) the phase start
    times (0, then the ends of the seven phases) [s], the start positions, velocities,
    accelerations and jerks (0 after the last phase); None where the evaluation here does not
    apply (brake phases, several sections, phase ends out of order)."""
    profiles = traj.profiles
    if len(profiles) != 1:
        return None
    values: list[float] = []
    for p in profiles[0]:
        if p.brake.duration != 0.0 or p.accel.duration != 0.0:
            return None
        # The phase ends as np.cumsum adds them (in order, one at a time).
        ends = list(itertools.accumulate(p.t))
        if not all(b - a >= 0.0 for a, b in itertools.pairwise(ends)):
            return None
        values += (0.0, *ends, *p.p, *p.v, *p.a, *p.j, 0.0)
    return np.array(values).reshape(4, 5, 8).transpose(1, 0, 2)


def evaluate(tables: np.ndarray, t: np.ndarray, duration: float, dofs: int):
    """Positions, velocities and accelerations (n, dofs) of the first `dofs` coordinates at
    the times `t` (n,) [s], within the segment of `duration` [s] whose phase tables are
    `tables` (`phase_tables_of`)."""
    index = _phase_index(tables[0, :dofs, 1:, None], t)
    index[t >= duration] = PHASES
    index += _COORDINATES[:dofs] * 8  # into the flat (4, 8) tables
    return _polynomials(t, *np.take(tables.reshape(5, -1), index, axis=1))


def _phase_index(ends: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The phase of each time and coordinate (n, dofs), row-major: how many of the phase ends
    `ends` (dofs, 7, n or 1) [s] are at or before the time `t` (n,) [s] (ruckig's upper
    bound in the phase ends). Row-major so that the states are too: sums over them take
    their order from their layout."""
    counts = (ends <= t).view(np.uint8).sum(axis=1, dtype=np.uint8)  # (dofs, n), at most 7
    return counts.T.astype(np.intp, order="C")


def _polynomials(t, start, p0, v0, a0, j):
    """Position, velocity and acceleration at times `t` (n,) [s] in phases starting at `start`
    (n, dofs) [s] in the state (p0, v0, a0) with jerk j, each (n, dofs): ruckig's operations,
    p + d (v + d (a/2 + d j / 6)), v + d (a + d j / 2) and a + d j (d j computed once)."""
    d = t[:, None] - start
    dj = d * j
    return p0 + d * (v0 + d * (a0 / 2 + dj / 6)), v0 + d * (a0 + dj / 2), a0 + dj


def sorted_once(times: np.ndarray) -> np.ndarray:
    """`np.unique(times)` (sorted, each value once) without its overhead on short arrays."""
    times = np.sort(times)
    keep = np.empty(times.shape, dtype=bool)
    keep[:1] = True
    np.not_equal(times[1:], times[:-1], out=keep[1:])
    return times[keep]


def stacked_xyz(tables: list[np.ndarray], durations: list[float], dt: float):
    """The check samples of several segments in one pass: per segment the times of
    `RuckigSegment.sample_times` (every `dt` [s] from 0, every jerk switch and the end,
    sorted, each once), stacked segment after segment.

    Args:
        tables: Each segment's phase tables (`phase_tables_of`, none None).
        durations: Each segment's duration [s].
        dt: Grid step [s].

    Returns:
        (sizes (S,) samples per segment, positions, velocities, accelerations (N, 3) of x, y
        and z), each sample's numbers exactly those of `evaluate` on its segment alone.
    """
    tab = np.stack(tables, axis=1)  # (5, S, 4, 8)
    times, end, segment = _stacked_times(tab[0], durations, dt)
    t = np.minimum(np.maximum(times, 0.0), end)  # clamped as `states_at` clamps
    ends = np.ascontiguousarray(tab[0, :, :3, 1:].transpose(1, 2, 0))  # (3, 7, S)
    index = _phase_index(np.take(ends, segment, axis=2), t)  # (np.take: far cheaper here)
    index[t >= end] = PHASES
    index += (segment * 32)[:, None] + _COORDINATES[:3] * 8  # into the flat (S, 4, 8) tables
    sizes = np.bincount(segment, minlength=len(tables))
    return (sizes, *_polynomials(t, *np.take(tab.reshape(5, -1), index, axis=1)))


def _stacked_times(starts: np.ndarray, durations: list[float], dt: float):
    """(times (N,), each one's segment's duration (N,), segment index (N,)) of the check
    times of segments whose phase starts are `starts` (S, 4, 8) [s], each segment's times
    those of `RuckigSegment.sample_times`, stacked."""
    count = len(durations)
    lengths = [math.ceil(d / dt) for d in durations]  # np.arange(0.0, d, dt)'s length
    grid = _grid(dt, max(lengths))
    dur = np.array(durations)
    # The jerk switches: the phase starts, offset by a zero brake phase (0.0 + -0.0 is 0.0),
    # within the segment (`RuckigSegment.breakpoints`; np.clip, of numbers none nan).
    jerks = np.minimum(np.maximum(0.0 + starts.reshape(count, -1), 0.0), dur[:, None])
    blocks = [
        np.sort(np.concatenate([grid[:n], jerks[s], dur[s : s + 1]])) for s, n in enumerate(lengths)
    ]
    times = np.concatenate(blocks)
    keep = np.empty(times.shape, dtype=bool)  # the first of equal times, per segment
    np.not_equal(times[1:], times[:-1], out=keep[1:])
    sizes = [len(b) for b in blocks]
    keep[[0, *itertools.accumulate(sizes[:-1])]] = True
    segment = np.repeat(np.arange(count), sizes)[keep]
    return times[keep], np.take(dur, segment), segment


_GRIDS: dict[float, np.ndarray] = {}


def _grid(dt: float, length: int) -> np.ndarray:
    """np.arange(0.0, d, dt) for any d of at most `length` steps, as a prefix of one longer
    grid (its values are i dt whatever its length)."""
    grid = _GRIDS.get(dt)
    if grid is None or len(grid) < length:
        grid = _GRIDS[dt] = np.arange(0.0, max(length, 4096) * dt, dt)
    return grid
