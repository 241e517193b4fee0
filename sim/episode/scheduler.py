"""What runs around each physics step and what is due at given times: hook lists and a
scheduler of events, in the manner of dm_control's composer.

Hooks (`Hooks`): every function registered on `"before_step"` runs before each physics step
(or each block of steps while every robot idles), every one on `"after_step"` after it, in the
order registered: the episode's own (`BEFORE_STEP`: the robots' set-points; `AFTER_STEP`: the
riders' belt time, the actuator log, the cups), then a user's. Events (`Scheduler`): the
infeed's drops, the observations, the item checks (warnings, throws, items out of reach, bins,
riding), the video frames, a user's periodic functions (`PeriodicEvent`) and the episode's
horizon (`sim.episode.parts.Horizon`), each with the next time it is due. After each step the
loop fires every event due, in the order registered, with the items brought up to date first;
while every robot idles it steps in one block up to the earliest next time (or decision). One
due test, `is_due`, serves both. Hooks and events are called with the episode's parts
(`sim.episode.parts.EpisodeParts`), not the episode.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from sim.cell.conveyor import BeltEncoder
from sim.checks import check, is_finite_number
from sim.episode.parts import DUE_TOLERANCE_S, EpisodeParts, is_due
from sim.errors import InvalidInput
from sim.results import timeline

HOOK_STAGES = ("before_step", "after_step")
"""Where a hook may run: before or after each physics step."""


def steps_until_due(t: float, when: float, dt: float) -> int:
    """Physics steps of `dt` [s] from sim time `t` [s] until something due at `when` [s] is
    due by `is_due` (at least one): the idle stepping's block, by the loop's own due test."""
    return max(1, math.ceil((when - t - DUE_TOLERANCE_S) / dt))


class Event(Protocol):
    """Something the scheduler fires when due."""

    def due(self, t: float) -> bool:
        """Whether it is due at sim time `t` [s]."""

    def next_time(self, t: float) -> float | None:
        """When it is due next [s] (None: never again), seen at sim time `t` [s]."""

    def fire(self, parts: EpisodeParts) -> None:
        """Do what is due."""


@dataclass(eq=False)
class PeriodicEvent:
    """A function called with the episode's parts every `period_s` of simulated time.

    Attributes:
        period_s: Its period [s].
        fn: Called with the episode's parts.
        next_s: When it is due next [s].
    """

    period_s: float
    fn: Callable[[EpisodeParts], object]
    next_s: float = 0.0

    def __post_init__(self) -> None:
        p = self.period_s
        ok = isinstance(p, int | float) and not isinstance(p, bool) and math.isfinite(p) and p > 0
        if not ok:
            raise InvalidInput("period_s", "a period > 0 s", p)
        if not callable(self.fn):
            raise InvalidInput("fn", "a function of the episode", self.fn)

    def due(self, t: float) -> bool:
        """Whether it is due at sim time `t` [s]."""
        return is_due(t, self.next_s)

    def next_time(self, t: float) -> float:
        """When it is due next [s]."""
        return self.next_s

    def fire(self, parts: EpisodeParts) -> None:
        """Call the function; due again a period later."""
        self.fn(parts)
        self.next_s += self.period_s


class BeltRowEvent:
    """A function called with the episode's parts each time the belt has run one row: the
    belt's clock (`sim.cell.conveyor.BeltEncoder.clock`) a multiple of `period_s`, as a
    line-scan camera's frames triggered by the belt's encoder. At the set speed it is due
    exactly when a `PeriodicEvent` of the period is; never while a fault stops the belt.

    Args:
        period_s: The belt's clock between rows [s] (the observation period), > 0.
        fn: Called with the episode's parts.
        encoder: The belt's encoder.
    """

    def __init__(self, period_s: float, fn: Callable[[EpisodeParts], object], encoder: BeltEncoder):
        self.clock = PeriodicEvent(period_s, fn)  # its next_s: the belt's clock of the next row
        self.encoder = encoder

    def due(self, t: float) -> bool:
        """Whether the belt has run to the next row at sim time `t` [s]."""
        when = self.encoder.time_at(self.clock.next_s)
        return when is not None and is_due(t, when)

    def next_time(self, t: float) -> float | None:
        """When the belt will have run to the next row at its speed now [s] (None: stopped)."""
        return self.encoder.time_at(self.clock.next_s)

    def fire(self, parts: EpisodeParts) -> None:
        """Call the function; due again a row later."""
        self.clock.fire(parts)


class FrameEvent:
    """The frame sink's frames (`sim.render.sink.FrameSink`: the video or the live view),
    each with the overlay the episode builds (`sim.episode.overlay`).

    Args:
        sink: Where the frames go.
        overlay: Builds a frame's overlay from the episode's parts and the sim time [s].
    """

    def __init__(self, sink, overlay: Callable[[EpisodeParts, float], object]):
        self.sink, self.overlay = sink, overlay

    def due(self, t: float) -> bool:
        """Whether the sink wants a frame at sim time `t` [s]."""
        return self.sink.due(t)

    def next_time(self, t: float) -> float:
        """When the sink wants its next frame [s]."""
        return self.sink.next_frame_time

    def fire(self, parts: EpisodeParts) -> None:
        """Hand the sink the cell as it is now and the overlay (timed as "video")."""
        t0 = time.perf_counter()
        overlay = self.overlay(parts, float(parts.data.time))
        self.sink.capture(parts.cell.items.current(), overlay)
        parts.timings.add("video", time.perf_counter() - t0)


class TimelineEvent:
    """A timeline row (`sim.results.timeline`) every `period_s` [s], handed to `sink`.

    It never sets where the loop stops (`next_time` is None): it is sampled at the first stop
    the loop makes for another event at or after its time (the item checks stop it every
    `CHECK_PERIOD_S`), so the physics steps exactly as without it; a row's `t_s` is the time
    it was sampled. Registered after the episode's own events: the row counts what they booked
    at that step.

    Args:
        period_s: The timeline's period [s], > 0.
        sink: Called with each row (`sim.results.timeline.TimelineWriter`).
    """

    def __init__(self, period_s: float, sink: Callable[[dict], object]):
        ok = is_finite_number(period_s) and period_s > 0
        check(ok, "timeline.period_s", "a period > 0 s", period_s)
        self.period_s, self.sink = float(period_s), sink
        self.next_s = self.period_s

    def due(self, t: float) -> bool:
        return is_due(t, self.next_s)

    def next_time(self, t: float) -> None:
        """Never: it rides on the other events' stops."""
        return None

    def fire(self, parts: EpisodeParts) -> None:
        """The row now; due again at the next multiple of the period after now."""
        t = float(parts.data.time)
        self.sink(timeline_sample(parts, t))
        self.next_s = (math.floor((t + DUE_TOLERANCE_S) / self.period_s) + 1) * self.period_s


