"""The loop of one episode: the only place that steps the physics while an episode runs.

In the manner of dm_control's `Environment.step` with composer's hook lists. While robots play
their picks the physics runs in chunks up to the next event or idle robot's decision, each step
with its own work only (set-points, actuator log, riders' belt time, cups: `sim.episode.chunks`);
while every robot idles, in one block. After each chunk or block every scheduled event due fires
(`sim.episode.scheduler`: drops at the infeed, observations, the item checks of
`sim.episode.item_checks`, video frames, a user's `every`), then finished picks are booked. A
user's `add_hook("after_step" | "before_step", fn)` runs around every step (the loop then steps
one at a time, with the episode's own hooks of `sim.episode.step_hooks`).

`step_until_decision` advances until a robot is free and a choice is needed; `apply` takes the
choice (the configured decision manager's in `run`, or a Gymnasium agent's). The episode ends
when every item has been dropped and left the belt and every robot is idle, or at the config's
`horizon_s` (`builder.Timeline.horizon`). Its parts are made by `sim.episode.builder`.
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
from sim.cell.held_slots import held_slots
from sim.cell.riding import PlannedPath
from sim.config import EpisodeConfig
from sim.episode import builder, chunks, item_checks, stations, step_hooks
from sim.episode.builder import CHECK_PERIOD_S, SETTLE_S, make_decision_manager
from sim.episode.infeed import Infeed
from sim.episode.overlay import overlay_of
from sim.episode.pick_control import PickController
from sim.episode.scheduler import (
    FrameEvent,
    Hooks,
    PeriodicEvent,
    Scheduler,
    is_due,
    steps_until_due,
)
from sim.episode.stations import RobotStation, StartedPick
from sim.monitors.energy import ActuatorLog, EnergyMeter
from sim.monitors.mj_warnings import WarningCounter
from sim.monitors.thrown import ThrowWatch
from sim.results.metrics import EpisodeMetrics
from sim.sensing.confidence import is_unsure
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
    `run()` is that loop with the configured decision manager choosing.

    Args:
        config: The episode's configuration.
        cell: The compiled cell it runs on (reset by `reset`).
        video: A frame sink (`sim.render.sink.FrameSink`: the video recorder, the live view),
            or None.
        progress: Called with (fraction, status line) about once per simulated second.
        planner: A decision manager object (`choose`, `reset`); the config's when omitted.
    """

    def __init__(self, config: EpisodeConfig, cell: Cell, video=None, progress=None, planner=None):
        self.config, self.cell, self.video, self.progress = config, cell, video, progress
        self.model, self.data = cell.model, cell.data
        self.planner = planner if planner is not None else make_decision_manager(config)
        self.stations: list[RobotStation] = []
        self._deciding: RobotStation | None = None
        self._ready = False
        self._user_hooks: list[tuple[str, Callable]] = []
        self._user_events: list[PeriodicEvent] = []
        self.hooks, self.scheduler = Hooks(), Scheduler()

    # ----- registration -------------------------------------------------------------------------

    def add_hook(self, stage: str, fn: Callable[[Episode], object]) -> None:
        """Run `fn(episode)` before or after every physics step (a block of steps while every
        robot idles), after the episode's own hooks; kept across resets. The loop then steps
        one at a time while picks are under way, instead of in chunks (`sim.episode.chunks`).

        Args:
            stage: "before_step" or "after_step".
            fn: Called with the episode.
        """
        Hooks().add(stage, fn)  # refused here, before anything is registered
        self._user_hooks.append((stage, fn))
        if self._ready:
            self.hooks.add(stage, fn)

    def every(self, period_s: float, fn: Callable[[Episode], object]) -> PeriodicEvent:
        """Call `fn(episode)` every `period_s` [s] of simulated time, from the start of each
        episode (or from now, registered during one), after the episode's own events due then;
        kept across resets. Returns the event (its `next_s` says when it is due next).

        Args:
            period_s: The period [s], > 0.
            fn: Called with the episode.
        """
        event = PeriodicEvent(period_s, fn, float(self.data.time) if self._ready else 0.0)
        self._user_events.append(event)
        if self._ready:
            self.scheduler.add(event)
        return event

    # ----- the deciding robot's parts -----------------------------------------------------------

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
        """The first robot's motor energy meter (the line's: `stations`)."""
        return self.stations[0].energy

    @property
    def current_pick(self):
        """The track the first robot is picking (None when idle)."""
        return self.stations[0].current_pick if self.stations else None

    def _station(self) -> RobotStation:
        return self._deciding if self._deciding is not None else self.stations[0]

    def __enter__(self) -> Episode:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close(aborted=exc_type is not None)

    # ----- lifecycle ----------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> None:
        """Start the episode afresh: the cell reset, the flow of `seed` (the config's when
        None), every counter at zero, the decision manager reset, the hooks and events
        registered again (a user's kept, due from the start)."""
        config = self.config if seed is None else replace(self.config, seed=int(seed))
        self.config, cell = config, self.cell
        builder.check_cell(cell, config)
        self.speed = config.belt_speed_mps
        cell.reset(self.speed)
        self.flow = builder.episode_flow(config, cell)
        self.timeline = builder.Timeline.of(cell, self.flow, self.speed, config.horizon_s)
        self.x_discard, self.t_end = self.timeline.x_discard, self.timeline.t_end
        self.metrics: EpisodeMetrics = builder.episode_metrics(config, cell, self.flow)
        self.tracker = Tracker(self.speed)
        controllers = builder.pick_controllers(config, cell, self.flow)
        self.bins = item_checks.episode_bins(cell)
        radius = builder.largest_item_radius(cell, self.flow)
        self.riding = builder.item_riding(config, cell, radius)
        cell.items.ride(self.riding)
        # MuJoCo's warning counts start at zero (the reset above clears them).
        self.mj_warnings = WarningCounter(self.data)
        self.throw_watch = ThrowWatch(self.model, cell.pool)
        self._timestep = float(self.model.opt.timestep)  # [s]
        self.last_step_s = 0.0
        """Duration of the last physics step, or block of steps [s]."""
        self.actuator_log = ActuatorLog(self.data)  # read by every robot's energy meter
        self.stations = builder.robot_stations(
            config, cell, controllers, self.planner, radius, self.actuator_log
        )
        self._deciding = None
        self.perception = builder.perception(config, cell, self.flow)
        self.infeed = Infeed(cell.items, self.flow, config.belt.infeed_hold)
        self.failures: dict[int, int] = {}  # failed attempts per true item id (truth mode)
        self.not_before: dict[int, float] = {}  # track id -> when it may be offered again [s]
        self.timings = dict.fromkeys(
            ("physics", "perception", "decision", "planning", "video"), 0.0
        )
        self.decisions = 0
        self.latencies: dict[str, list[float]] = {"perception": [], "decision": [], "plan": []}
        self._candidates: list[TrackedItem] = []
        # track id -> (its probabilities, its item) as `offerable_items` last made them
        self.track_items: dict[int, tuple[np.ndarray, TrackedItem]] = {}
        self.busy: list[RobotStation] = []
        self._last_report = -1.0
        self._closed_out = False
        self._register()
        self._ready = True

    def _register(self) -> None:
        """The episode's own hooks and events, then a user's."""
        self.hooks, self.scheduler = Hooks(), Scheduler()
        for fn in step_hooks.BEFORE_STEP:
            self.hooks.add("before_step", fn)
        for fn in step_hooks.AFTER_STEP:
            self.hooks.add("after_step", fn)
        self.scheduler.add(self.infeed)
        builder.add_observations(self.scheduler, self)  # perception, visibility monitor
        self.scheduler.add(PeriodicEvent(CHECK_PERIOD_S, item_checks.run_checks))
        if self.video is not None:
            self.scheduler.add(FrameEvent(self.video, overlay_of))
        for stage, fn in self._user_hooks:
            self.hooks.add(stage, fn)
        for event in self._user_events:
            event.next_s = 0.0
            self.scheduler.add(event)
        if self.timeline.horizon is not None:  # last: what is due at the horizon goes first
            self.scheduler.add(self.timeline.horizon)

    def close(self, aborted: bool = False) -> None:
        """Release the perception's renderer and finish (or, `aborted`, discard) the video."""
        perception = getattr(self, "perception", None)
        if perception is not None:
            perception.close()
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
        if not self._ready:
            self.reset()
        self._deciding = None
        while not self._finished():
            t = self.data.time
            items = None  # the tracked items now, once for every robot free now
            for station in self.stations:
                if not station.robot.busy and is_due(t, station.next_decision):
                    station.next_decision = t + DECIDE_PERIOD_S
                    if items is None:
                        items = stations.offerable_items(self, t)
                    self._candidates = stations.line_offer(
                        self.stations,
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
        readings = [s.energy.reading() for s in self.stations]
        self.metrics.on_energy(*(sum(r[i] for r in readings) for i in (0, 1)))
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
        dt = time.perf_counter() - t0
        self.timings["decision"] += dt
        self.latencies["decision"].append(dt)
        self.decisions += 1
        return choice

    def apply(self, choice: Choice | None) -> bool:
        """Act on a choice: start the pick when the cup can meet the item soon, else wait and
        decide again later (None: nothing now). True if a pick started."""
        t = float(self.data.time)
        t1 = time.perf_counter()
        if choice is None:
            return False
        station = self._station()
        robot = station.robot
        if choice.meet_time - t > MAX_LEAD_S:
            # Far upstream: wait where we are and decide again with fresher positions.
            station.next_decision = t + min(choice.meet_time - t - MAX_LEAD_S, WAIT_STEP_S)
            return False
        track = self.tracker.get(choice.item_id)
        x = track.x_at(t, self.speed)
        intercept = robot.plan(x, track.y, choice.bin_class)
        self.timings["planning"] += time.perf_counter() - t1
        self.latencies["plan"].append(time.perf_counter() - t1)
        if not intercept.feasible:
            # Not now: offered again shortly (the tracker prunes it once it is past the robot).
            self.not_before[track.track_id] = t + RETRY_AFTER_S
            return False
        if intercept.meet_time > MAX_LEAD_S + WAIT_STEP_S:
            station.next_decision = t + WAIT_STEP_S  # the cycle model was optimistic: wait
            return False
        self.tracker.remove(track.track_id)  # no other robot is offered it now
        # The thesis's distance of the pick (rest -> item -> bin, in the belt's plane) [m].
        meet_xy = intercept.pick_xyz[:2]
        drop_xy = np.asarray(station.context.bin_of(choice.bin_class)[:2], dtype=float)
        travel = float(np.linalg.norm(meet_xy - robot.rest[:2]) + np.linalg.norm(drop_xy - meet_xy))
        station.pick = StartedPick(track, choice, station.energy.reading(), travel, t)
        robot.start(intercept, -1 if track.true_id is None else int(track.true_id))
        station.path = None
        if self.riding.in_window:
            station.path = PlannedPath.of(intercept.plan.chain, t, *station.path_reach)
            self.riding.wake_on_path(self.data, station.path, self.speed)
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
        busy = [s for s in self.stations if s.robot.busy]
        self.busy = busy
        if busy and not self._user_hooks:
            t, dt = self.data.time, self._timestep
            idle = [s.next_decision for s in self.stations if not s.robot.busy]
            when = min([self.scheduler.next_due(t), *idle])
            steps = chunks.steps_until_due_stepwise(t, when, dt, chunks.MAX_CHUNK_STEPS)
            robots = [s.robot for s in busy]
            chunks.step_busy(self.model, self.data, robots, self.actuator_log, self.riding, steps)
            self.last_step_s = dt
        else:
            self.hooks.run("before_step", self)
            nstep = 1 if busy else self._idle_steps()
            mujoco.mj_step(self.model, self.data, nstep=nstep)
            self.last_step_s = nstep * self._timestep
            self.hooks.run("after_step", self)
        self._fire_due()
        if busy:
            for station in busy:
                outcome = station.robot.poll()
                if outcome is not None:  # booked; the robot decides again at once
                    stations.book_pick(self, station, outcome)
                    station.next_decision = self.data.time
            return
        t = self.data.time
        if self.progress is not None and t - self._last_report >= 1.0:
            self._last_report = t
            self.progress(min(t / self.t_end, 1.0), self.metrics.status_line(t))

    def _fire_due(self) -> None:
        """Every event due now, in order, each seeing the items where they are now."""
        self.scheduler.fire_due(self, self.data.time, self.cell.items.current)

    def _idle_steps(self) -> int:
        """Physics steps until the next event or decision while every robot idles."""
        t, dt = self.data.time, self.model.opt.timestep
        when = min(self.scheduler.next_time(t), *(s.next_decision for s in self.stations))
        return steps_until_due(t, when, dt)

    def sink_frame(self, sink, overlay) -> None:
        """Hand `sink` a frame of the cell as it is now with `overlay` (timed)."""
        t0 = time.perf_counter()
        sink.capture(self.cell.items.current(), overlay)
        self.timings["video"] += time.perf_counter() - t0

    def held(self) -> np.ndarray:
        """The pool slots the robots' cups hold now, robot by robot (`sim.cell.held_slots`)."""
        return held_slots(s.robot.suction.held_slot for s in self.stations)

    def observe(self) -> None:
        """The perception's detections now, handed to the tracker (timed); new tracks booked
        against the true items (`never_detected`)."""
        t = self.data.time
        t0 = time.perf_counter()
        self.cell.items.kinematics()
        created = self.tracker.update(self.perception.observe(t))
        dt = time.perf_counter() - t0
        self.timings["perception"] += dt
        self.latencies["perception"].append(dt)
        item_checks.attribute(self, created, t)

    def robot_columns(self, sim_s: float) -> dict[str, object]:
        """A line's episodes.csv columns (`sim.episode.stations.robot_columns`)."""
        coordination = self.config.coordination
        return stations.robot_columns(self.stations, self.metrics, coordination, sim_s)

    def book_unsure(self, gone: list) -> None:
        """Count the tracks among `gone` (went past the robot unpicked, or still tracked at the
        end) that the confidence rule kept from the decision manager (`left_unsure`)."""
        threshold = self.config.applied_min_class_confidence
        self.metrics.on_left_unsure(sum(1 for tr in gone if is_unsure(tr.probs, threshold)))

    def _finished(self) -> bool:
        if self.timeline.at_horizon:
            return True
        if any(s.robot.busy for s in self.stations):  # a pick under way is always finished
            return False
        t = self.data.time
        if t >= self.timeline.t_cap:
            return True
        if self.infeed.pending or len(self.cell.items.active_slots()):
            return False
        return t >= self.timeline.t_last_spawn + SETTLE_S

    def _close_out(self) -> None:
        """Items still in play count as missed at the time cap, as left on the belt at the
        horizon (once)."""
        if self._closed_out:
            return
        self._closed_out = True
        self.metrics.on_warnings(self.mj_warnings.update())
        self.book_unsure(self.tracker.tracks())  # still tracked when the episode ended
        items = self.cell.items
        book = self.metrics.on_left_on_belt if self.timeline.at_horizon else self.metrics.on_missed
        for slot in items.active_slots():
            book(int(items.park(int(slot))))
