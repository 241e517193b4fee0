"""The loop of one episode: the only place that steps the physics while an episode runs.

In the manner of dm_control's `Environment.step` with composer's hook lists. While robots play
their picks the physics runs in chunks up to the next event or idle robot's decision, each step
with its own work only (set-points, actuator log, riders' belt time, cups: `sim.episode.chunks`);
while every robot idles, in one block. After each chunk or block every scheduled event due fires
(`sim.episode.scheduler`: drops at the infeed, observations, the item checks of
`sim.episode.item_checks`, video frames, a user's `every`), then finished picks are booked. A
user's `add_hook("after_step" | "before_step", fn)` runs around every step (the loop then steps
one at a time, with the episode's own hooks, `sim.episode.scheduler.BEFORE_STEP`/`AFTER_STEP`).

`step_until_decision` advances until a robot is free and a choice is needed; `apply` takes the
choice (the configured decision manager's in `run`, or a Gymnasium agent's). The episode ends
when every item has been dropped and left the belt and every robot is idle, or at the config's
`horizon_s` (`sim.episode.parts.Timeline`). Its parts are made by `sim.episode.builder` into one
frozen `sim.episode.parts.EpisodeParts`, which hooks and events are called with.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import mujoco
import numpy as np

from planner.decision.interface import Choice, DecisionContext, RobotState, TrackedItem
from planner.decision.registry import ask_manager
from sim.cell.cell import Cell
from sim.cell.riding import PlannedPath
from sim.config import EpisodeConfig
from sim.config.faults import FaultSchedule
from sim.episode import builder, chunks, item_checks, stations
from sim.episode.builder import make_decision_manager
from sim.episode.overlay import overlay_of
from sim.episode.parts import SETTLE_S, EpisodeParts, Perception
from sim.episode.pick_control import PickController
from sim.episode.scheduler import (
    AFTER_STEP,
    BEFORE_STEP,
    FrameEvent,
    Hooks,
    PeriodicEvent,
    Scheduler,
    TimelineEvent,
    is_due,
    steps_until_due,
)
from sim.episode.stations import PickUnderWay, RobotStation
from sim.errors import CallOrderError, InvalidInput
from sim.monitors.energy import EnergyMeter
from sim.results.metrics import EpisodeMetrics
from sim.sensing.tracking import Tracker

__all__ = ["Episode", "make_decision_manager"]

DECIDE_PERIOD_S = 0.02
"""How often an idle robot asks the decision manager again [s]."""
MAX_LEAD_S = 1.0
"""A pick is started only if the cup meets the item within this time; an item further
upstream is waited for and decided on again (its position is fresher by then) [s]."""
WAIT_STEP_S = 0.25
"""Longest wait before deciding again on an item still upstream [s]."""
RETRY_AFTER_S = 0.25
"""An item the cup cannot meet now (a neighbour in the way, a plan outside the motor limits as
it enters the window) is offered again after this long, while it is still on the belt [s]. The
camera reports an item once; dropping its track would lose it for good."""


class Episode:
    """One episode on a `Cell`, steppable from outside (see the module docstring).

    Lifecycle as Gymnasium's `Env`: `reset(seed)`, then `step_until_decision()` and
    `apply(choice)` until the former returns False, then `close()`; usable with `with`.
    `run()` is that loop with the configured decision manager choosing. Its parts, made at
    each reset, are `parts` (`sim.episode.parts.EpisodeParts`); only this class writes its own
    attributes.

    Args:
        config: The episode's configuration.
        cell: The compiled cell it runs on (reset by `reset`).
        video: A frame sink (`sim.render.sink.FrameSink`: the video recorder, the live view),
            or None.
        progress: Called with (fraction, status line) about once per simulated second.
        planner: A decision manager object (`choose`, `reset`); the config's when omitted.
        wrap_perception: Called with the perception made at each reset; what it returns
            (`observe(t)`, `close()`) observes instead: a study's noisier or softened sensor.
        timeline: Called with a timeline row every `[timeline] period_s` (`TimelineEvent`),
            or None.
        faults: The faults of each episode (`sim.config.faults.FaultSchedule`); the config's
            when omitted.
    """

    def __init__(
        self,
        config: EpisodeConfig,
        cell: Cell,
        video=None,
        progress=None,
        planner=None,
        wrap_perception: Callable[[Perception], Perception] | None = None,
        timeline: Callable[[dict], object] | None = None,
        faults: FaultSchedule | None = None,
    ):
        self.config, self.cell, self.video, self.progress = config, cell, video, progress
        self.timeline = timeline
        self.faults = faults
        self.model, self.data = cell.model, cell.data
        self._timestep = float(self.model.opt.timestep)  # [s]
        self.planner = planner if planner is not None else make_decision_manager(config)
        self._wrap_perception = wrap_perception
        self.parts: EpisodeParts | None = None
        self._deciding: RobotStation | None = None
        self._candidates: list[TrackedItem] = []
        self._user_hooks: list[tuple[str, Callable[[EpisodeParts], object]]] = []
        self._user_events: list[PeriodicEvent] = []
        self.hooks, self.scheduler = Hooks(), Scheduler()
        self._last_report, self._closed_out = -1.0, False

    # ----- registration -------------------------------------------------------------------------

    def add_hook(self, stage: str, fn: Callable[[EpisodeParts], object]) -> None:
        """Run `fn(parts)` before or after every physics step (a block of steps while every
        robot idles), after the episode's own hooks; kept across resets. The loop then steps
        one at a time while picks are under way, instead of in chunks (`sim.episode.chunks`).

        Args:
            stage: "before_step" or "after_step".
            fn: Called with the episode's parts (`sim.episode.parts.EpisodeParts`: `data`,
                `cell`, `metrics`, `last_step_s`, `held()`, ...).
        """
        Hooks().add(stage, fn)  # refused here, before anything is registered
        self._user_hooks.append((stage, fn))
        if self.parts is not None:
            self.hooks.add(stage, fn)

    def every(self, period_s: float, fn: Callable[[EpisodeParts], object]) -> PeriodicEvent:
        """Call `fn(parts)` every `period_s` [s] of simulated time, from the start of each
        episode (or from now, registered during one), after the episode's own events due then;
        kept across resets. Returns the event (its `next_s` says when it is due next).

        Args:
            period_s: The period [s], > 0.
            fn: Called with the episode's parts (`sim.episode.parts.EpisodeParts`).
        """
        ready = self.parts is not None
        event = PeriodicEvent(period_s, fn, float(self.data.time) if ready else 0.0)
        self._user_events.append(event)
        if ready:
            self.scheduler.add(event)
        return event

    # ----- what is read from outside ------------------------------------------------------------

    @property
    def metrics(self) -> EpisodeMetrics:
        return self._ready().metrics

    @property
    def tracker(self) -> Tracker:
        return self._ready().tracker

    @property
    def perception(self):
        return self._ready().perception

    @property
    def speed(self) -> float:
        """The belt's speed [m/s]."""
        return self.config.belt_speed_mps

    @property
    def robot(self) -> PickController:
        """The pick controller of the robot deciding now (the first robot between decisions)."""
        return self._station().robot

    @property
    def context(self) -> DecisionContext:
        """The decision context of the robot deciding now (the first between decisions)."""
        return self._station().context

    @property
    def deciding_robot(self) -> int:
        """Index of the robot deciding now, 0 upstream (the first robot between decisions)."""
        return self._station().index

    @property
    def energy(self) -> EnergyMeter:
        """The first robot's motor energy meter (the line's: `parts.stations`)."""
        return self._ready().stations[0].energy

    @property
    def current_pick(self):
        """The track the first robot is picking (None when idle)."""
        return None if self.parts is None else self.parts.current_pick

    def _station(self) -> RobotStation:
        return self._deciding if self._deciding is not None else self._ready().stations[0]

    def _ready(self) -> EpisodeParts:
        """The parts of the episode under way (made by `reset`)."""
        if self.parts is None:
            raise CallOrderError("the episode has no parts before reset(seed): reset it first")
        return self.parts

    def __enter__(self) -> Episode:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close(aborted=exc_type is not None)

    # ----- lifecycle ----------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        """Start the episode afresh: the cell reset, the flow of `seed` (the config's when
        None), every counter at zero, the decision manager reset, the hooks and events
        registered again (a user's kept, due from the start)."""
        self.config = self.config if seed is None else replace(self.config, seed=int(seed))
        self.parts = builder.build_parts(
            self.config, self.cell, self.planner, self._wrap_perception, self.faults
        )
        self._deciding, self._candidates = None, []
        self._last_report, self._closed_out = -1.0, False
        self._register()

    def _register(self) -> None:
        """The episode's own hooks and events, then a user's."""
        parts = self._ready()
        self.hooks, self.scheduler = Hooks(), Scheduler()
        for fn in BEFORE_STEP:
            self.hooks.add("before_step", fn)
        for fn in AFTER_STEP:
            self.hooks.add("after_step", fn)
        for event in builder.own_events(parts):
            self.scheduler.add(event)
        if self.timeline is not None:
            self.scheduler.add(TimelineEvent(self.config.timeline.period_s, self.timeline))
        if self.video is not None:
            self.scheduler.add(FrameEvent(self.video, overlay_of))
        for stage, user_fn in self._user_hooks:
            self.hooks.add(stage, user_fn)
        for event in self._user_events:
            event.next_s = 0.0
            self.scheduler.add(event)
        if parts.timeline.horizon is not None:  # last: due at the horizon, it goes first
            self.scheduler.add(parts.timeline.horizon)

    def close(self, aborted: bool = False) -> None:
        """Release the perception's renderer and finish (or, `aborted`, discard) the video."""
        if self.parts is not None:
            self.parts.perception.close()
        if self.video is not None:
            if aborted:
                self.video.abort()
            else:
                self.video.close()
            self.video = None

    # ----- the public stepping interface --------------------------------------------------------

    def step_until_decision(self) -> bool:
        """Advance the physics until a robot is free and a choice is due among the tracked
        items (`candidates()`, `robot_state()`, `context`); False once the episode has ended."""
        if self.parts is None:
            self.reset()
        parts = self._ready()
        self._deciding = None
        while not self._finished():
            t = self.data.time
            items = None  # the tracked items now, once for every robot free now
            for station in parts.stations:
                if not station.robot.busy and is_due(t, station.next_decision):
                    station.decide_at(t + DECIDE_PERIOD_S)
                    if items is None:
                        items = parts.offers.items(t)
                    self._candidates = stations.line_offer(
                        parts.stations,
                        station,
                        items,
                        t,
                        self.config.coordination,
                        self.config.robot_class_ids,
                    )
                    if self._candidates:
                        self._deciding = station
                        self.cell.items.current()  # a decision and a plan see the items now
                        return True
            self._step()
        self.cell.items.current()
        readings = [s.energy.reading() for s in parts.stations]
        parts.metrics.on_energy(*(sum(r[i] for r in readings) for i in (0, 1)))
        self._close_out()
        return False

    def candidates(self) -> list[TrackedItem]:
        """The tracked items a choice is made among, at the current sim time."""
        return list(self._candidates)

    def robot_state(self) -> RobotState:
        """Where the deciding robot rests and the current sim time."""
        return RobotState(tuple(self.robot.rest), float(self.data.time))

    def choose(self) -> Choice | None:
        """The configured decision manager's choice now (timed for the benchmarks)."""
        t0 = time.perf_counter()
        station = self._station()
        choice = ask_manager(station.planner, self._candidates, self.robot_state(), station.context)
        self._ready().timings.decided(time.perf_counter() - t0)
        return choice

    def apply(self, choice: Choice | None) -> bool:
        """Act on a choice: start the pick when the cup can meet the item soon, else wait and
        decide again later (None: nothing now). True if a pick started."""
        t = float(self.data.time)
        t1 = time.perf_counter()
        if choice is None:
            return False
        parts, station = self._ready(), self._station()
        robot = station.robot
        if choice.meet_time - t > MAX_LEAD_S:
            # Far upstream: wait where we are and decide again with fresher positions.
            station.decide_at(t + min(choice.meet_time - t - MAX_LEAD_S, WAIT_STEP_S))
            return False
        track = parts.tracker.get(choice.item_id)
        if track is None:
            allowed = "the id of an item offered now (episode.candidates())"
            raise InvalidInput("choice.item_id", allowed, choice.item_id)
        x = track.x_at(t, parts.speed)
        intercept = robot.plan(x, track.y, choice.bin_class)
        parts.timings.add("planning", time.perf_counter() - t1, "plan")
        if not intercept.feasible:
            # Not now: offered again shortly (the tracker prunes it once it is past the robot).
            parts.offers.retry_after(track.track_id, t + RETRY_AFTER_S)
            return False
        if intercept.meet_time > MAX_LEAD_S + WAIT_STEP_S:
            station.decide_at(t + WAIT_STEP_S)  # the cycle model was optimistic: wait
            return False
        parts.tracker.remove(track.track_id)  # no other robot is offered it now
        # The thesis's distance of the pick (rest -> item -> bin, in the belt's plane) [m].
        meet_xy = intercept.pick_xyz[:2]
        drop_xy = np.asarray(station.context.bin_of(choice.bin_class)[:2], dtype=float)
        travel = float(np.linalg.norm(meet_xy - robot.rest[:2]) + np.linalg.norm(drop_xy - meet_xy))
        pick = PickUnderWay(track, choice, station.energy.reading(), travel, t)
        robot.start(intercept, -1 if track.true_id is None else int(track.true_id))
        parts.metrics.on_pick_started(station.index, t)
        path = None
        if parts.riding.in_window:
            assert intercept.plan is not None  # a feasible intercept has its plan
            path = PlannedPath.of(intercept.plan.chain, t, *station.path_reach)
        station.start(pick, path)
        if path is not None:
            parts.riding.wake_on_path(self.data, path, parts.speed)
        return True

    def run(self) -> None:
        """Simulate until the episode ends, the configured decision manager choosing."""
        while self.step_until_decision():
            self.apply(self.choose())

    # ----- stepping -----------------------------------------------------------------------------

    def _step(self) -> None:
        """While a pick is under way, a chunk of steps up to the next event or idle robot's
        decision (`sim.episode.chunks`; one step at a time with a user's step hooks), else one
        block of steps up to the next event or decision; then the events due, finished picks."""
        parts = self._ready()
        busy = [s for s in parts.stations if s.robot.busy]
        parts.clock.stepping(busy)
        if busy and not self._user_hooks:
            t, dt = self.data.time, self._timestep
            idle = [s.next_decision for s in parts.stations if not s.robot.busy]
            when = min([self.scheduler.next_due(t), *idle])
            steps = chunks.steps_until_due_stepwise(t, when, dt, chunks.MAX_CHUNK_STEPS)
            robots = [s.robot for s in busy]
            chunks.step_busy(self.model, self.data, robots, parts.actuator_log, parts.riding, steps)
            parts.clock.stepped(dt)
        else:
            self.hooks.run("before_step", parts)
            nstep = 1 if busy else self._idle_steps()
            mujoco.mj_step(self.model, self.data, nstep=nstep)
            parts.clock.stepped(nstep * self._timestep)
            self.hooks.run("after_step", parts)
        self.scheduler.fire_due(parts, self.data.time, self.cell.items.current)
        if busy:
            for station in busy:
                outcome = station.robot.poll()
                if outcome is not None:  # booked; the robot decides again at once
                    stations.book_pick(station, outcome, parts.flow, parts.offers, parts.metrics)
                    station.decide_at(self.data.time)
            return
        t = self.data.time
        if self.progress is not None and t - self._last_report >= 1.0:
            self._last_report = t
            self.progress(min(t / parts.timeline.t_end, 1.0), parts.metrics.status_line(t))

    def _idle_steps(self) -> int:
        """Physics steps until the next event or decision while every robot idles."""
        t, dt = self.data.time, self.model.opt.timestep
        decisions = (s.next_decision for s in self._ready().stations)
        return steps_until_due(t, min(self.scheduler.next_time(t), *decisions), dt)

    def _finished(self) -> bool:
        parts = self._ready()
        timeline = parts.timeline
        if timeline.at_horizon:
            return True
        if any(s.robot.busy for s in parts.stations):  # a pick under way is always finished
            return False
        t = self.data.time
        if t >= timeline.t_cap:
            return True
        if parts.infeed.pending or len(self.cell.items.active_slots()):
            return False
        return t >= timeline.t_last_spawn + SETTLE_S

    def _close_out(self) -> None:
        """Items still in play count as missed at the time cap, as left on the belt at the
        horizon (once)."""
        if self._closed_out:
            return
        self._closed_out = True
        parts = self._ready()
        parts.metrics.on_warnings(parts.mj_warnings.update())
        item_checks.book_unsure(parts, parts.tracker.tracks())  # still tracked at the end
        items, metrics = self.cell.items, parts.metrics
        book = metrics.on_left_on_belt if parts.timeline.at_horizon else metrics.on_missed
        for slot in items.active_slots():
            book(int(items.park(int(slot))))