def timeline_sample(parts: EpisodeParts, t: float) -> dict:
    """The episode's timeline row at sim time `t` [s] (`sim.results.timeline.timeline_row`):
    the faults active then (`parts.faults`)."""
    schedule = parts.faults
    states = [timeline.robot_state(s.robot.busy, s.index, t, schedule) for s in parts.stations]
    active = schedule.active(t)
    on_belt = len(parts.cell.items.active_slots()) + len(parts.metrics.left_on_belt)
    return timeline.timeline_row(t, parts.metrics, on_belt, states, active)


class Scheduler:
    """The events of an episode, in the order they fire when due together."""

    def __init__(self):
        self.events: list[Event] = []
        self._earliest = -math.inf  # no event is due before this [s]; -inf: not known

    def add(self, event: Event) -> Event:
        """Register `event` (fired after the ones registered before it); returns it."""
        self.events.append(event)
        self._earliest = -math.inf
        return event

    def due(self, t: float) -> list[Event]:
        """The events due at sim time `t` [s], in order (all judged before any fires)."""
        if not is_due(t, self._earliest):  # none can be: skip asking each (every step)
            return []
        return [event for event in self.events if event.due(t)]

    def fire_due(self, parts: EpisodeParts, t: float, prepare: Callable[[], object]) -> None:
        """Fire every event due at sim time `t` [s], in order, after `prepare()` (once, when
        any is due); then note when the next one is due.

        Args:
            parts: Handed to each event.
            t: Sim time now [s].
            prepare: Called before the first event fires (the items brought up to date).
        """
        due = self.due(t)
        if due:
            prepare()
            for event in due:
                event.fire(parts)
        if due or self._earliest == -math.inf:
            self._earliest = self.next_time(t)

    def next_due(self, t: float) -> float:
        """The earliest time an event is due next [s] (inf: none), as kept between firings
        (`fire_due` notes it after each firing), seen at sim time `t` [s]."""
        if self._earliest == -math.inf:
            self._earliest = self.next_time(t)
        return self._earliest

    def next_time(self, t: float) -> float:
        """The earliest time an event is due next [s] (inf: none)."""
        times = (event.next_time(t) for event in self.events)
        return min((w for w in times if w is not None), default=math.inf)


class Hooks:
    """Functions run around each physics step, stage by stage, in the order registered."""

    def __init__(self):
        self._stages: dict[str, list[Callable[[EpisodeParts], object]]] = {
            s: [] for s in HOOK_STAGES
        }

    def add(self, stage: str, fn: Callable[[EpisodeParts], object]) -> None:
        """Run `fn(parts)` at `stage` ("before_step" or "after_step") from now on.

        Args:
            stage: One of `HOOK_STAGES`.
            fn: Called with the episode's parts.
        """
        if stage not in self._stages:
            raise InvalidInput("stage", " | ".join(HOOK_STAGES), stage)
        if not callable(fn):
            raise InvalidInput("fn", "a function of the episode", fn)
        self._stages[stage].append(fn)

    def run(self, stage: str, parts: EpisodeParts) -> None:
        """Run every hook of `stage` with `parts`."""
        for fn in self._stages[stage]:
            fn(parts)


def set_points(parts: EpisodeParts) -> None:
    """Before a step: the busy robots' set-points of the coming control period."""
    for station in parts.clock.busy:
        station.robot.before_step()


def carry_riders(parts: EpisodeParts) -> None:
    """After a step: the belt's time the riders are owed (`sim.cell.riding`)."""
    parts.riding.carry(parts.clock.last_step_s)


def log_actuators(parts: EpisodeParts) -> None:
    """After a step: the actuators' power over it, for the energy meters."""
    parts.actuator_log.record(parts.clock.last_step_s)


def cups(parts: EpisodeParts) -> None:
    """After a step: the busy robots' cups (seal, hold, release)."""
    for station in parts.clock.busy:
        station.robot.after_step()


BEFORE_STEP = (set_points,)
"""The episode's own before-step hooks, in order."""
AFTER_STEP = (carry_riders, log_actuators, cups)
"""The episode's own after-step hooks, in order."""
