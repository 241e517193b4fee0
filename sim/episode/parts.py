"""The parts of one episode, made afresh at each reset (`sim.episode.builder.build_parts`): one
frozen value (`EpisodeParts`) that the loop, the scheduled events and the hooks read, and the
episode's time: when it ends (`Timeline`, `Horizon`), the step just made (`StepClock`) and where
the wall time went (`Timings`).

The value never changes; what changes during an episode lives in named objects, each written
through its own methods: the offers (`sim.episode.stations.Offers`: failures, waits, the items
last offered), the clocks here, the robots' stations (`sim.episode.stations.RobotStation`), the
metrics, the tracker, the items' riding and the infeed. A user's hook or periodic function
(`Episode.add_hook`, `Episode.every`) is called with this value.
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np

from sim.cell.cell import Cell
from sim.cell.held_slots import held_slots
from sim.cell.riding import ItemRiding
from sim.config import EpisodeConfig
from sim.config.faults import Fault, FaultSchedule
from sim.episode.infeed import Infeed
from sim.episode.stations import Offers, RobotStation
from sim.flow.config import X_INFEED
from sim.flow.generator import Flow
from sim.monitors.bins import Bins
from sim.monitors.energy import ActuatorLog
from sim.monitors.mj_warnings import WarningCounter
from sim.monitors.thrown import ThrowWatch
from sim.results.metrics import EpisodeMetrics
from sim.sensing.tracking import Detection, Track, Tracker

DUE_TOLERANCE_S = 1e-9
"""An event whose time is at most this far ahead of the clock is due [s] (the clock sums
steps: 0.001 s steps reach 0.5 s a rounding error early)."""
DISCARD_MARGIN_M = 0.15
"""An item this far past the reachable window's downstream edge is out of the robot's reach
(the scene's cup radius and the item's half length included; a larger cup adds its extra
radius, `Cell.cup_extra_m`) [m]."""
SETTLE_S = 2.0
"""Time after the last item left before the episode may end (falls into bins) [s]."""
TIMED_STAGES = ("physics", "perception", "decision", "planning", "video")
"""The stages every episode's timings hold ("visibility" is added when used)."""


def is_due(t: float, when: float) -> bool:
    """Whether something due at `when` [s] is due at sim time `t` [s]."""
    return t + DUE_TOLERANCE_S >= when


class Perception(Protocol):
    """What reports the items crossing the camera line (`sim.sensing.truth.TruthPerception`,
    the camera pipelines of `sim.sensing.perception`)."""

    def observe(self, t: float, blind: frozenset[int] = frozenset()) -> list[Detection]:
        """The detections at sim time `t` [s]; none from the cameras in `blind` (indices,
        upstream first: an outage)."""

    def close(self) -> None:
        """Release what it holds (a renderer)."""


class Horizon:
    """The time an episode ends at, whatever is left (the config's `horizon_s`): an event,
    so the physics is stepped up to it exactly (the loop ends the episode once it is reached).

    Args:
        at_s: The horizon [s].
    """

    def __init__(self, at_s: float):
        self.at_s = at_s
        self.reached = False

    def due(self, t: float) -> bool:
        return not self.reached and is_due(t, self.at_s)

    def next_time(self, t: float) -> float | None:
        return None if self.reached else self.at_s

    def fire(self, parts: object) -> None:
        """Mark the horizon reached: the episode ends after this step."""
        self.reached = True


@dataclass(frozen=True)
class Timeline:
    """When an episode's items have passed and when it must end.

    Attributes:
        t_last_spawn: When the last item drops [s].
        x_discard: Where an unpicked item is out of every robot's reach [m].
        t_end: When the last item has passed the robots and settled: a normal end, or the
            horizon when that comes first [s].
        t_cap: The latest end [s].
        horizon: The event of the config's `horizon_s` (None: the run ends when the belt is
            clear).
    """

    t_last_spawn: float
    x_discard: float
    t_end: float
    t_cap: float
    horizon: Horizon | None = None

    @classmethod
    def of(
        cls,
        cell: Cell,
        flow: Flow,
        belt_speed: float,
        horizon_s: float | None = None,
        delay_s: float = 0.0,
    ) -> Timeline:
        """The timeline of `flow` on `cell` at `belt_speed` [m/s], ended at `horizon_s` [s], the
        belt and infeed delayed by `delay_s` [s] (stopped or slowed by faults)."""
        t_last_spawn = (float(flow.t_spawn[-1]) if len(flow) else 0.0) + delay_s
        x_discard = float(np.nanmax(cell.window.x_exit)) + DISCARD_MARGIN_M + cell.cup_extra_m
        t_end = t_last_spawn + (x_discard - X_INFEED) / belt_speed + SETTLE_S
        horizon = None if horizon_s is None else Horizon(float(horizon_s))
        t_stop = t_end if horizon is None else min(t_end, horizon.at_s)
        return cls(t_last_spawn, x_discard, t_stop, t_end + 10.0, horizon)

    @property
    def at_horizon(self) -> bool:
        """Whether the episode has reached its horizon (it ends there, whatever is left)."""
        return self.horizon is not None and self.horizon.reached


