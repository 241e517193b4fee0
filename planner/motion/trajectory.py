"""Trajectory interface: TCP states, segments, chains of segments and their sampling.

A trajectory moves the tool centre point (the cup's lip) in four coordinates, `(x, y, z, axis4)`
[m, m, m, rad] in the world frame. Backends (e.g. `planner.motion.ruckig_trajectory`) implement
`TrajectoryGenerator.plan`; everything here is pure numpy and never touches a simulator.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from planner.errors import PlannerInputError

DOF = 4


def _vec4(value, name: str) -> np.ndarray:
    arr = np.array(value, dtype=float).reshape(-1)
    # (math.isfinite on the four floats: a State is made thousands of times per plan)
    if arr.shape != (DOF,) or not all(map(math.isfinite, arr.tolist())):
        raise PlannerInputError(name, "4 finite numbers (x, y, z [m], axis4 [rad])", value)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class State:
    """Kinematic state of the TCP.

    Attributes:
        position: (x, y, z [m], axis4 [rad]).
        velocity: Its time derivative [m/s, rad/s]; zero by default.
        acceleration: Second derivative [m/s^2, rad/s^2]; zero by default.
    """

    position: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(DOF))
    acceleration: np.ndarray = field(default_factory=lambda: np.zeros(DOF))

    def __post_init__(self):
        object.__setattr__(self, "position", _vec4(self.position, "position"))
        object.__setattr__(self, "velocity", _vec4(self.velocity, "velocity"))
        object.__setattr__(self, "acceleration", _vec4(self.acceleration, "acceleration"))

    @classmethod
    def at_rest(cls, xyz: Sequence[float] | np.ndarray, axis4: float = 0.0) -> State:
        """A state at rest at `xyz` [m] with axis 4 at `axis4` [rad]."""
        return cls(np.array([xyz[0], xyz[1], xyz[2], axis4], dtype=float))


@dataclass(frozen=True)
class SampledTrajectory:
    """A trajectory sampled on a uniform time grid (the last sample is the exact end).

    Attributes:
        time: (N,) sample times from 0 [s].
        position: (N, 4) positions [m, rad].
        velocity: (N, 4) velocities [m/s, rad/s].
        acceleration: (N, 4) accelerations [m/s^2, rad/s^2].
    """

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


class Segment(abc.ABC):
    """One piece of a trajectory, defined on `[0, duration]`."""

    label: str = ""

    @property
    @abc.abstractmethod
    def duration(self) -> float:
        """Length of the segment [s]."""

    @abc.abstractmethod
    def at_time(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at time `t` [s] (clamped to the segment)."""

    def states_at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations (n, 4) at `times` (n,) [s], each as
        `at_time` gives it (backends evaluate all times at once)."""
        out = np.empty((3, len(times), DOF))
        for k, t in enumerate(times):
            out[0, k], out[1, k], out[2, k] = self.at_time(float(t))
        return out[0], out[1], out[2]

    @property
    def start(self) -> State:
        """State at t = 0."""
        return State(*self.at_time(0.0))

    @property
    def end(self) -> State:
        """State at t = duration."""
        return State(*self.at_time(self.duration))


class Dwell(Segment):
    """Constant-velocity motion (zero velocity: a pause), e.g. the cup sealing on a moving item.

    Args:
        start: Start state; its acceleration must be zero.
        duration: Length [s], >= 0.
    """

    def __init__(self, start: State, duration: float, label: str = "dwell"):
        if not np.isfinite(duration) or duration < 0:
            raise PlannerInputError("duration", "a finite number >= 0 [s]", duration)
        if np.any(start.acceleration != 0.0):
            raise PlannerInputError("start.acceleration", "zero for a dwell", start.acceleration)
        self._start = start
        self._duration = float(duration)
        self.label = label

    @property
    def duration(self) -> float:
        return self._duration

    def at_time(self, t: float):
        t = min(max(t, 0.0), self._duration)
        pos = self._start.position + self._start.velocity * t
        return pos, self._start.velocity.copy(), np.zeros(DOF)

    def states_at(self, times: np.ndarray):
        t = np.minimum(np.maximum(np.asarray(times, dtype=float), 0.0), self._duration)
        pos = self._start.position + self._start.velocity * t[:, None]
        vel = np.broadcast_to(self._start.velocity, pos.shape).copy()
        return pos, vel, np.zeros_like(pos)


class Chain:
    """Segments played one after another (each segment must start where the last one ended)."""

    def __init__(self, segments: Sequence[Segment]):
        if not segments:
            raise PlannerInputError("segments", "at least one segment", segments)
        self.segments = list(segments)
        self.starts = np.concatenate([[0.0], np.cumsum([s.duration for s in self.segments])])

    @property
    def duration(self) -> float:
        """Total length [s]."""
        return float(self.starts[-1])

    def phase_start(self, label: str) -> float:
        """Start time [s] of the first segment called `label`."""
        for seg, t0 in zip(self.segments, self.starts, strict=False):
            if seg.label == label:
                return float(t0)
        raise PlannerInputError("label", f"one of {[s.label for s in self.segments]}", label)

    def at_time(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at time `t` [s] (clamped to the chain)."""
        i = int(np.searchsorted(self.starts, t, side="right")) - 1
        i = min(max(i, 0), len(self.segments) - 1)
        return self.segments[i].at_time(t - self.starts[i])

    def states_at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations (n, 4) at `times` (n,) [s], each exactly
        as `at_time` gives it, evaluated segment by segment in one go."""
        times = np.asarray(times, dtype=float)
        index = np.clip(
            np.searchsorted(self.starts, times, side="right") - 1, 0, len(self.segments) - 1
        )
        out = np.empty((3, times.size, DOF))
        if times.size and (index[1:] >= index[:-1]).all():  # in order: one run per segment
            firsts = np.flatnonzero(index[1:] != index[:-1]) + 1
            for lo, hi in zip([0, *firsts.tolist()], [*firsts.tolist(), times.size], strict=True):
                i = index[lo]
                out[0, lo:hi], out[1, lo:hi], out[2, lo:hi] = self.segments[i].states_at(
                    times[lo:hi] - self.starts[i]
                )
            return out[0], out[1], out[2]
        for i in np.unique(index):
            rows = index == i
            out[0, rows], out[1, rows], out[2, rows] = self.segments[i].states_at(
                times[rows] - self.starts[i]
            )
        return out[0], out[1], out[2]

    def sample(self, dt: float) -> SampledTrajectory:
        """Samples every `dt` [s] from 0, plus the exact end point."""
        if not np.isfinite(dt) or dt <= 0:
            raise PlannerInputError("dt", "a finite number > 0 [s]", dt)
        n = int(np.floor(self.duration / dt + 1e-9))
        times = np.arange(n + 1) * dt
        if self.duration - times[-1] > 1e-12:
            times = np.append(times, self.duration)
        return SampledTrajectory(times, *self.states_at(times))


@dataclass(frozen=True, eq=False)
class Waypoint:
    """A point the chain passes through.

    Attributes:
        position: (x, y, z [m], axis4 [rad]).
        velocity: Velocity at the point [m/s, rad/s]; `None` marks a corner whose velocity the
            blending chooses (zero without blending).
        dwell: Time spent after arriving, moving at `velocity` (e.g. sealing, releasing) [s].
        label: Name of the segment that ends here.
        arrival_time: If set, arrive exactly at this time from the chain's start [s] (the
            segment is stretched with ruckig's minimum duration; it must be reachable by then).
        zone: How far [m] the chain may pass from a corner, along the corner's longer leg.
        slow: Plan the segment that ends here with the limits of a motion `slow` (>= 1) times
            slower (a gentle touch-down the servos can follow without lag).
    """

    position: np.ndarray
    velocity: np.ndarray | None = None
    dwell: float = 0.0
    label: str = ""
    dwell_label: str = "dwell"
    arrival_time: float | None = None
    zone: float = 0.0
    slow: float = 1.0

    def __post_init__(self):
        pos = np.asarray(self.position, dtype=float).reshape(DOF)
        object.__setattr__(self, "position", pos)
        if self.velocity is not None:
            object.__setattr__(self, "velocity", np.asarray(self.velocity, float).reshape(DOF))
        if not (np.isfinite(self.dwell) and self.dwell >= 0.0):
            raise PlannerInputError("dwell", "a finite time >= 0 [s]", self.dwell)
        if self.dwell > 0.0 and self.velocity is None:
            raise PlannerInputError("velocity", "given (not None) where the chain dwells", None)
        if not (np.isfinite(self.slow) and self.slow >= 1.0):
            raise PlannerInputError("slow", "a finite factor >= 1", self.slow)
        if not (np.isfinite(self.zone) and self.zone >= 0.0):
            raise PlannerInputError("zone", "a finite distance >= 0 [m]", self.zone)


class TrajectoryGenerator(abc.ABC):
    """Plans one state-to-state segment."""

    @abc.abstractmethod
    def plan(
        self,
        start: State,
        goal: State,
        label: str = "",
        minimum_duration: float | None = None,
        slow: float = 1.0,
    ) -> Segment:
        """The fastest segment from `start` to `goal` within the generator's limits.

        Args:
            minimum_duration: Make the segment last at least this long [s]; `None`: time-optimal.
            slow: Use the limits of the same motion played `slow` (>= 1) times slower.
        """
