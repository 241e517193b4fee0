"""Ruckig backend of the trajectory interface: time-optimal, jerk-limited state-to-state segments.

Each segment is one offline `ruckig.Ruckig.calculate` in the four TCP coordinates (x, y, z,
axis4), time-synchronised so every coordinate arrives together. Ruckig knows only per-coordinate
limits; the motors' speed limit is checked afterwards through the delta Jacobian
(`planner.motion.kinematics.jacobian`), and the motors' torque through the lumped dynamics
(`planner.motion.dynamics`) when given, and where either is exceeded the segment is re-planned with
the
limits of a uniformly slowed motion (`MotionLimits.slowed`) until both hold.
"""

from __future__ import annotations

import numpy as np
from ruckig import InputParameter, Result, Ruckig, RuckigError
from ruckig import Trajectory as _RuckigTrajectory

from planner.errors import PlannerInputError
from planner.motion.dynamics import LumpedDynamics
from planner.motion.kinematics import DeltaGeometry, angles_and_reachability
from planner.motion.limits import MotionLimits
from planner.motion.motor_rates import motor_rates, motor_rates_at_angles
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
_COORDINATES = np.arange(DOF)


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
        ends, starts, phase_p, phase_v, phase_a, phase_j = tables
        # The phase of each time and coordinate (n, 4): ruckig's upper bound in the phase ends,
        # 7 (the final state) past the last phase and at the segment's end.
        index = np.sum(ends <= t[:, None, None], axis=2)
        index[t >= self._duration] = 7
        d = t[:, None] - starts[_COORDINATES, index]
        p0 = phase_p[_COORDINATES, index]
        v0 = phase_v[_COORDINATES, index]
        a0 = phase_a[_COORDINATES, index]
        j = phase_j[_COORDINATES, index]
        return (
            p0 + d * (v0 + d * (a0 / 2 + d * j / 6)),
            v0 + d * (a0 + d * j / 2),
            a0 + d * j,
        )

    def _phase_tables(self):
        """Per coordinate (rows of (4, 7) or (4, 8) arrays): phase end times [s], phase start
        times (0, then the ends) [s], start positions, velocities, accelerations and jerks
        (0 after the last phase); None where the vectorised evaluation does not apply (brake
        phases, several sections, phase ends out of order)."""
        if self._tables is not _NOT_BUILT:
            return self._tables
        profiles = self._traj.profiles
        tables = None
        if len(profiles) == 1 and all(
            p.brake.duration == 0.0 and p.accel.duration == 0.0 for p in profiles[0]
        ):
            section = profiles[0]
            ends = np.cumsum([p.t for p in section], axis=1)
            if np.all(np.diff(ends, axis=1) >= 0.0):
                tables = (
                    ends,
                    np.concatenate([np.zeros((DOF, 1)), ends], axis=1),
                    np.array([p.p for p in section]),
                    np.array([p.v for p in section]),
                    np.array([p.a for p in section]),
                    np.concatenate([np.array([p.j for p in section]), np.zeros((DOF, 1))], axis=1),
                )
        self._tables = tables
        return tables

    def position_range(self, dof: int) -> tuple[float, float]:
        """Lowest and highest position of coordinate `dof` over the segment (exact)."""
        ext = self._traj.position_extrema[dof]
        return ext.min, ext.max

    def breakpoints(self) -> np.ndarray:
        """Times [s] where some coordinate's jerk switches (its acceleration peaks there)."""
        tables = self._phase_tables()
        if tables is not None:
            # The phase starts, offset by the zero brake phase as below (0.0 + -0.0 is 0.0).
            return np.clip(0.0 + tables[1].ravel(), 0.0, self._duration)
        times = []
        for section in self._traj.profiles:
            for prof in section:
                t0 = prof.brake.duration
                times.append(t0 + np.concatenate([[0.0], np.cumsum(prof.t)]))
        return np.clip(np.concatenate(times), 0.0, self._duration)

    def sample_states(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Times (N,) every `dt` [s], at every jerk switch and at the end, and the positions,
        velocities and accelerations (N, 4) there."""
        grid = np.append(np.arange(0.0, self._duration, dt), self._duration)
        times = np.unique(np.concatenate([grid, self.breakpoints()]))
        return (times, *self.states_at(times))


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
        if self.geometry is None:
            return 0.0, 0.0
        times, pos, vel, acc = segment.sample_states(CHECK_DT)
        q, reachable = angles_and_reachability(self.geometry, pos[:, :3])
        if not np.all(reachable):
            return np.inf, np.inf
        rates = motor_rates_at_angles(self.geometry, q, pos[:, :3], vel[:, :3], acc[:, :3])
        speed = float(np.max(np.abs(rates.qdot))) / self.limits.motor_velocity
        if self.dynamics is None:
            return speed, 0.0
        d = self.dynamics
        tau = d.torque(rates.q, rates.qdot, rates.qddot, rates.jac, acc[:, :3])
        return speed, float(np.max(np.abs(tau))) / (TORQUE_MARGIN * self.dynamics.torque_limit)

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
            start: Start state.
            goal: Goal state.
            label: Name of the phase.
            minimum_duration: Make the segment last at least this long [s] (e.g. to arrive at a
                moving item exactly when it gets there); `None` for time-optimal.
            slow: Plan with the limits of the motion played `slow` (>= 1) times slower, e.g.
                for a gentle touch-down.

        Raises:
            PlannerInputError: the states are outside the limits, the segment leaves the
                workspace, or no slowed re-plan meets the motor speed and torque limits.
        """
        limits = self.limits if slow == 1.0 else self.limits.slowed(slow)
        segment = RuckigSegment(
            self._calculate(start, goal, limits, minimum_duration), limits, label
        )
        self.last_retimes = 0
        factor = slow
        for _ in range(self.max_retimes + 1):
            speed, torque = self.limit_ratios(segment)
            if speed <= 1.0 and torque <= 1.0:
                return segment
            if not (np.isfinite(speed) and np.isfinite(torque)):
                raise PlannerInputError("goal", "a segment inside the reachable workspace", label)
            # Speeds scale with 1/factor, the inertial part of the torque with 1/factor^2.
            factor *= min(max(speed, np.sqrt(torque)), 2.0) * 1.01
            limits = self.limits.slowed(factor)
            traj = self._calculate(start, goal, limits, minimum_duration)
            segment = RuckigSegment(traj, limits, label)
            self.last_retimes += 1
        raise PlannerInputError("goal", "boundary states within the motor limits", label)