class StepClock:
    """The physics step (or chunk, or block of steps) under way or made last; written by the
    loop only."""

    def __init__(self):
        self.last_step_s = 0.0
        """Duration of the last physics step, or block of steps [s]."""
        self.busy: Sequence[RobotStation] = ()
        """The stations playing a pick in the step under way."""

    def stepping(self, busy: Sequence[RobotStation]) -> None:
        """A step begins with `busy` playing picks."""
        self.busy = busy

    def stepped(self, duration_s: float) -> None:
        """The step just made covered `duration_s` [s]."""
        self.last_step_s = duration_s


MAX_LATENCIES = 20_000
"""Latencies kept per stage: every call's up to this many, then a uniform sample of them all
of this size (reservoir sampling), so a shift's memory stays flat; percentiles of a long run
are then estimates from the sample."""


class Timings:
    """Wall time spent per stage of an episode [s], the calls' latencies kept for some stages
    (at most `MAX_LATENCIES` each), and the decisions asked."""

    def __init__(self):
        self.seconds: dict[str, float] = dict.fromkeys(TIMED_STAGES, 0.0)
        self.latencies: dict[str, list[float]] = {"perception": [], "decision": [], "plan": []}
        self.calls: dict[str, int] = dict.fromkeys(self.latencies, 0)
        self.decisions = 0
        self._sample = random.Random(0)  # its own stream: wall times never touch the episode's

    def add(self, stage: str, seconds: float, latency: str | None = None) -> None:
        """`seconds` [s] more spent in `stage`; also one latency of `latency` when given."""
        self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds
        if latency is None:
            return
        kept, n = self.latencies[latency], self.calls[latency]
        self.calls[latency] = n + 1
        if n < MAX_LATENCIES:
            kept.append(seconds)
        elif (k := self._sample.randrange(n + 1)) < MAX_LATENCIES:
            kept[k] = seconds

    def decided(self, seconds: float) -> None:
        """A decision manager was asked once, taking `seconds` [s]."""
        self.add("decision", seconds, "decision")
        self.decisions += 1


class FaultState(Protocol):
    """What the faults have failed now (`sim.episode.faults.cell_faults.CellFaults`)."""

    blind_cameras: frozenset[int]

    def active(self, t: float) -> tuple[Fault, ...]:
        """The faults holding at sim time `t` [s]."""

    def robot_state(self, k: int, t: float) -> str:
        """Robot `k`'s state at sim time `t` [s]: "stopped", "picking" or "idle"."""


@dataclass(frozen=True)
class EpisodeParts:
    """What one episode is made of (see the module docstring).

    Attributes:
        config: The episode's configuration (its seed the one reset with).
        cell: The compiled cell it runs on.
        flow: The items dropped, their times and types.
        timeline: When the items have passed and when the episode must end.
        metrics: The episode's counters (episodes.csv, picks.csv).
        tracker: The tracked items.
        offers: What the decision managers are offered.
        stations: The robots, upstream first.
        perception: What reports the items crossing the camera line (`observe(t)`, `close()`).
        infeed: The items' drops.
        riding: Which items ride the belt without contact dynamics.
        bins: The landings in the bins.
        actuator_log: The actuators' power per step, read by the energy meters.
        mj_warnings: MuJoCo's warning counts.
        throw_watch: Items thrown off the belt.
        clock: The physics step.
        timings: Where the wall time went.
        faults: The episode's faults (empty: nothing fails).
        fault_state: What the faults have failed now (`robot_state(k, t)`, `active(t)`,
            `sim.episode.faults.cell_faults.CellFaults`).
    """

    config: EpisodeConfig
    cell: Cell
    flow: Flow
    timeline: Timeline
    metrics: EpisodeMetrics
    tracker: Tracker
    offers: Offers
    stations: tuple[RobotStation, ...]
    perception: Perception
    infeed: Infeed
    riding: ItemRiding
    bins: Bins
    actuator_log: ActuatorLog
    mj_warnings: WarningCounter
    throw_watch: ThrowWatch
    clock: StepClock
    timings: Timings
    faults: FaultSchedule
    fault_state: FaultState

    @property
    def model(self) -> mujoco.MjModel:
        return self.cell.model

    @property
    def data(self) -> mujoco.MjData:
        return self.cell.data

    @property
    def speed(self) -> float:
        """The belt's speed now [m/s] (the config's, but while a fault stops or slows it)."""
        return self.tracker.belt_speed

    @property
    def last_step_s(self) -> float:
        """Duration of the last physics step, or block of steps [s]."""
        return self.clock.last_step_s

    @property
    def current_pick(self) -> Track | None:
        """The track the first robot is picking (None when idle)."""
        return self.stations[0].current_pick

    def held(self) -> np.ndarray:
        """The pool slots the robots' cups hold now, robot by robot (`sim.cell.held_slots`)."""
        return held_slots(s.robot.suction.held_slot for s in self.stations)
